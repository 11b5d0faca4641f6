//! `lrmcal servo-tune`: level-1 calibration at the terminal. Jog one servo's
//! pulse until the protractor reads -100°, 0° and +100°, record each, and
//! write the three-point curve into the arm file and onto the board.

use std::path::PathBuf;

use crossterm::event::{self, Event, KeyCode, KeyEvent, KeyEventKind};
use crossterm::terminal;
use model::ServoCurve;

use crate::device::{Client, ClientError, DeviceArgs, Link, calibration};
use crate::error::Error;
use crate::io::arm_toml::{self, NO_SERVO};

/// Tune one servo's pulse curve interactively.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Example:\n  lrmcal servo-tune 3 --arm my_arm.toml --port /dev/ttyACM0\n\n\
Keys: ←/→ 1 µs, ↓/↑ 10 µs, PgDn/PgUp 100 µs; 1, 2, 3 record the pulse as -100°, 0°, +100°; \
w writes the curve to the arm file (and to the board's calibration, if it has one); q quits \
and leaves the servo limp. The board clamps every pulse to its safe range."
)]
pub struct Args {
    /// Joint 1..6.
    #[arg(value_parser = clap::value_parser!(u8).range(1..=6))]
    pub joint: u8,
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

/// The tuning session's state: the pulse now and the three points.
#[derive(Clone, Debug, PartialEq)]
pub struct Tuning {
    /// Pulse on the servo, µs.
    pub pulse_us: u16,
    /// The curve being built (starts as the arm file's).
    pub curve: ServoCurve<f64>,
    /// Which of -100°, 0°, +100° were recorded in this session.
    pub recorded: [bool; 3],
    /// Last message for the user.
    pub note: String,
}

impl Tuning {
    /// Starts at the curve's 0° pulse.
    pub fn new(curve: ServoCurve<f64>) -> Self {
        Self {
            pulse_us: curve.zero.round().clamp(0.0, 65535.0) as u16,
            curve,
            recorded: [false; 3],
            note: String::new(),
        }
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
            KeyCode::Char(c @ '1'..='3') => {
                let p = f64::from(self.pulse_us);
                let (slot, name) = match c {
                    '1' => (&mut self.curve.minus100, "-100°"),
                    '2' => (&mut self.curve.zero, "0°"),
                    _ => (&mut self.curve.plus100, "+100°"),
                };
                *slot = p;
                self.recorded[(c as u8 - b'1') as usize] = true;
                self.note = format!("recorded {p} µs as {name}");
                Action::Nothing
            }
            KeyCode::Char('w') if self.curve.is_monotonic() => Action::Write(self.curve),
            KeyCode::Char('w') => {
                self.note = "not written: the three pulses must run one way".into();
                Action::Nothing
            }
            KeyCode::Char('q') | KeyCode::Esc => Action::Quit,
            _ => Action::Nothing,
        }
    }

    fn line(&self, joint: u8) -> String {
        let mark = |i: usize| if self.recorded[i] { "*" } else { " " };
        format!(
            "\rjoint {joint}: {:>5} µs | -100°: {:.0}{} 0°: {:.0}{} +100°: {:.0}{} | {}\x1b[K",
            self.pulse_us,
            self.curve.minus100,
            mark(0),
            self.curve.zero,
            mark(1),
            self.curve.plus100,
            mark(2),
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
    c.calibrated.joints[joint].servo = curve.map_f32();
    let c = calibration::identified(c).map_err(|f| Error::DeviceInput {
        what: "put the new curve into the board's calibration".into(),
        reason: f.to_string(),
    })?;
    client.push_calibration(&c, |_, _| {})?;
    Ok(format!("board calibration updated ({:08x})", c.id))
}

/// Single precision for the board.
trait MapF32 {
    fn map_f32(self) -> ServoCurve<f32>;
}

impl MapF32 for ServoCurve<f64> {
    fn map_f32(self) -> ServoCurve<f32> {
        ServoCurve {
            minus100: self.minus100 as f32,
            zero: self.zero as f32,
            plus100: self.plus100 as f32,
        }
    }
}

/// Runs `lrmcal servo-tune`.
pub fn run(args: &Args) -> Result<(), Error> {
    let mut description = arm_toml::read(&args.arm)?;
    let j = (args.joint - 1) as usize;
    if description.arm.joints[j].servo == NO_SERVO {
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
    }
    let mut client = args.device.connect()?;
    let mut tuning = Tuning::new(description.arm.joints[j].servo);
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
                    description.arm.joints[j].servo = curve;
                    arm_toml::write(&args.arm, &description)?;
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
        let mut t = Tuning::new(ServoCurve::nominal());
        assert_eq!(t.pulse_us, 1650);
        assert_eq!(t.key(KeyCode::Up), Action::Pulse(1660));
        assert_eq!(t.key(KeyCode::Left), Action::Pulse(1659));
        t.key(KeyCode::Char('2'));
        assert_eq!(t.curve.zero, 1659.0);
        for _ in 0..8 {
            t.key(KeyCode::PageDown);
        }
        t.key(KeyCode::Char('1'));
        assert_eq!(t.curve.minus100, 859.0);
        assert_eq!(t.recorded, [true, true, false]);
        assert_eq!(
            t.key(KeyCode::Char('w')),
            Action::Write(ServoCurve {
                minus100: 859.0,
                zero: 1659.0,
                plus100: 2400.0
            })
        );
        // Recording +100° below 0° makes a non-monotonic curve, which is not written.
        t.key(KeyCode::Char('3'));
        assert_eq!(t.key(KeyCode::Char('w')), Action::Nothing);
        assert!(t.note.contains("not written"));
        assert_eq!(t.key(KeyCode::Char('q')), Action::Quit);
    }
}
