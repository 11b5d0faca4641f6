//! Where `measure` takes each position from: a live DTrack stream, read
//! once the arm holds still, or text lines from a file, a pipe or the
//! keyboard.

use std::io::{BufRead, Write};
use std::time::Duration;

use nalgebra::Vector3;

use crate::error::Error;
use crate::progress::Meter;
use lrmcal_engine::tracker::listen::Listener;
use lrmcal_engine::tracker::text::parse_tracker_line;
use lrmcal_engine::tracker::{SettleOptions, Target};

/// Where tracker positions come from.
pub(super) enum Tracker {
    Text(Text),
    DTrack {
        listener: Listener,
        target: Target,
        options: SettleOptions,
        timeout: Duration,
    },
}

/// Positions as text lines.
pub(super) enum Text {
    Lines(Box<dyn BufRead>, String),
    Typed,
}

impl Tracker {
    /// The next position for `pose`.
    pub(super) fn next(&mut self, pose: u32, bar: &Meter) -> Result<Vector3<f64>, Error> {
        match self {
            Tracker::Text(text) => text.next(pose, bar),
            Tracker::DTrack {
                listener,
                target,
                options,
                timeout,
            } => {
                let r = listener.read(*target, *options, *timeout)?;
                bar.println(&format!(
                    "pose {pose}: {} frames {}..{}, spread {:.3} mm, {} lost",
                    r.frames,
                    r.frame_range.0,
                    r.frame_range.1,
                    r.spread_m * 1e3,
                    r.lost
                ));
                Ok(r.position)
            }
        }
    }
}

impl Text {
    /// The next position for `pose`.
    pub(super) fn next(&mut self, pose: u32, bar: &Meter) -> Result<Vector3<f64>, Error> {
        loop {
            let mut line = String::new();
            let (n, source) = match self {
                Text::Lines(r, name) => (r.read_line(&mut line), name.clone()),
                Text::Typed => bar.suspend(|| {
                    print!("pose {pose}: tracker x y z (mm)? ");
                    let _ = std::io::stdout().flush();
                    (
                        std::io::stdin().lock().read_line(&mut line),
                        "the keyboard".to_owned(),
                    )
                }),
            };
            let read_failed = |reason: String| Error::DeviceInput {
                what: format!("read a tracker position from {source}"),
                reason,
            };
            if n.map_err(|e| read_failed(e.to_string()))? == 0 {
                return Err(read_failed(format!(
                    "it ended before pose {pose}; the poses so far are saved"
                )));
            }
            match parse_tracker_line(&line) {
                Ok(None) => continue,
                Ok(Some((Some(named), _))) if named != pose => {
                    return Err(read_failed(format!(
                        "the line names pose {named} but the arm is at pose {pose}"
                    )));
                }
                Ok(Some((_, p))) => return Ok(p),
                Err(reason) if matches!(self, Text::Typed) => bar.suspend(|| eprintln!("{reason}")),
                Err(reason) => return Err(read_failed(reason)),
            }
        }
    }
}
