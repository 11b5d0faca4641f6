//! `lrmcal demo --camera`: the webcam path on a simulated arm, as a user
//! runs it. The bundled webcam setup is written into the folder (or the
//! one given is taken), and each step is the command a user types, run
//! through the command line's own parser: plan the poses the camera sees,
//! select N of them with DETMAX on the pixels they will give, take the
//! images (`simulate --images`: the simulated webcam renders the board on
//! the true arm), detect the tags, and identify the arm, the board and the
//! camera together. The calibration file is then judged against the
//! simulation's truth: where it puts the board at seen poses it was not
//! fitted to, and where it puts the camera.

use std::path::Path;
use std::time::Instant;

use nalgebra::{IsometryMatrix3, Point3};

use super::{Args, PAPER_LOAD_KG};
use crate::commands::helpers::write_text;
use crate::error::Error;
use lrmcal_core::camera::{CameraSetup, Mount, bundled, setup};
use lrmcal_core::dataset::{Pose, from_home};
use lrmcal_core::io::arm_source::ArmSource;
use lrmcal_core::io::{pose_list, read_text};
use lrmcal_engine::calib::results::export::rig_of;
use lrmcal_engine::calib::{Rig, Sample};
use lrmcal_engine::sim::{Pass, SimConfig, TrueArm, Webcam};

/// The calibration the camera path writes (the default option's).
const CALIBRATION: &str = "calibration/calibration-elasto-kinematic-servo.json";

/// Seen poses not fitted that the calibration is judged at, at most.
const CHECK_POSES: usize = 100;

/// A runner of `lrmcal` command lines (the CLI's own).
type Lrmcal<'a> = &'a dyn Fn(&[String]) -> Result<(), Error>;

/// Runs `lrmcal demo --camera`, each step's command line through `runner`.
pub fn run(args: &Args, runner: Lrmcal<'_>) -> Result<(), Error> {
    let started = Instant::now();
    let out = &args.out;
    std::fs::create_dir_all(out).map_err(|source| lrmcal_core::Error::Write {
        path: out.clone(),
        source,
    })?;
    let setup_path = match &args.camera_setup {
        Some(path) => path.clone(),
        None => bundled::write(
            out,
            if args.eye_in_hand {
                Mount::EyeInHand
            } else {
                Mount::EyeToHand
            },
        )?,
    };
    let setup = setup::read(&setup_path)?;
    let named = setup::parse(&read_text(&setup_path)?).map_err(|e| e.in_file(&setup_path))?;
    let folder = setup_path.parent().unwrap_or(Path::new(""));
    let at = |name: &str| out.join(name).display().to_string();
    let setup_arg = setup_path.display().to_string();
    let arm = arm_arguments(&args.arm);
    let seed = args.seed.to_string();

    lrmcal(
        runner,
        &["plan", "--camera", &setup_arg, "--out", &at("seen.csv")],
        &[&arm, &["--random".into(), args.random.to_string()]],
    )?;
    lrmcal(
        runner,
        &[
            "select",
            "--camera",
            &setup_arg,
            "--candidates",
            &at("seen.csv"),
            "--validate",
            "0",
            "--compare-random",
            "0",
            "--out",
            &at("selection.csv"),
        ],
        &[
            &arm,
            &[
                "--n".into(),
                args.poses.to_string(),
                "--starts".into(),
                args.starts.to_string(),
            ],
        ],
    )?;
    let loads = format!("0,{PAPER_LOAD_KG}");
    let simulate = words(
        &[
            "simulate",
            "--camera",
            &setup_arg,
            "--poses",
            &at("selection.csv"),
            "--loads",
            &loads,
            "--seed",
            &seed,
            "--images",
            &at("images"),
            "--truth",
            &at("truth.json"),
        ],
        &[&arm, &flag(args.model_only, "--model-only")],
    );
    run_words(runner, &simulate)?;
    lrmcal(
        runner,
        &[
            "detect",
            "--images",
            &at("images"),
            "--board",
            &folder.join(&named.board).display().to_string(),
            "--intrinsics",
            &folder.join(&named.intrinsics).display().to_string(),
            "--poses",
            &out.join("images").join("poses.csv").display().to_string(),
            "--out",
            &at("views.csv"),
        ],
        &[],
    )?;
    let load = PAPER_LOAD_KG.to_string();
    lrmcal(
        runner,
        &[
            "identify",
            "--camera",
            &setup_arg,
            "--measurements",
            &at("views.csv"),
            "--load-kg",
            &load,
            "--out",
            &at("calibration"),
        ],
        &[&arm, &flag(args.no_robust, "--no-robust")],
    )?;

    let check = judge(args, &setup)?;
    write_text(
        &out.join("check.json"),
        &serde_json::to_string_pretty(&check).unwrap_or_default(),
    )?;
    println!(
        "\nAgainst the simulation's truth (true arm seed {}):\n  \
         the board's origin at {} poses the camera sees that were not fitted: mean {:.2} mm \
         (the nominal arm where the setup puts it: {:.1} mm)\n  \
         the camera: {:.2} mm and {:.3}° off (the setup as told: {:.1} mm and {:.2}°), judged by \
         {}",
        args.seed,
        check.poses,
        check.board_mm,
        check.nominal_board_mm,
        check.camera_mm,
        check.camera_deg,
        check.told_camera_mm,
        check.told_camera_deg,
        match setup.mount {
            Mount::EyeToHand => "where each puts the arm's first joint frame at the zero command",
            Mount::EyeInHand => "where each puts the camera before the board at those poses",
        }
    );
    println!(
        "\nwrote {} (setup and board files, seen.csv, selection.csv, images/, views.csv, truth.json, \
         calibration/ with the calibration, report.json and report.html, check.json: the figures against the truth) in {:.1} s",
        out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The calibration's errors against the truth, and what another tool's
/// camera is judged by (`check.json`).
#[derive(serde::Serialize)]
struct Check {
    seed: u64,
    poses: usize,
    board_mm: f64,
    nominal_board_mm: f64,
    camera_mm: f64,
    camera_deg: f64,
    told_camera_mm: f64,
    told_camera_deg: f64,
    /// The true arm's first joint frame at the zero command in the true
    /// camera's frame, row by row (4 × 4, m); null eye-in-hand.
    true_frame1_in_camera: Option<[[f64; 4]; 4]>,
    /// The nominal arm's first joint frame at the zero command in the arm
    /// file's world frame, row by row (4 × 4, m): a camera found in that
    /// frame by another tool is judged by where it then sees this frame;
    /// null eye-in-hand.
    nominal_frame1_in_world: Option<[[f64; 4]; 4]>,
    /// The poses the board and camera figures are judged at, with where the
    /// true camera saw the true board there: another tool's calibration is
    /// judged at them as this one is.
    checked: Vec<CheckedPose>,
}

/// One pose the calibration is judged at.
#[derive(serde::Serialize)]
struct CheckedPose {
    /// The pose's id in `seen.csv`.
    pose: u32,
    /// The commanded joint angles, degrees.
    q_deg: Vec<f64>,
    /// The payload, kg.
    load_kg: f64,
    /// The true board in the true camera's frame, row by row (4 × 4, m).
    true_board_in_camera: [[f64; 4]; 4],
}

/// `pose` as a 4 × 4 matrix, row by row.
fn rows(pose: &IsometryMatrix3<f64>) -> [[f64; 4]; 4] {
    let m = pose.to_homogeneous();
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}

/// Judges the calibration the camera path wrote against the true arm and
/// webcam `simulate` drew (its defaults, or `--model-only`): the board's
/// origin in the camera frame at the planned poses not selected that the
/// true camera sees, under the paper's load, and the camera's place: by
/// where it sees the arm's first joint frame at the zero command when it
/// stands still, by where it stands before the board at those poses when
/// the arm carries it.
fn judge(args: &Args, setup: &CameraSetup) -> Result<Check, Error> {
    let nominal = args.arm.load()?.arm;
    let config = if args.model_only {
        SimConfig::model_only()
    } else {
        SimConfig::default()
    }
    .scaled_to(&nominal);
    let truth = TrueArm::draw(&nominal, args.seed, &config)?;
    let webcam = Webcam::draw(setup, args.seed, 0.0);
    let told = Webcam::as_told(setup);

    let selected: Vec<u32> = pose_list::read(&args.out.join("selection.csv"))?
        .iter()
        .map(|r| r.pose.id)
        .collect();
    let others: Vec<Pose> = pose_list::read(&args.out.join("seen.csv"))?
        .into_iter()
        .map(|r| r.pose)
        .filter(|p| !selected.contains(&p.id))
        .collect();
    let watched = truth.watch(
        &webcam,
        &[Pass {
            load_kg: PAPER_LOAD_KG,
            poses: &others,
        }],
    )?;
    let calibration = ArmSource::Calibration(args.out.join(CALIBRATION)).load()?;
    let rig = rig_of(&calibration);
    let nominal_rig = Rig::from(nominal);
    let mount = setup.mount;
    // The board in the camera frame as the calibration has it: its world is
    // what stood still (the camera's frame, or the board's), its tool frame
    // what the arm carried.
    let calibrated = |sample: &Sample| -> Result<IsometryMatrix3<f64>, Error> {
        let last = rig.evaluate(sample)?.deflection.frames.frames.last_value();
        let carried = last * rig.arm.tool.isometry();
        Ok(match mount {
            Mount::EyeToHand => carried,
            Mount::EyeInHand => carried.inverse(),
        })
    };
    let origin = |iso: &IsometryMatrix3<f64>| iso * Point3::origin();
    let (mut sum, mut nominal_sum, mut count) = (0.0, 0.0, 0usize);
    let (mut carried_mm, mut carried_deg, mut told_mm, mut told_deg) = (0.0, 0.0, 0.0, 0.0);
    let mut checked = Vec::new();
    for (view, flange) in watched.views.iter().zip(&watched.flanges).take(CHECK_POSES) {
        let sample = Sample::from(view);
        let actual = mount.camera_from_board(&webcam.camera, &webcam.board_pose, flange);
        checked.push(CheckedPose {
            pose: sample.id,
            q_deg: sample.q.iter().map(|q| q.to_degrees()).collect(),
            load_kg: sample.load_kg,
            true_board_in_camera: rows(&actual),
        });
        let predicted = calibrated(&sample)?;
        let nominal_flange = nominal_rig
            .evaluate(&sample)?
            .deflection
            .frames
            .frames
            .last_value();
        let guessed = mount.camera_from_board(&told.camera, &told.board_pose, &nominal_flange);
        sum += (origin(&predicted) - origin(&actual)).norm();
        nominal_sum += (origin(&guessed) - origin(&actual)).norm();
        // Where the camera stands before the board.
        let off = |seen: &IsometryMatrix3<f64>| {
            (
                1e3 * (origin(&seen.inverse()) - origin(&actual.inverse())).norm(),
                (seen * actual.inverse()).rotation.angle().to_degrees(),
            )
        };
        let ((mm, deg), (t_mm, t_deg)) = (off(&predicted), off(&guessed));
        (carried_mm, carried_deg) = (carried_mm + mm, carried_deg + deg);
        (told_mm, told_deg) = (told_mm + t_mm, told_deg + t_deg);
        count += 1;
    }
    let mean = |s: f64| s / count.max(1) as f64;
    if mount == Mount::EyeInHand {
        return Ok(Check {
            seed: args.seed,
            true_frame1_in_camera: None,
            nominal_frame1_in_world: None,
            poses: count,
            board_mm: 1e3 * mean(sum),
            nominal_board_mm: 1e3 * mean(nominal_sum),
            camera_mm: mean(carried_mm),
            camera_deg: mean(carried_deg),
            told_camera_mm: mean(told_mm),
            told_camera_deg: mean(told_deg),
            checked,
        });
    }
    let true_camera = webcam.camera.isometry().inverse();
    let told_camera = told.camera.isometry().inverse();

    // The arm's first joint frame at the zero command: the base's yaw and
    // height are one with joint 1's offsets, so the camera is judged by
    // where it sees that frame.
    let joints = nominal.joints.len();
    let zero = Sample {
        id: 0,
        q: model::PerJoint::splat(joints, 0.0),
        load_kg: 0.0,
        target: 0,
        approach: from_home(joints),
    };
    let frame1 = |rig: &Rig| rig.chain().frames(&rig.standing_angles(&zero), 0.0).frames[1];
    let true_frame1 = true_camera
        * truth
            .arm
            .chain()
            .frames(&truth.driven_angles(&zero.q, &zero.approach), 0.0)
            .frames[1];
    let off = |seen: IsometryMatrix3<f64>| {
        let off = seen.inverse() * true_frame1;
        (
            1e3 * off.translation.vector.norm(),
            off.rotation.angle().to_degrees(),
        )
    };
    let (camera_mm, camera_deg) = off(frame1(&rig));
    let (told_camera_mm, told_camera_deg) = off(told_camera * frame1(&nominal_rig));
    Ok(Check {
        seed: args.seed,
        true_frame1_in_camera: Some(rows(&true_frame1)),
        nominal_frame1_in_world: Some(rows(&frame1(&nominal_rig))),
        poses: count,
        board_mm: 1e3 * mean(sum),
        nominal_board_mm: 1e3 * mean(nominal_sum),
        camera_mm,
        camera_deg,
        told_camera_mm,
        told_camera_deg,
        checked,
    })
}

/// The `--arm` words of `arm` as a user types them.
fn arm_arguments(arm: &ArmSource) -> Vec<String> {
    match arm {
        ArmSource::Bundled(name) => vec!["--arm".into(), (*name).into()],
        ArmSource::Description(path) | ArmSource::Calibration(path) => {
            vec!["--arm".into(), path.display().to_string()]
        }
        ArmSource::Urdf {
            path,
            base_link,
            tip_link,
        } => {
            let mut words = vec!["--arm".into(), path.display().to_string()];
            if let Some(link) = base_link {
                words.extend(["--base-link".into(), link.clone()]);
            }
            if let Some(link) = tip_link {
                words.extend(["--tip-link".into(), link.clone()]);
            }
            words
        }
    }
}

/// `name` when `on`.
fn flag(on: bool, name: &str) -> Vec<String> {
    on.then(|| name.to_owned()).into_iter().collect()
}

/// The command line `lrmcal <first> <rest...>`.
fn words(first: &[&str], rest: &[&[String]]) -> Vec<String> {
    let mut line = vec!["lrmcal".to_owned()];
    line.extend(first.iter().map(|w| (*w).to_owned()));
    for part in rest {
        line.extend(part.iter().cloned());
    }
    line
}

/// Prints the command line and runs it.
fn run_words(runner: Lrmcal<'_>, line: &[String]) -> Result<(), Error> {
    println!("\n$ {}", line.join(" "));
    runner(line)
}

/// Runs `lrmcal <first> <rest...>`, printed first.
fn lrmcal(runner: Lrmcal<'_>, first: &[&str], rest: &[&[String]]) -> Result<(), Error> {
    run_words(runner, &words(first, rest))
}
