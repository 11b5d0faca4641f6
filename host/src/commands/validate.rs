//! `lrmcal validate`: how well a calibration predicts another measurement
//! file, per load, against the nominal model it was identified from.

use std::path::PathBuf;

use crate::error::Error;
use lrmcal_core::camera::{intrinsics_file, setup, views};
use lrmcal_core::io::arm_source::ArmSource;
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::measurements;
use lrmcal_engine::calib::fit::checks::check_plausible_calibrated;
use lrmcal_engine::calib::fit::validate::{ErrorStats, reprojection_errors_px, validate_per_load};
use lrmcal_engine::calib::results::export::{camera_rigs_of, rigs_of};
use lrmcal_engine::calib::results::report::ValidationOutlier;
use lrmcal_engine::calib::results::summary;
use lrmcal_engine::calib::run::CameraInput;
use lrmcal_engine::camera::corner_measurements::corner_measurements;

/// Check a calibration against measurements it was not identified from.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal validate --calibration cal/calibration-elasto-kinematic-servo.json --measurements other.csv\n  \
lrmcal validate --calibration cal.json --measurements m.csv --arm my_arm.toml\n  \
lrmcal validate --camera setup.toml --calibration cal/calibration-elasto-kinematic-servo.json --measurements views.csv\n\n\
Prints mean, median, RMS, 95th percentile and max of the 3D error norm per load, \
before (nominal arm) and after (calibrated), and names the measurements whose error \
after calibration is far beyond the others' (a measurement far from where the calibrated \
arm puts the tool is one of them; the file is refused only when most are, which means a wrong \
unit, arm or frame). With --arm, the calibration must have been \
identified from that arm (its base aside when `identify` registered it). A calibration \
registered by `identify` holds both arms in the tracker's frame, so the measurements are \
taken in that frame as they are.")]
pub struct Args {
    /// Calibration file written by `lrmcal identify` or `lrmcal demo`.
    #[arg(long, value_name = "FILE")]
    pub calibration: PathBuf,
    /// Measurement CSV to validate on.
    #[arg(long, value_name = "FILE")]
    pub measurements: PathBuf,
    /// A camera measured: its setup (TOML); --measurements is then a camera
    /// measurement file, and the calibration one `identify --camera` made
    /// with that camera.
    #[arg(long, value_name = "SETUP")]
    pub camera: Option<PathBuf>,
    /// With --camera, the lens to see with instead of the setup's: the
    /// camera_info `identify --camera --refine-intrinsics` wrote beside the
    /// calibration.
    #[arg(long, value_name = "FILE", requires = "camera")]
    pub intrinsics: Option<PathBuf>,
    /// The nominal arm the calibration must belong to [default: the one recorded in it].
    #[arg(long, value_name = "NAME|FILE")]
    pub arm: Option<ArmSource>,
}

/// Runs `lrmcal validate`.
pub fn run(args: &Args) -> Result<(), Error> {
    let cal = CalibrationFile::read(&args.calibration)?;
    if let Some(source) = &args.arm {
        cal.check_nominal(&source.load()?.arm, &args.calibration)?;
    }
    let file = args.measurements.display().to_string();
    let (rows, (nominal, calibrated), pixels) = match &args.camera {
        Some(path) => {
            let mut setup = setup::read(path)?;
            if let Some(lens) = &args.intrinsics {
                setup.intrinsics = intrinsics_file::read(lens)?;
            }
            let views = views::read(&args.measurements)?;
            let (rows, _) =
                corner_measurements(&setup.intrinsics, &setup.board, &views, setup.mount).map_err(
                    |source| Error::Views {
                        path: args.measurements.clone(),
                        source,
                    },
                )?;
            let camera = CameraInput::of_setup(&setup);
            let rigs = camera_rigs_of(&cal, &camera.intrinsics, &camera.corners, setup.mount);
            // The same errors in the camera's own unit.
            let px = |rig| reprojection_errors_px(rig, &rows).map(|e| ErrorStats::of(&e));
            let (before, after) = (px(&rigs.0)?, px(&rigs.1)?);
            let line = format!(
                "reprojection error over the {} corners, px: median {:.2} -> {:.2}, rms {:.2} -> {:.2}",
                after.count, before.median_m, after.median_m, before.rms_m, after.rms_m
            );
            (rows, rigs, Some(line))
        }
        None => (measurements::read(&args.measurements)?, rigs_of(&cal), None),
    };
    // Far from the calibrated arm is a validation outlier; most of them far,
    // a wrong unit, arm or frame.
    check_plausible_calibrated(&calibrated, &rows, &file)?;
    println!(
        "{} calibration {} on {file}:",
        cal.option.name(),
        args.calibration.display()
    );
    println!(
        "{:>8} {:>6} | {:>31} | {:>31} | {:>9}",
        "load kg",
        if args.camera.is_some() {
            "corners"
        } else {
            "poses"
        },
        "before: mean median rms p95 max",
        "after: mean median rms p95 max",
        "reduction"
    );
    let fmt = |s: &ErrorStats| {
        format!(
            "{:5.2} {:5.2} {:5.2} {:5.2} {:6.2}",
            s.mean_m * 1e3,
            s.median_m * 1e3,
            s.rms_m * 1e3,
            s.p95_m * 1e3,
            s.max_m * 1e3
        )
    };
    let per_load = validate_per_load(&nominal, &calibrated, &rows)?;
    for lv in &per_load {
        let v = &lv.validation;
        println!(
            "{:>8} {:>6} | {:>31} | {:>31} | {:>7.1} %",
            lv.load_kg,
            v.before.count,
            fmt(&v.before),
            fmt(&v.after),
            v.reduction_pct
        );
    }
    println!(
        "(errors in mm; {})",
        match args.camera {
            Some(_) => "at the board's corners: the reprojection error carried to their distance",
            None => "3D distance between measured and predicted tool point",
        }
    );
    if let Some(line) = pixels {
        println!("{line}");
    }
    for (o, measurements) in per_load
        .iter()
        .flat_map(|lv| lv.validation.outlying_poses())
    {
        println!(
            "{}",
            summary::validation_outlier(&ValidationOutlier {
                pose: o.pose,
                load_kg: o.load_kg,
                error_mm: o.after_m * 1e3,
                measurements,
            })
        );
    }
    Ok(())
}
