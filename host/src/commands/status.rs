//! `lrmcal status`: what the board runs on and what it is doing.

use protocol::{Faults, Status};

use crate::device::DeviceArgs;
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
                "calibration {:08x} ({}), flash sequence {}\n",
                c.id,
                c.option.name(),
                c.sequence
            )
        }
        None => out += "calibration none: nominal servo curves and ±100° limits\n",
    }
    let c = s.compensation;
    out += &format!(
        "compensation {:?}, payload {:.4} kg, last solve {} ({} iterations, {:.2} µm), {} fallbacks\n",
        s.mode,
        s.payload_kg,
        if c.converged {
            "converged"
        } else {
            "not converged"
        },
        c.iterations,
        c.error_um,
        c.fallbacks
    );
    out += &format!("motion {}\n", if s.moving { "running" } else { "still" });
    out += "joint  target°   now°      pulse µs\n";
    for i in 0..6 {
        let pulse = match s.pulses_us[i] {
            0 => "limp".to_owned(),
            p => p.to_string(),
        };
        out += &format!(
            "{:>5}  {:>8.2}  {:>8.2}  {pulse:>8}\n",
            i + 1,
            s.targets_rad[i].to_degrees(),
            s.nominal_rad[i].to_degrees()
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
