//! `lrmcal identify`: fit the error parameters to a measurement file, from a
//! DETMAX selection of N poses or an explicit pose list, for one model option
//! or all three; validate on the measured poses not used (a list that marks
//! validation poses, as `lrmcal select` writes it, names exactly those);
//! write the calibration file(s) and a report. Measurements of several targets per
//! pose (a `target` column) fit one arm and a tool point per target; with
//! `--tool-only`, only the tool points are fitted, the arm of an earlier
//! calibration held fixed (after a tool change).
//! Before the fit the arm is registered in the measurement frame
//! (`lrmcal_engine::calib::fit::registration`, on the first target's rows) unless
//! `--no-register` keeps the arm file's base.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::commands::helpers::OptionChoice;
use crate::commands::helpers::write_text;
use crate::error::Error;
use crate::progress::Steps;
use crate::report_page;
use lrmcal_core::camera::static_transform::StaticTransform;
use lrmcal_core::camera::{Intrinsics, Mount, intrinsics_file, setup, views};
use lrmcal_core::dataset::{Measurement, Pose};
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM};
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::pose_list::PoseRole;
use lrmcal_core::io::{measurements, pose_list};
use lrmcal_engine::calib::analysis::detmax::DetmaxOptions;
use lrmcal_engine::calib::fit::identify::IdentifyOptions;
use lrmcal_engine::calib::fit::registration::Gravity;
use lrmcal_engine::calib::results::summary;
use lrmcal_engine::calib::run::{
    CameraInput, Placement, PoseChoice, Request, calibrate, reteach as reteach_tools,
};
use lrmcal_engine::camera::corner_measurements::corner_measurements;
use lrmcal_engine::tracker::axes::Up;

/// Identify the arm's error parameters from measured tool positions.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal identify --measurements m.csv --select 50 --out cal\n  \
lrmcal identify --measurements m.csv --poses selection.csv --option all --out cal\n  \
lrmcal identify --measurements m.csv --load-kg 0.0663 --candidates candidates.csv --no-robust\n  \
lrmcal identify --measurements new-tool.csv --calibration cal/calibration-elasto-kinematic-servo.json --tool-only\n\n\
The fit uses the measurements under one load (--load-kg; the file's only load by default). \
With --select N, DETMAX picks N of the measured poses (D-optimal for the option); with \
--poses, the list's poses are used; with neither, every measured pose is. Measured poses \
not used for the fit validate it, under every load in the file. A list from `lrmcal select` \
marks its validation poses (role `validate`): they are held out of the fit and validate it, \
and measured poses the list does not name are left out (--no-hold-out fits the validation \
poses too). Measurements far off the \
others are down-weighted (Huber) and named, in the fit and in the validation. Writes \
calibration-<option>.json (the file `lrmcal push` sends to the board), report.json and report.html \
(one page: the errors, the parameters, suspect measurements and what to do next; `lrmcal report DIR` \
builds it again from report.json).\n\n\
The positions may be in any right-handed frame (the tracker's): the arm's base is found \
in it from the measurements first (printed, and recorded in the calibration file), so the \
arm file's [base] need not be known. Gravity is the arm file's `gravity` in that frame, \
or -g along the axis --up names, or along the base's -z with --level-base.\n\n\
Several targets per pose: a `target` column in the measurements names the target of each row; \
the fit shares the arm and gives each target its own tool point (every target needs at least \
3 poses). After a tool change, re-teach only the tool points from a few poses with \
--calibration OLD.json --tool-only: the arm of OLD.json stays as it is.")]
pub struct Args {
    /// The nominal arm: a bundled arm's name, an arm description `.toml` file, or a
    /// URDF `.urdf` file (its chain from --base-link to --tip-link).
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Measurement CSV (`pose,load_kg,q1_deg..q6_deg,x_mm,y_mm,z_mm[,target]`).
    #[arg(long, value_name = "FILE")]
    pub measurements: PathBuf,
    /// Candidate pose list: every measured pose must be one of them.
    #[arg(long, value_name = "FILE")]
    pub candidates: Option<PathBuf>,
    /// Select this many poses with DETMAX.
    #[arg(long, value_name = "N", conflicts_with = "poses")]
    pub select: Option<usize>,
    /// Fit the poses of this pose list; those it marks `validate` (role
    /// column) are held out of the fit to validate it.
    #[arg(long, value_name = "FILE")]
    pub poses: Option<PathBuf>,
    /// Fit the validation poses of --poses too: nothing is held out.
    #[arg(long, requires = "poses")]
    pub no_hold_out: bool,
    /// Model option: elasto-kinematic-servo (each servo's own curve, backlash
    /// and stiffening too, as far as the measurements carry them),
    /// elasto-kinematic, kinematic, elastic (the paper's three, the geometry
    /// complete for every chain), paper-elasto-kinematic, paper-kinematic
    /// (the paper's plain DH) or all (the first four).
    #[arg(long, default_value_t = OptionChoice::One(lrmcal_engine::calib::parameters::option::DEFAULT))]
    pub option: OptionChoice,
    /// Load whose measurements the fit uses, kg.
    #[arg(long, value_name = "KG")]
    pub load_kg: Option<f64>,
    /// Plain least squares: measurements far off keep their full weight
    /// (they are still named, with a warning).
    #[arg(long)]
    pub no_robust: bool,
    /// Fit measured poses outside the arm's joint limits too (with a warning)
    /// instead of refusing the file.
    #[arg(long)]
    pub allow_outside_limits: bool,
    /// The measurement frame's axis that points up: gravity along its minus
    /// direction [default: the arm file's `gravity`, read in the measurement frame].
    #[arg(
        long,
        value_name = "AXIS",
        allow_hyphen_values = true,
        conflicts_with = "level_base"
    )]
    pub up: Option<Up>,
    /// The arm's base stands level: gravity along its frame 0's -z, wherever
    /// registration puts it.
    #[arg(long)]
    pub level_base: bool,
    /// Keep the arm file's base: the measurements are in its world frame.
    #[arg(long, conflicts_with = "level_base")]
    pub no_register: bool,
    /// Re-teach only the tool points (one per target of the measurements)
    /// with the arm of --calibration held fixed: after a tool change.
    #[arg(long, requires = "calibration", conflicts_with_all = ["select", "poses", "candidates"])]
    pub tool_only: bool,
    /// The earlier calibration whose arm --tool-only keeps.
    #[arg(long, value_name = "FILE", requires = "tool_only")]
    pub calibration: Option<PathBuf>,
    /// DETMAX random starts.
    #[arg(long, default_value_t = DetmaxOptions::default().starts)]
    pub starts: usize,
    /// A webcam measured: the camera setup (TOML) it stood as, roughly;
    /// --measurements is then its camera measurement file (the board's
    /// corners seen at each pose).
    #[arg(long, value_name = "SETUP", conflicts_with_all = ["no_register", "tool_only"])]
    pub camera: Option<PathBuf>,
    /// With --camera, refine the camera's intrinsics (focal lengths,
    /// principal point, distortion) with the arm, starting from the
    /// setup's intrinsics file; the refined lens is written as
    /// camera_info-OPTION.yaml.
    #[arg(long, requires = "camera")]
    pub refine_intrinsics: bool,
    /// Output folder (created if missing).
    #[arg(long, short, value_name = "DIR", default_value = "lrmcal-calibration")]
    pub out: PathBuf,
}

/// Runs `lrmcal identify`.
pub fn run(args: &Args) -> Result<(), Error> {
    let loaded = args.arm.load()?;
    let camera = match &args.camera {
        Some(path) => Some(camera_input(args, path, &loaded.arm)?),
        None => None,
    };
    let nominal = match &camera {
        Some((input, _)) => input.nominal_arm(&loaded.arm),
        None => loaded.arm,
    };
    // The file is read once: the limits are checked on the rows read, every
    // target's included, each named by its line.
    let listed = match &camera {
        Some((_, measured)) => measured.clone(),
        None => measurements::read_listed(&args.measurements)?,
    };
    if let Some(warning) = pose_list::check_within_limits(
        &nominal,
        &args.measurements,
        &pose_list::of_measurements(&listed),
        args.allow_outside_limits,
    )? {
        eprintln!("warning: {warning}");
    }
    let mut all = measurements::unlisted(&listed);
    if let Some(path) = &args.calibration {
        return reteach(args, path, &all);
    }
    let candidates: Option<Vec<Pose>> = match &args.candidates {
        Some(path) => Some(pose_list::read(path)?.into_iter().map(|r| r.pose).collect()),
        None => None,
    };
    let poses = match (&args.select, &args.poses) {
        (Some(n), _) => PoseChoice::Detmax {
            n: *n,
            starts: args.starts,
        },
        (None, Some(path)) => {
            let (ids, kept) = listed_poses(args, path, &all)?;
            all = kept;
            PoseChoice::Listed {
                ids,
                file: path.display().to_string(),
            }
        }
        (None, None) => PoseChoice::All,
    };
    // A camera's frame says nothing of up: the base stands level unless --up says.
    let level_base = args.level_base || (camera.is_some() && args.up.is_none());
    let gravity = Gravity::chosen(&nominal, args.up.map(Up::rotation), level_base);
    let request = Request {
        nominal: &nominal,
        arm_origin: loaded.origin.clone(),
        measurements: &all,
        measurements_file: args.measurements.display().to_string(),
        load_kg: args.load_kg,
        candidates: candidates.as_deref(),
        poses,
        options: args.option.options(),
        placement: if args.no_register {
            Placement::Keep(gravity)
        } else {
            Placement::Register(gravity)
        },
        identify: identify_options(args),
        camera: camera.map(|(input, _)| input),
    };
    create_out(args)?;
    let run = calibrate(&request, &Steps::new())?;

    if !args.no_register {
        let (lines, warning) = summary::registration(&run.registration, &nominal);
        println!("{lines}");
        if let Some(warning) = warning {
            eprintln!("{warning}");
        }
    }
    for (option, e) in &run.skipped {
        eprintln!("{option}: not fitted: {e}");
    }
    for (option, note) in &run.notes {
        eprintln!(
            "warning: {option}: {note}; those are held at their nominal values, and the model is sized from what the poses carry"
        );
    }
    for ((cal, details), result) in run.files.iter().zip(&run.report.options).zip(&run.results) {
        // The file knows the arm it was made for: its name and joints' names.
        let cal = cal.clone().for_arm(&loaded.name, &loaded.joint_names);
        let path = args.out.join(format!("calibration-{}.json", cal.option));
        write_text(&path, &cal.to_json())?;
        println!("\n{}", summary::option_details(details));
        match (&request.camera, &details.camera) {
            // A board's corners are where the board file puts them: the
            // camera is what the user wants to know.
            (Some(camera), Some(fitted)) => {
                let tf = fitted.static_transform();
                print!("{}", camera_lines(&tf));
                if camera.mount == Mount::EyeInHand {
                    print!("{}", board_line(&cal.arm.base));
                }
                let lens = match &result.identified.rig.camera {
                    Some(fitted) => fitted.lens_now(),
                    None => camera.intrinsics.clone(),
                };
                if let Some(line) = summary::lens_refined(details) {
                    print!("{line}");
                }
                for written in write_camera_files(&args.out, &cal.option.to_string(), &lens, &tf)? {
                    println!("  wrote {}", written.display());
                }
                if let Some(lines) = summary::camera_pixels(details) {
                    print!("{lines}");
                }
            }
            (None, _) if !cal.targets.is_empty() => {
                print!("{}", summary::targets_table(&cal.targets))
            }
            _ => {}
        }
        if args.no_robust
            && let Some(warning) = summary::unweighted_outliers(details, &request.measurements_file)
        {
            eprintln!("{warning}");
        }
        println!("  wrote {}", path.display());
    }
    write_text(&args.out.join("report.json"), &run.report.to_json())?;
    let page = report_page::write(&args.out, &run.report)?;
    println!(
        "\nValidation on the measured poses not used for the fit, {} kg ({}):",
        run.load_kg,
        match request.camera {
            Some(_) =>
                "mean error at the board's corners: the reprojection error carried to their distance",
            None => "mean 3D error",
        }
    );
    print!("{}", summary::table(&run.report.options));
    println!(
        "wrote {} (the page: {})",
        args.out.display(),
        page.display()
    );
    Ok(())
}

/// `--camera`: the camera of the setup at `path`, and the corners of its
/// measurement file (`--measurements`) as measurements, each listed at its
/// view's place in the file.
fn camera_input(
    args: &Args,
    path: &Path,
    arm: &model::Arm<f64>,
) -> Result<(CameraInput, Vec<measurements::ListedMeasurement>), Error> {
    let setup = setup::read(path)?;
    let views = views::read(&args.measurements)?;
    let (corners_seen, corners) =
        corner_measurements(&setup.intrinsics, &setup.board, &views, setup.mount).map_err(
            |source| Error::Views {
                path: args.measurements.clone(),
                source,
            },
        )?;
    // Each corner listed at its view's first line: the joint-limit check
    // names the line of the pose it refuses.
    let lines = views
        .iter()
        .flat_map(|v| std::iter::repeat_n(v.line, 4 * v.tags.len()));
    let units = model::PerJoint::from_slice(&arm.kinds()).unwrap_or_default();
    let listed = corners_seen
        .into_iter()
        .zip(lines)
        .map(|(measurement, line)| measurements::ListedMeasurement {
            line,
            measurement,
            units,
        })
        .collect();
    Ok((
        CameraInput {
            corners,
            refine_lens: args.refine_intrinsics,
            ..CameraInput::of_setup(&setup)
        },
        listed,
    ))
}

/// The lines that say where the camera is, and how to publish it.
fn camera_lines(tf: &StaticTransform) -> String {
    let t = tf.child_in_parent.translation.vector;
    let (roll, pitch, yaw) = tf.child_in_parent.rotation.euler_angles();
    let parent = match tf.parent.as_str() {
        "flange" => "the arm's last frame (the flange: name it as your URDF does)",
        _ => "the arm's base frame",
    };
    format!(
        "  camera in {parent}: ({:.1}, {:.1}, {:.1}) mm, roll {:.2} pitch {:.2} yaw {:.2} deg\n  \
         publish it: {}\n",
        t.x * 1e3,
        t.y * 1e3,
        t.z * 1e3,
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees(),
        tf.command()
    )
}

/// Where the board lies in the arm's base frame, when the camera rides the
/// flange: the calibration's base (in the board's frame, where it was
/// registered) turned round.
fn board_line(base: &model::Frame<f64>) -> String {
    let board = base.isometry().inverse();
    let t = board.translation.vector * 1e3;
    let (roll, pitch, yaw) = board.rotation.euler_angles();
    format!(
        "  board in the arm's base frame: ({:.1}, {:.1}, {:.1}) mm, roll {:.2} pitch {:.2} yaw {:.2} deg\n",
        t.x,
        t.y,
        t.z,
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    )
}

/// Writes the camera's files beside the calibration of `option`: its
/// intrinsics as a ROS `camera_info` YAML and its pose as a ROS 2 launch
/// file publishing the static transform; returns their paths.
fn write_camera_files(
    out: &Path,
    option: &str,
    intrinsics: &Intrinsics,
    tf: &StaticTransform,
) -> Result<[PathBuf; 2], Error> {
    let info = out.join(format!("camera_info-{option}.yaml"));
    write_text(
        &info,
        &intrinsics_file::to_camera_info(intrinsics, "camera"),
    )?;
    let launch = out.join(format!("camera_tf-{option}.launch.xml"));
    write_text(&launch, &tf.launch_xml())?;
    Ok([info, launch])
}

/// `--tool-only`: re-teaches the tool points of `--calibration` from the
/// measurements under the fitted load, its arm held fixed.
fn reteach(args: &Args, path: &Path, all: &[Measurement]) -> Result<(), Error> {
    let (cal, count) = reteach_tools(
        CalibrationFile::read(path)?,
        all,
        args.load_kg,
        &args.measurements.display().to_string(),
        &identify_options(args),
    )?;
    let out = create_out(args)?.join(format!("calibration-{}.json", cal.option));
    write_text(&out, &cal.to_json())?;
    println!(
        "tool points re-taught from {count} measurements with the arm of {} held fixed:",
        path.display()
    );
    print!("{}", summary::targets_table(&cal.targets));
    println!("  wrote {}", out.display());
    Ok(())
}

/// The poses of the list at `path` to fit, and the measurements to work
/// from: all of `all` for a list without validation poses (every measured
/// pose not fitted validates); for a list that marks some, only the
/// measurements of the poses it names, so that exactly its validation poses
/// are held out (none with `--no-hold-out`, which fits them too).
fn listed_poses(
    args: &Args,
    path: &Path,
    all: &[Measurement],
) -> Result<(Vec<u32>, Vec<Measurement>), Error> {
    let list = pose_list::read_listed(path)?;
    let mut fit = pose_list::ids_with_role(&list, PoseRole::Fit);
    let validate = pose_list::ids_with_role(&list, PoseRole::Validate);
    if validate.is_empty() {
        return Ok((fit, all.to_vec()));
    }
    let named: HashSet<u32> = fit.iter().chain(&validate).copied().collect();
    let kept: Vec<Measurement> = all
        .iter()
        .filter(|m| named.contains(&m.pose.id))
        .copied()
        .collect();
    let measured: HashSet<u32> = all.iter().map(|m| m.pose.id).collect();
    let unnamed = measured.iter().filter(|id| !named.contains(id)).count();
    if unnamed > 0 {
        println!(
            "{unnamed} measured poses are not in {} and are left out (it names the poses to fit and those to validate on)",
            path.display()
        );
    }
    let unmeasured = validate.iter().filter(|id| !measured.contains(id)).count();
    if unmeasured > 0 {
        eprintln!(
            "warning: {unmeasured} of the {} validation poses of {} have no measurement: the fit is validated on the other {}",
            validate.len(),
            path.display(),
            validate.len() - unmeasured
        );
    }
    if args.no_hold_out {
        println!(
            "fitting the {} validation poses of {} too (--no-hold-out): nothing is held out",
            validate.len(),
            path.display()
        );
        fit.extend(validate.iter().filter(|id| measured.contains(id)));
    } else {
        println!(
            "holding out the {} validation poses of {} (role `validate`): the fit never sees them",
            validate.len() - unmeasured,
            path.display()
        );
    }
    Ok((fit, kept))
}

/// The fit's options as the arguments set them.
fn identify_options(args: &Args) -> IdentifyOptions {
    IdentifyOptions {
        robust: !args.no_robust,
        ..Default::default()
    }
}

/// Creates the output folder if missing; its path.
fn create_out(args: &Args) -> Result<&Path, Error> {
    std::fs::create_dir_all(&args.out).map_err(|source| lrmcal_core::Error::Write {
        path: args.out.clone(),
        source,
    })?;
    Ok(&args.out)
}
