//! `lrmcal servo-tune`: level-1 calibration at the terminal, the quick start
//! before any identification. Jog one servo's pulse until the protractor
//! reads each of the tuning angles (by default -100°, -50°, 0°, +50°, +100°),
//! record each, and write the curve through them into the arm file and onto
//! the board.

use protocol::CHANNELS;
use std::path::PathBuf;

use crossterm::event::{self, Event, KeyCode, KeyEvent, KeyEventKind};
use crossterm::terminal;
use model::ServoCurve;
use model::servo::{KnotCount, PULSE_RANGE_US};

use crate::commands::device_args::DeviceArgs;
use crate::error::Error;
use lrmcal_core::io::arm_toml;
use lrmcal_engine::device::{Client, ClientError, Link, calibration};

/// Tune one servo's pulse curve interactively.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Example:\n  lrmcal servo-tune 3 --arm my_arm.toml --port /dev/ttyACM0\n\n\
Keys: ←/→ 1 µs, ↓/↑ 10 µs, PgDn/PgUp 100 µs; 1 … N record the pulse as the N tuning angles \
from -100° to +100° (with the default 5 points: 1 = -100°, 2 = -50°, 3 = 0°, 4 = +50°, \
5 = +100°); w writes the curve to the arm file (and to the board's calibration, if it has \
one); q quits and leaves the servo limp. The board clamps every pulse to its safe range. \
Points not recorded keep the pulse the arm file's curve gives at their angle."
)]
pub struct Args {
    /// Joint (servo channel) 1..6.
    #[arg(value_parser = clap::value_parser!(u8).range(1..=CHANNELS as i64))]
    pub joint: u8,
    /// Tuning angles, evenly spaced from -100° to +100° (3 to 9; odd counts include 0°).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u8).range(3..=9))]
    pub points: u8,
    /// Arm description (TOML) whose `servo` curve of this joint is rewritten.
    #[arg(long, value_name = "FILE")]
    pub arm: PathBuf,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// What a key asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// Put this pulse on the servo, µs.
    Pulse(u16),
    /// Nothing to send.
    Nothing,
    /// Write the curve.
    Write(ServoCurve<f64>),
    /// Leave.
    Quit,
}

/// The tuning session's state: the pulse now and the curve through the tuning angles.
#[derive(Clone, Debug, PartialEq)]
pub struct Tuning {
    /// Pulse on the servo, µs.
    pub pulse_us: u16,
    /// The curve being built: a knot at each tuning angle, starting with the
    /// pulses the arm file's curve gives there.
    pub curve: ServoCurve<f64>,
    /// Which knots were recorded in this session.
    pub recorded: Vec<bool>,
    /// Last message for the user.
    pub note: String,
}

/// `points` angles evenly spaced from -100° to +100°, degrees.
pub fn tuning_angles_deg(points: usize) -> Vec<f64> {
    let last = points.saturating_sub(1).max(1) as f64;
    (0..points)
        .map(|k| -100.0 + 200.0 * k as f64 / last)
        .collect()
}

/// An angle as the prompt shows it: `-100°`, `0°`, `+50°`, `-33.3°`.
fn label(deg: f64) -> String {
    if deg == 0.0 {
        "0°".into()
    } else if deg.fract() == 0.0 {
        format!("{deg:+}°")
    } else {
        format!("{deg:+.1}°")
    }
}

impl Tuning {
    /// Starts from `curve` (the arm file's) resampled at `points` tuning
    /// angles, at its 0° pulse.
    pub fn new(curve: ServoCurve<f64>, points: usize) -> Result<Self, KnotCount> {
        let angles: Vec<f64> = tuning_angles_deg(points)
            .iter()
            .map(|d| d.to_radians())
            .collect();
        let curve = curve.resampled(&angles)?;
        Ok(Self {
            pulse_us: curve.pulse_us(0.0).round().clamp(0.0, 65535.0) as u16,
            curve,
            recorded: vec![false; points],
            note: String::new(),
        })
    }

    /// Why the curve cannot be written yet, if it cannot.
    fn unwritable(&self) -> Option<String> {
        if !self.curve.is_monotonic() {
            return Some("not written: the pulses must run one way".into());
        }
        let [lo, hi] = PULSE_RANGE_US.map(f64::from);
        let outside = self
            .curve
            .pulses_us()
            .iter()
            .position(|p| !(lo..=hi).contains(p))?;
        Some(format!(
            "not written: point {} lies outside {lo}..{hi} µs; record it",
            outside + 1
        ))
    }

    /// Applies one key.
    pub fn key(&mut self, code: KeyCode) -> Action {
        let step = |s: &mut Self, d: i32| {
            s.pulse_us = (s.pulse_us as i32 + d).clamp(0, 65535) as u16;
            Action::Pulse(s.pulse_us)
        };
        match code {
            KeyCode::Left => step(self, -1),
            KeyCode::Right => step(self, 1),
            KeyCode::Down => step(self, -10),
            KeyCode::Up => step(self, 10),
            KeyCode::PageDown => step(self, -100),
            KeyCode::PageUp => step(self, 100),
            KeyCode::Char(c @ '1'..='9') if usize::from(c as u8 - b'1') < self.recorded.len() => {
                let k = usize::from(c as u8 - b'1');
                let p = f64::from(self.pulse_us);
                self.curve.pulses_us_mut()[k] = p;
                self.recorded[k] = true;
                let deg = tuning_angles_deg(self.recorded.len())[k];
                self.note = format!("recorded {p} µs as {}", label(deg));
                Action::Nothing
            }
            KeyCode::Char('w') => match self.unwritable() {
                None => Action::Write(self.curve),
                Some(why) => {
                    self.note = why;
                    Action::Nothing
                }
            },
            KeyCode::Char('q') | KeyCode::Esc => Action::Quit,
            _ => Action::Nothing,
        }
    }

    fn line(&self, joint: u8) -> String {
        let points: Vec<String> = tuning_angles_deg(self.recorded.len())
            .iter()
            .zip(self.curve.pulses_us())
            .zip(&self.recorded)
            .map(|((&deg, p), &rec)| {
                format!("{}: {p:.0}{}", label(deg), if rec { "*" } else { " " })
            })
            .collect();
        format!(
            "\rjoint {joint}: {:>5} µs | {} | {}\x1b[K",
            self.pulse_us,
            points.join(" "),
            self.note
        )
    }
}

/// Writes `curve` into the board's calibration, if it has one; says what happened.
fn write_to_board<L: Link>(
    client: &mut Client<L>,
    joint: usize,
    curve: ServoCurve<f64>,
) -> Result<String, Error> {
    let mut c = match client.pull_calibration() {
        Ok(c) => c,
        Err(ClientError::Endpoint {
            error: protocol::WireError::NoCalibration,
            ..
        }) => {
            return Ok("board has no calibration: push one to use the curve there".into());
        }
        Err(e) => return Err(e.into()),
    };
    c.calibrated.joints[joint].servo = Some(curve.map(|x| x as f32));
    let c = calibration::identified(c).map_err(|f| Error::DeviceInput {
        what: "put the new curve into the board's calibration".into(),
        reason: f.to_string(),
    })?;
    client.push_calibration(&c, |_, _| {})?;
    Ok(format!("board calibration updated ({:08x})", c.id))
}

/// Runs `lrmcal servo-tune`.
pub fn run(args: &Args) -> Result<(), Error> {
    let description = arm_toml::read(&args.arm)?;
    let j = (args.joint - 1) as usize;
    let Some(start) = description.arm.joints[j].servo else {
        return Err(Error::DeviceInput {
            what: format!("tune joint {} of `{}`", args.joint, args.arm.display()),
            reason: format!(
                "joint {} (`{}`) has no `servo` table, so the arm file says the board does not \
                 drive it; to drive it, add a starting curve to its [[joint]] table (the \
                 data-sheet curve is `servo = {{ minus100 = 900.0, zero = 1650.0, plus100 = 2400.0 }}`) \
                 and tune again",
                args.joint, description.joint_names[j]
            ),
        });
    };
    let mut client = args.device.connect()?;
    let mut tuning =
        Tuning::new(start, usize::from(args.points)).map_err(|e| Error::DeviceInput {
            what: format!("tune joint {} at {} points", args.joint, args.points),
            reason: e.to_string(),
        })?;
    let tty = |e: std::io::Error| Error::DeviceInput {
        what: "use the terminal".into(),
        reason: e.to_string(),
    };
    terminal::enable_raw_mode().map_err(tty)?;
    let outcome = (|| -> Result<(), Error> {
        tuning.pulse_us = client.raw_pulse(args.joint - 1, tuning.pulse_us)?;
        loop {
            eprint!("{}", tuning.line(args.joint));
            let Event::Key(KeyEvent {
                code,
                kind: KeyEventKind::Press,
                ..
            }) = event::read().map_err(tty)?
            else {
                continue;
            };
            match tuning.key(code) {
                Action::Pulse(p) => tuning.pulse_us = client.raw_pulse(args.joint - 1, p)?,
                Action::Nothing => {}
                Action::Write(curve) => {
                    // In place: the file's comments and layout stay the user's.
                    arm_toml::write_servo(&args.arm, j, &curve)?;
                    let board = write_to_board(&mut client, j, curve)?;
                    tuning.note = format!("written to {}; {board}", args.arm.display());
                }
                Action::Quit => return Ok(()),
            }
        }
    })();
    let _ = terminal::disable_raw_mode();
    eprintln!();
    // Leave the servo limp whatever happened: a raw pulse must not outlive the session.
    let limp = client.detach(Some(args.joint - 1));
    outcome?;
    limp?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_jog_record_and_refuse_a_bad_curve() {
        let mut t = Tuning::new(ServoCurve::nominal(), 5).unwrap();
        assert_eq!(t.curve.pulses_us(), [900.0, 1275.0, 1650.0, 2025.0, 2400.0]);
        assert_eq!(t.pulse_us, 1650);
        assert_eq!(t.key(KeyCode::Up), Action::Pulse(1660));
        assert_eq!(t.key(KeyCode::Left), Action::Pulse(1659));
        t.key(KeyCode::Char('3'));
        assert_eq!(t.curve.pulses_us()[2], 1659.0);
        assert_eq!(t.note, "recorded 1659 µs as 0°");
        for _ in 0..8 {
            t.key(KeyCode::PageDown);
        }
        t.key(KeyCode::Char('1'));
        assert_eq!(t.note, "recorded 859 µs as -100°");
        assert_eq!(t.recorded, [true, false, true, false, false]);
        // Only five points: keys past 5 record nothing.
        assert_eq!(t.key(KeyCode::Char('6')), Action::Nothing);
        assert_eq!(t.recorded, [true, false, true, false, false]);
        let d = |x: f64| x.to_radians();
        assert_eq!(
            t.key(KeyCode::Char('w')),
            Action::Write(
                ServoCurve::new(
                    &[d(-100.0), d(-50.0), d(0.0), d(50.0), d(100.0)],
                    &[859.0, 1275.0, 1659.0, 2025.0, 2400.0]
                )
                .unwrap()
            )
        );
        let line = t.line(2);
        assert!(
            line.contains("-100°: 859* -50°: 1275  0°: 1659* +50°: 2025  +100°: 2400 "),
            "{line}"
        );
        // Recording +50° below 0° makes a non-monotonic curve, which is not written.
        t.key(KeyCode::Char('4'));
        assert_eq!(t.key(KeyCode::Char('w')), Action::Nothing);
        assert!(t.note.contains("not written"), "{}", t.note);
        assert_eq!(t.key(KeyCode::Char('q')), Action::Quit);
    }

    #[test]
    fn three_points_are_the_old_tuning_and_odd_counts_include_zero() {
        let mut t = Tuning::new(ServoCurve::nominal(), 3).unwrap();
        assert_eq!(t.curve, ServoCurve::nominal());
        t.key(KeyCode::Char('2'));
        assert_eq!(t.note, "recorded 1650 µs as 0°");
        assert_eq!(t.key(KeyCode::Char('4')), Action::Nothing);
        assert_eq!(tuning_angles_deg(9)[1], -75.0);
        assert_eq!(tuning_angles_deg(7)[3], 0.0);
        let four = Tuning::new(ServoCurve::nominal(), 4).unwrap();
        assert!(four.line(1).contains("-33.3°: 1400"), "{}", four.line(1));
        assert!(Tuning::new(ServoCurve::nominal(), 10).is_err());
    }

    #[test]
    fn a_point_outside_the_pulse_range_is_not_written() {
        // A curve whose outer knots lie inside ±100°: resampled at ±100° it
        // runs past 2500 µs until that point is recorded.
        let d = |x: f64| x.to_radians();
        let steep = ServoCurve::new(&[d(-50.0), d(50.0)], &[1300.0, 2200.0]).unwrap();
        let mut t = Tuning::new(steep, 3).unwrap();
        assert!((t.curve.pulses_us()[2] - 2650.0).abs() < 1e-9);
        assert_eq!(t.key(KeyCode::Char('w')), Action::Nothing);
        assert!(
            t.note.contains("point 3") && t.note.contains("2500"),
            "{}",
            t.note
        );
        t.pulse_us = 2450;
        t.key(KeyCode::Char('3'));
        assert!(matches!(t.key(KeyCode::Char('w')), Action::Write(_)));
    }
}
