//! `lrmcal home`: attach every joint and move to the home pose.

use std::time::Duration;

use crate::commands::device_args::{DeviceArgs, timing};
use crate::error::Error;

/// Move to the home pose (the calibration's, or all zeros).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "At power-on the board drives no servo (all limp). Park the arm with \
`lrmcal home` and `lrmcal detach` before switching off: the first move after power-on \
starts from the home pose."
)]
pub struct Args {
    /// How long the move takes, ms.
    #[arg(long)]
    pub duration_ms: Option<u32>,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// Runs `lrmcal home`.
pub fn run(args: &Args) -> Result<(), Error> {
    let mut client = args.device.connect()?;
    client.home(timing(args.duration_ms, None))?;
    client.wait_until_still(Duration::from_millis(100), Duration::from_secs(700))?;
    println!("at home");
    Ok(())
}
