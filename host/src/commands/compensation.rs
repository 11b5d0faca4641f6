//! `lrmcal compensation`: choose what the board corrects.

use protocol::CompensationMode;

use crate::commands::device_args::DeviceArgs;
use crate::error::Error;

/// What the board does with the nominal joint targets.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Mode {
    /// Servo curves only.
    Off,
    /// Cancel the elastic sag.
    Elastic,
    /// Cancel sag and geometric errors: the tool goes where the nominal arm's would.
    Full,
}

/// Switch the real-time compensation off, to elastic only, or to full.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Example:\n  lrmcal compensation full --port /dev/ttyACM0\n\n\
Needs a calibration on the board (`lrmcal push`); refused while the arm moves."
)]
pub struct Args {
    /// The mode.
    #[arg(value_enum)]
    pub mode: Mode,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// Runs `lrmcal compensation`.
pub fn run(args: &Args) -> Result<(), Error> {
    let mode = match args.mode {
        Mode::Off => CompensationMode::Off,
        Mode::Elastic => CompensationMode::ElasticOnly,
        Mode::Full => CompensationMode::Full,
    };
    let mut client = args.device.connect()?;
    client.set_compensation(mode)?;
    Ok(())
}
