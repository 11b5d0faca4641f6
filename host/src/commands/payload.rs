//! `lrmcal payload`: tell the board the mass at the tool.

use crate::commands::device_args::DeviceArgs;
use crate::error::Error;

/// Set the payload mass the compensation accounts for.
#[derive(Debug, clap::Args)]
#[command(after_help = "Example:\n  lrmcal payload 0.0663 --port /dev/ttyACM0")]
pub struct Args {
    /// Payload mass, kg (0 for none).
    pub kg: f32,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// Runs `lrmcal payload`.
pub fn run(args: &Args) -> Result<(), Error> {
    let mut client = args.device.connect()?;
    client.set_payload(args.kg)?;
    Ok(())
}
