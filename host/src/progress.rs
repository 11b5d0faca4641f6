//! Progress of long commands, on stderr: a bar on a terminal, plain lines
//! when stderr is a pipe or a log file (a bar would be dropped there, and
//! the lines a command prints above it with it).
//!
//! In a log a step says where it is at most every [`PLAIN_EVERY`], and
//! when it ends if it took that long: a 20-minute measurement leaves a
//! line a few seconds apart, a step of a second leaves none.
//!
//! [`Meter`] is one step a command counts itself (poses measured, bytes
//! sent); [`Steps`] draws the engine's steps (`calib::progress::Progress`)
//! with a meter each.

use std::cell::{Cell, RefCell};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

use lrmcal_engine::calib::progress::Progress;

/// How often a step writes a line in a log, at most.
pub const PLAIN_EVERY: Duration = Duration::from_secs(5);

/// The one bar style: label, bar, count with its unit, time so far.
const STYLE: &str = "{msg:<40} [{bar:30}] {pos}/{len} {prefix} {elapsed}";

/// One counted step: a bar on a terminal, plain lines in a log.
pub struct Meter {
    shown: Shown,
    /// How often a line is written in a log, at most.
    every: Duration,
    unit: &'static str,
    label: RefCell<String>,
    len: Cell<u64>,
    pos: Cell<u64>,
    start: Instant,
    last_line: Cell<Instant>,
}

enum Shown {
    Bar(ProgressBar),
    /// Lines on stderr.
    Lines,
    /// Lines kept, for the tests.
    #[cfg(test)]
    Kept(RefCell<Vec<String>>),
}

impl Meter {
    /// A step of `len` units called `unit` (`poses`, `bytes`; empty when the
    /// label says it), labelled `label`.
    pub fn new(label: &str, len: u64, unit: &'static str) -> Self {
        let shown = if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(len).with_prefix(unit);
            if let Ok(style) = ProgressStyle::with_template(STYLE) {
                bar.set_style(style);
            }
            bar.set_message(label.to_owned());
            Shown::Bar(bar)
        } else {
            Shown::Lines
        };
        let now = Instant::now();
        Self {
            shown,
            every: PLAIN_EVERY,
            unit,
            label: RefCell::new(label.to_owned()),
            len: Cell::new(len),
            pos: Cell::new(0),
            start: now,
            last_line: Cell::new(now),
        }
    }

    /// Renames the step (`pose 17`).
    pub fn set_label(&self, label: &str) {
        if let Shown::Bar(bar) = &self.shown {
            bar.set_message(label.to_owned());
        }
        *self.label.borrow_mut() = label.to_owned();
    }

    /// Sets how many units the step has.
    pub fn set_length(&self, len: u64) {
        if let Shown::Bar(bar) = &self.shown {
            bar.set_length(len);
        }
        self.len.set(len);
    }

    /// Sets how many units are done.
    pub fn set_position(&self, pos: u64) {
        if let Shown::Bar(bar) = &self.shown {
            bar.set_position(pos);
        }
        self.pos.set(pos);
        self.maybe_line();
    }

    /// Counts `units` more done.
    pub fn inc(&self, units: u64) {
        self.set_position(self.pos.get() + units);
    }

    /// Prints `line` on stderr above the bar (or as it is, in a log).
    pub fn println(&self, line: &str) {
        match &self.shown {
            Shown::Bar(bar) => bar.println(line),
            _ => self.line(line.to_owned()),
        }
    }

    /// Writes `line` where the plain lines go.
    fn line(&self, line: String) {
        match &self.shown {
            Shown::Bar(_) => {}
            Shown::Lines => eprintln!("{line}"),
            #[cfg(test)]
            Shown::Kept(lines) => lines.borrow_mut().push(line),
        }
    }

    /// Runs `f` with the bar out of the way (a prompt on the terminal).
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.shown {
            Shown::Bar(bar) => bar.suspend(f),
            _ => f(),
        }
    }

    /// Ends the step: the bar is cleared; in a log, a last line if the step
    /// took [`PLAIN_EVERY`] or more.
    pub fn finish(&self) {
        match &self.shown {
            Shown::Bar(bar) => bar.finish_and_clear(),
            _ if self.start.elapsed() >= self.every => self.line(format!(
                "{} in {:.1} s",
                self.count(),
                self.start.elapsed().as_secs_f64()
            )),
            _ => {}
        }
    }

    /// `label: pos/len unit`.
    fn count(&self) -> String {
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        format!(
            "{}: {}/{}{unit}",
            self.label.borrow(),
            self.pos.get(),
            self.len.get()
        )
    }

    /// In a log, a line if the last one is `every` old.
    fn maybe_line(&self) {
        // The last unit's line is the one `finish` writes.
        if !matches!(self.shown, Shown::Bar(_))
            && self.pos.get() < self.len.get()
            && self.last_line.get().elapsed() >= self.every
        {
            self.last_line.set(Instant::now());
            self.line(format!(
                "{} ({:.0} s so far)",
                self.count(),
                self.start.elapsed().as_secs_f64()
            ));
        }
    }
}

/// The engine's progress: a [`Meter`] for each of its steps, with the step's
/// label and length, ended when the step ends.
#[derive(Default)]
pub struct Steps(RefCell<Option<Meter>>);

impl Steps {
    /// No meter until a step begins.
    pub fn new() -> Self {
        Self::default()
    }
}

impl Progress for Steps {
    fn begin(&self, label: &str, len: u64) {
        if let Some(previous) = self.0.replace(Some(Meter::new(label, len, ""))) {
            previous.finish();
        }
    }

    fn advance(&self, units: u64) {
        if let Some(meter) = self.0.borrow().as_ref() {
            meter.inc(units);
        }
    }

    fn end(&self) {
        if let Some(meter) = self.0.take() {
            meter.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A meter whose plain lines are kept, written at most every `every`.
    fn kept(label: &str, len: u64, unit: &'static str, every: Duration) -> Meter {
        let now = Instant::now();
        Meter {
            shown: Shown::Kept(RefCell::new(Vec::new())),
            every,
            unit,
            label: RefCell::new(label.to_owned()),
            len: Cell::new(len),
            pos: Cell::new(0),
            start: now,
            last_line: Cell::new(now),
        }
    }

    fn lines(meter: &Meter) -> Vec<String> {
        match &meter.shown {
            Shown::Kept(lines) => lines.borrow().clone(),
            _ => unreachable!("a kept meter"),
        }
    }

    #[test]
    fn a_log_gets_a_line_per_period_and_a_closing_one() {
        // Every unit is a period late: a line each, but the last unit's,
        // whose line is the closing one.
        let meter = kept("measuring", 3, "poses", Duration::ZERO);
        meter.set_label("pose 7");
        meter.println("pose 7: 20 frames");
        for _ in 0..3 {
            meter.inc(1);
        }
        meter.finish();
        let lines = lines(&meter);
        assert_eq!(lines.len(), 4, "{lines:?}");
        assert_eq!(lines[0], "pose 7: 20 frames");
        assert!(lines[1].starts_with("pose 7: 1/3 poses ("), "{lines:?}");
        assert!(lines[2].starts_with("pose 7: 2/3 poses ("), "{lines:?}");
        assert!(lines[3].starts_with("pose 7: 3/3 poses in "), "{lines:?}");
    }

    #[test]
    fn a_short_step_leaves_nothing_in_a_log() {
        let meter = kept("elasto-kinematic: DETMAX starts", 8, "", PLAIN_EVERY);
        meter.inc(8);
        meter.finish();
        assert!(lines(&meter).is_empty());
    }
}
