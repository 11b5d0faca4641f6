//! How the engine tells its caller how far a long step has come, without
//! knowing whether anyone is watching: the commands show a terminal bar, tests
//! and benches pass [`Silent`].

/// Receives the engine's progress. A step begins, advances unit by unit and
/// ends; steps do not nest (an inner loop of a step reports nothing).
pub trait Progress {
    /// A step named `label` of `len` units begins.
    fn begin(&self, label: &str, len: u64);
    /// `units` more units of the current step are done.
    fn advance(&self, units: u64);
    /// The current step is over.
    fn end(&self);
}

/// `f` of each of `items`, on rayon's threads, in `items`' order, advancing
/// `progress` by one as each call ends, from the calling thread (so the
/// caller's progress need not be shareable between threads). `None` when a
/// call panicked.
///
/// Called from one of rayon's threads (a parallel step inside another), it
/// runs the calls there and reports them all at the end: a rayon thread
/// that waited for another thread's parallel work could leave the pool
/// with no thread to do it.
pub fn par_map<T: Sync, R: Send>(
    items: &[T],
    f: impl Fn(&T) -> R + Sync,
    progress: &dyn Progress,
) -> Option<Vec<R>> {
    use rayon::prelude::*;
    if rayon::current_thread_index().is_some() {
        let out = items.par_iter().map(&f).collect();
        progress.advance(items.len() as u64);
        return Some(out);
    }
    let (done, finished) = std::sync::mpsc::channel::<()>();
    std::thread::scope(|scope| {
        let f = &f;
        let worker = scope.spawn(move || {
            items
                .par_iter()
                .map_with(done, |done, item| {
                    let out = f(item);
                    // The receiver only goes away once every call is over.
                    let _ = done.send(());
                    out
                })
                .collect::<Vec<_>>()
        });
        for () in finished {
            progress.advance(1);
        }
        worker.join().ok()
    })
}

/// Progress nobody watches.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn begin(&self, _label: &str, _len: u64) {}
    fn advance(&self, _units: u64) {}
    fn end(&self) {}
}
