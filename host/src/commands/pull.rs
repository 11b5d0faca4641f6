//! `lrmcal pull`: read the calibration stored on the board.

use std::path::PathBuf;

use protocol::Calibration;

use crate::commands::device_args::DeviceArgs;
use crate::commands::helpers::write_text;
use crate::error::Error;

/// Read the board's calibration back (JSON: id, option, both arms, home pose).
#[derive(Debug, clap::Args)]
#[command(after_help = "Example:\n  lrmcal pull --port /dev/ttyACM0 --out on-board.json")]
pub struct Args {
    /// Where to write it [default: standard output].
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// The board's calibration as written by `lrmcal pull` (single precision, as stored).
#[derive(Debug, serde::Serialize)]
struct Pulled<'a> {
    schema: &'static str,
    id: String,
    option: &'static str,
    home_deg: Vec<f32>,
    nominal: &'a model::Arm<f32>,
    calibrated: &'a model::Arm<f32>,
}

/// Runs `lrmcal pull`.
pub fn run(args: &Args) -> Result<(), Error> {
    let mut client = args.device.connect()?;
    let c: Calibration = client.pull_calibration()?;
    let pulled = Pulled {
        schema: "lrmcal-board-calibration",
        id: format!("{:08x}", c.id),
        option: c.option.name(),
        home_deg: c.home_rad.iter().map(|a| a.to_degrees()).collect(),
        nominal: &c.nominal,
        calibrated: &c.calibrated,
    };
    let text = serde_json::to_string_pretty(&pulled).map_err(|e| Error::DeviceInput {
        what: "write the calibration as JSON".into(),
        reason: e.to_string(),
    })? + "\n";
    match &args.out {
        Some(path) => write_text(path, &text),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}
