//! `lrmcal status`: what the board runs on and what it is doing.

use protocol::CHANNELS;
use protocol::{CompensationMode, Faults, Status};

use crate::commands::device_args::DeviceArgs;
use crate::error::Error;

/// Show the board's versions, calibration, compensation, joints and faults.
#[derive(Debug, clap::Args)]
#[command(after_help = "Example:\n  lrmcal status --port /dev/ttyACM0")]
pub struct Args {
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// Runs `lrmcal status`.
pub fn run(args: &Args) -> Result<(), Error> {
    let mut client = args.device.connect()?;
    let status = client.status()?;
    print!("{}", render(&status));
    Ok(())
}

/// The status as text for people.
pub fn render(s: &Status) -> String {
    let mut out = format!(
        "firmware {} (protocol {}), up {:.1} s\n",
        s.device.firmware,
        s.device.protocol,
        s.uptime_ms as f64 / 1000.0
    );
    match s.calibration {
        Some(c) => {
            out += &format!(
                "calibration {:08x} ({}, {} joints), flash sequence {}\n",
                c.id,
                c.option.name(),
                c.joints,
                c.sequence
            )
        }
        None => out += "calibration none: nominal servo curves and ±100° limits\n",
    }
    let c = s.compensation;
    out += &match s.mode {
        CompensationMode::Off => format!("compensation off, payload {:.4} kg\n", s.payload_kg),
        mode => format!(
            "compensation {}, payload {:.4} kg, last solve {} ({} iterations, {:.2} µm), {} fallbacks\n",
            if mode == CompensationMode::Full {
                "full"
            } else {
                "elastic only"
            },
            s.payload_kg,
            if c.converged {
                "converged"
            } else {
                "not converged"
            },
            c.iterations,
            c.error_um,
            c.fallbacks
        ),
    };
    out += &format!("motion {}\n", if s.moving { "running" } else { "still" });
    out += "joint  target°   now°      pulse µs\n";
    for i in 0..CHANNELS {
        let pulse = match s.pulses_us[i] {
            0 => "limp".to_owned(),
            p => p.to_string(),
        };
        // A channel past the arm's last joint has no target: it stays limp.
        let angle = |v: &[f32]| {
            v.get(i)
                .map_or("-".to_owned(), |a| format!("{:.2}", a.to_degrees()))
        };
        out += &format!(
            "{:>5}  {:>8}  {:>8}  {pulse:>8}\n",
            i + 1,
            angle(&s.targets_rad),
            angle(&s.nominal_rad)
        );
    }
    let faults: Vec<&str> = Faults::NAMED
        .iter()
        .filter(|(f, _)| s.faults.contains(*f))
        .map(|(_, name)| *name)
        .collect();
    out += &format!(
        "faults {}; {} frames dropped since boot\n",
        if faults.is_empty() {
            "none".into()
        } else {
            faults.join(", ")
        },
        s.frames_dropped
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::testing::TEST_ARM_JOINTS as JOINTS;
    use protocol::{CalibrationInfo, CompensationReport, DeviceInfo, FirmwareVersion, ModelOption};

    #[test]
    fn status_reads_for_people() {
        let mut s = Status {
            device: DeviceInfo {
                protocol: 1,
                firmware: FirmwareVersion {
                    major: 0,
                    minor: 1,
                    patch: 0,
                },
                channels: 6,
            },
            calibration: Some(CalibrationInfo {
                id: 0xABC,
                option: ModelOption::Elastic,
                joints: 6,
                sequence: 4,
            }),
            mode: CompensationMode::Full,
            compensation: CompensationReport {
                converged: true,
                iterations: 2,
                error_um: 1.25,
                fallbacks: 0,
            },
            payload_kg: 0.0663,
            moving: false,
            targets_rad: [0.5; JOINTS].into(),
            nominal_rad: [0.5; JOINTS].into(),
            pulses_us: [1865, 0, 1865, 1865, 1865, 1865],
            faults: Faults::LIMIT_CLAMPED,
            frames_dropped: 2,
            uptime_ms: 1500,
        };
        let text = render(&s);
        assert!(
            text.contains("calibration 00000abc (elastic, 6 joints), flash sequence 4"),
            "{text}"
        );
        assert!(text.contains(
            "compensation full, payload 0.0663 kg, last solve converged (2 iterations, 1.25 µm)"
        ));
        assert!(
            text.contains("    2     28.65     28.65      limp"),
            "{text}"
        );
        assert!(text.contains("faults a command was clamped to a limit; 2 frames dropped"));
        s.mode = CompensationMode::Off;
        s.calibration = None;
        let text = render(&s);
        assert!(
            text.contains("compensation off, payload") && text.contains("calibration none"),
            "{text}"
        );
    }
}
