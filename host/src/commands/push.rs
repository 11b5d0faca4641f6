//! `lrmcal push`: send a calibration file to the board, which stores it in
//! flash and uses it from then on.

use protocol::{CHANNELS, PerChannel};
use std::path::PathBuf;

use crate::commands::device_args::DeviceArgs;
use crate::error::Error;
use crate::progress::Meter;
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_engine::device::calibration::{self, NotDriven};

/// Send a calibration to the board (stored in flash, used at once).
#[derive(Debug, clap::Args)]
#[command(
    // With --dry-run no board is needed.
    mut_arg("port", |a| a.required(false).required_unless_present("dry_run")),
    after_help = "Examples:\n  lrmcal push calibration.json --port /dev/ttyACM0\n  \
lrmcal push calibration.json --target marker2 --port /dev/ttyACM0\n  \
lrmcal push calibration.json --dry-run\n\n\
The board checks the whole calibration (length, CRC, finite values, limits, monotonic servo \
curves, compliances, softenings and plays within the physical bounds of the nominal arm) before \
it stores it in the flash slot not in use; if the transfer breaks off or the check fails, it \
keeps the calibration it had. lrmcal makes the same check before connecting. The payload also \
carries how far the board may correct each joint: the largest correction the calibration asks \
for within the joint limits, with a margin. A calibration of several measured targets \
compensates one of them: the first unless --target names another. --dry-run prepares and checks \
the payload and prints what would be sent, without a board."
)]
pub struct Args {
    /// Calibration file written by `lrmcal identify` or `lrmcal demo`.
    pub calibration: PathBuf,
    /// Home pose for `lrmcal home` and start-up, one angle per joint, degrees [default: all 0].
    #[arg(long, num_args = 1..=CHANNELS, value_name = "DEG", allow_negative_numbers = true)]
    pub home_deg: Option<Vec<f64>>,
    /// The measured target the board compensates (its tool point goes where
    /// the nominal arm's would be) [default: the calibration's first].
    #[arg(long, value_name = "NAME")]
    pub target: Option<String>,
    /// Check the calibration and build what the board would receive, without
    /// a board: nothing is sent.
    #[arg(long)]
    pub dry_run: bool,
    /// The board (not needed with --dry-run).
    #[command(flatten)]
    pub device: Option<DeviceArgs>,
}

/// Runs `lrmcal push`.
pub fn run(args: &Args) -> Result<(), Error> {
    let file = CalibrationFile::read(&args.calibration)?;
    let joints = file.arm.joints.len();
    if !file.converged {
        return Err(Error::DeviceInput {
            what: format!("prepare `{}` for the board", args.calibration.display()),
            reason: "its fit did not converge (`converged`: false), so it may leave the arm worse than uncalibrated; identify again from more poses or with a simpler --option".into(),
        });
    }
    if let Err(refused) = calibration::drivable(&file.arm) {
        let way_out = match refused {
            NotDriven::Joints { .. } => {
                "this calibration is for the host only (`lrmcal predict`, `validate`, `export`)"
                    .to_owned()
            }
            NotDriven::NoServo { joint } => format!(
                "add one to the arm file (the data-sheet curve is \
                 `servo = {{ minus100 = 900.0, zero = 1650.0, plus100 = 2400.0 }}`), tune it with \
                 `lrmcal servo-tune {joint}` and identify again"
            ),
        };
        return Err(Error::DeviceInput {
            what: format!("prepare `{}` for the board", args.calibration.display()),
            reason: format!("{refused}; {way_out}"),
        });
    }
    let home = args.home_deg.clone().unwrap_or_else(|| vec![0.0; joints]);
    if home.len() != joints {
        return Err(Error::DeviceInput {
            what: format!("prepare `{}` for the board", args.calibration.display()),
            reason: format!(
                "--home-deg gives {} angles; the arm has {joints} joints, one angle each",
                home.len()
            ),
        });
    }
    let home_rad = PerChannel::from_fn(joints, |i| home[i].to_radians() as f32);
    let file = file
        .for_target(args.target.as_deref())
        .map_err(|reason| Error::DeviceInput {
            what: format!("prepare `{}` for the board", args.calibration.display()),
            reason,
        })?;
    let payload = calibration::payload(&file, home_rad).map_err(|fault| Error::DeviceInput {
        what: format!("prepare `{}` for the board", args.calibration.display()),
        reason: calibration::explain(fault, &file.arm),
    })?;
    let Some(device) = args.device.as_ref().filter(|_| !args.dry_run) else {
        let bounds: Vec<String> = payload
            .max_correction_rad
            .iter()
            .map(|m| format!("{:.1}", m.to_degrees()))
            .collect();
        println!(
            "calibration {:08x} ({}) of `{}` checked: the board would accept it (dry run, \
             nothing sent)\nlargest correction per joint, deg: {}\nrated payload: {} kg",
            payload.id,
            payload.option.name(),
            args.calibration.display(),
            bounds.join(" "),
            file.nominal.rated_payload_kg
        );
        return Ok(());
    };
    let mut client = device.connect()?;
    let bar = Meter::new("sending", 0, "bytes");
    let info = client.push_calibration(&payload, |sent, total| {
        bar.set_length(total as u64);
        bar.set_position(sent as u64);
    })?;
    bar.finish();
    println!(
        "calibration {:08x} ({}) stored in flash (sequence {}) and in use",
        info.id,
        info.option.name(),
        info.sequence
    );
    Ok(())
}
