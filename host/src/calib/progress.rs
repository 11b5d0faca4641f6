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

/// Progress nobody watches.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn begin(&self, _label: &str, _len: u64) {}
    fn advance(&self, _units: u64) {}
    fn end(&self) {}
}
