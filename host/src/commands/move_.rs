//! `lrmcal move`: move the arm to nominal joint angles.

use std::time::Duration;

use protocol::Timing;

use crate::device::DeviceArgs;
use crate::error::Error;

/// Move every joint to a nominal angle (degrees), all arriving together.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal move 0 30 -45 0 60 0 --port /dev/ttyACM0\n  \
lrmcal move -- -100 0 100 0 -100 0 --duration-ms 4000\n\n\
The angles are the nominal model's: with compensation on, the board commands the angles that \
put the calibrated, deflected arm's tool where the nominal arm's would be. The board keeps \
its speed and acceleration limits whatever the duration asked for.")]
pub struct Args {
    /// Six joint angles, degrees, base to tip.
    #[arg(
        num_args = 6,
        value_name = "DEG",
        allow_negative_numbers = true,
        required = true
    )]
    pub angles_deg: Vec<f64>,
    /// How long the move takes, ms (stretched if the limits need more).
    #[arg(long, conflicts_with = "speed_deg_s")]
    pub duration_ms: Option<u32>,
    /// Speed of the joint that travels furthest, deg/s [default: the board's top speed].
    #[arg(long)]
    pub speed_deg_s: Option<f64>,
    /// Return at once instead of waiting until the arm stands still.
    #[arg(long)]
    pub no_wait: bool,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// The timing the board is asked for.
pub fn timing(duration_ms: Option<u32>, speed_deg_s: Option<f64>) -> Timing {
    match (duration_ms, speed_deg_s) {
        (_, Some(v)) => Timing::SpeedRadPerS(v.to_radians() as f32),
        (Some(ms), None) => Timing::DurationMs(ms),
        (None, None) => Timing::DurationMs(0),
    }
}

/// Runs `lrmcal move`.
pub fn run(args: &Args) -> Result<(), Error> {
    let targets: [f32; 6] = std::array::from_fn(|i| args.angles_deg[i].to_radians() as f32);
    let mut client = args.device.connect()?;
    client.move_to(targets, timing(args.duration_ms, args.speed_deg_s))?;
    if !args.no_wait {
        client.wait_until_still(Duration::from_millis(100), Duration::from_secs(700))?;
        println!("arrived");
    }
    Ok(())
}
