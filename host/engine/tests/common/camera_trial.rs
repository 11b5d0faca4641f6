//! The camera as the instrument, end to end on a simulated arm: a webcam
//! placed off its setup watches the board on a true arm (servo errors,
//! play, softening springs), its views become measurements, and the one
//! calibration run fits the arm, the board and the camera from the pixels.
//! Judged against the simulator's truth where a user would judge it: the
//! board's point the calibrated arm predicts at poses it never saw, and
//! where it puts the camera relative to the arm. Shared by the test
//! (`tests/camera_fit.rs`, one seed) and the figures (`examples/camera_figures.rs`).

use std::path::Path;

use lrmcal_core::camera::{CameraSetup, Intrinsics, Mount, setup};
use lrmcal_core::dataset::Pose;
use lrmcal_core::io::arm_source::ArmSource;
use lrmcal_engine::calib::Sample;
use lrmcal_engine::calib::fit::registration::Gravity;
use lrmcal_engine::calib::progress::Silent;
use lrmcal_engine::calib::run::{CameraInput, Placement, PoseChoice, Request, calibrate};
use lrmcal_engine::camera::corner_measurements::corner_measurements;
use lrmcal_engine::plan::{PlanConfig, candidates};
use lrmcal_engine::sim::{Pass, SimConfig, TrueArm, Webcam};
use nalgebra::{IsometryMatrix3, Point3};

/// What one seed's camera calibration gives.
pub struct Trial {
    /// Mean distance of the calibrated arm's board origin from the truth at
    /// 40 poses the fit never saw, mm.
    pub board_mm: f64,
    /// The same for the nominal arm, registered, mm.
    pub nominal_mm: f64,
    /// The same for the arm calibrated by a tracker on the board's origin
    /// at the same poses (0.15 mm of noise), mm.
    pub tracker_mm: f64,
    /// How far the fitted camera is from where it stands: relative to the
    /// arm's first joint frame at the zero command when it stands still,
    /// relative to the board at the unseen poses (the mean) when the arm
    /// carries it, mm.
    pub camera_mm: f64,
    /// And turned, degrees.
    pub camera_deg: f64,
    /// How far the lens the calibration ends with projects from the true
    /// lens, over a grid of the image's rays: the RMS, px.
    pub lens_px: f64,
}

/// What the calibration is told of the lens, and what it does with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lens {
    /// The setup's intrinsics are the camera's, held.
    Calibrated,
    /// The camera's lens is off the setup's intrinsics (as a nominal lens
    /// is): the focal lengths by 3 %, k1 by 0.04 and k2 by -0.03.
    /// `refine`: the fit refines the lens; otherwise it holds the setup's.
    Off {
        /// Whether the fit refines the lens.
        refine: bool,
    },
}

/// The lens `told` off by [`Lens::Off`]'s amounts: the camera's true lens.
fn lens_off(told: &Intrinsics) -> Intrinsics {
    let mut distortion = told.distortion;
    distortion[0] += 0.04;
    distortion[1] -= 0.03;
    Intrinsics {
        fx: told.fx * 1.03,
        fy: told.fy * 1.03,
        distortion,
        ..told.clone()
    }
}

/// The RMS distance, px, between where `fitted` and `truth` project the
/// rays of a 9 × 5 grid of the true image.
fn lens_rms_px(fitted: &Intrinsics, truth: &Intrinsics) -> f64 {
    let (w, h) = (f64::from(truth.width_px), f64::from(truth.height_px));
    let mut sum = 0.0;
    let mut n = 0.0;
    for i in 0..9 {
        for j in 0..5 {
            let pixel = nalgebra::Point2::new(
                w * (0.05 + 0.9 * f64::from(i) / 8.0),
                h * (0.05 + 0.9 * f64::from(j) / 4.0),
            );
            let ray = truth.undistort(&pixel).unwrap();
            let seen = fitted.project(&Point3::new(ray.x, ray.y, 1.0)).unwrap();
            sum += (seen - pixel).norm_squared();
            n += 1.0;
        }
    }
    (sum / n).sqrt()
}

/// The bundled setup of `mount`: the webcam before the arm, or on its flange.
fn camera_setup(mount: Mount) -> CameraSetup {
    let file = match mount {
        Mount::EyeToHand => "setup.toml",
        Mount::EyeInHand => "setup-eye-in-hand.toml",
    };
    setup::read(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../core/arms/lrm-webcam")
            .join(file),
    )
    .unwrap()
}

/// Seed `seed`'s true arm and webcam, the camera and the board carried as
/// `mount` says, 60 poses the camera sees fitted under 66.3 g with 0.3 px
/// of corner noise, 40 others checked.
pub fn trial(seed: u64, lens: Lens, mount: Mount) -> Trial {
    let loaded = ArmSource::Bundled("lrm").load().unwrap();
    let setup = camera_setup(mount);
    let config = PlanConfig {
        camera: Some(setup.clone()),
        random: 400,
        ..PlanConfig::for_loaded(&loaded).unwrap()
    };
    let planned: Vec<Pose> = candidates(&loaded.arm, &config).unwrap().kept;
    let load_kg = 0.0663;

    let truth = TrueArm::draw(&loaded.arm, seed, &SimConfig::default()).unwrap();
    let mut webcam = Webcam::draw(&setup, seed, 0.3);
    if let Lens::Off { .. } = lens {
        webcam.intrinsics = lens_off(&setup.intrinsics);
    }
    // The poses the camera really sees (the setup is told roughly, so
    // some planned ones fall out of the image): every third for the fit,
    // the next ones to check it.
    let seen: Vec<Pose> = truth
        .watch(
            &webcam,
            &[Pass {
                load_kg,
                poses: &planned,
            }],
        )
        .unwrap()
        .views
        .iter()
        .map(|v| v.pose)
        .collect();
    let fit: Vec<Pose> = seen.iter().step_by(3).take(60).copied().collect();
    let check: Vec<Pose> = seen.iter().skip(1).step_by(3).take(40).copied().collect();
    assert_eq!((fit.len(), check.len()), (60, 40), "{} seen", seen.len());
    let watched = truth
        .watch(
            &webcam,
            &[Pass {
                load_kg,
                poses: &fit,
            }],
        )
        .unwrap();
    let (measurements, corners) =
        corner_measurements(&setup.intrinsics, &setup.board, &watched.views, setup.mount).unwrap();
    let camera = CameraInput {
        corners,
        refine_lens: lens == Lens::Off { refine: true },
        ..CameraInput::of_setup(&setup)
    };
    let nominal = camera.nominal_arm(&loaded.arm);
    let g = nominal.gravity_vector().norm();
    let request = Request::new(&nominal, &measurements)
        .camera(camera)
        .placement(Placement::Register(Gravity::LevelBase(g)))
        .poses(PoseChoice::All);
    let run = calibrate(&request, &Silent).unwrap();
    let result = &run.results[0];

    // A tracker on what the flange carries at the same poses (0.15 mm of
    // noise, its frame the arm's world): what the camera is compared with.
    let on_flange = match mount {
        Mount::EyeToHand => webcam.board_pose,
        Mount::EyeInHand => webcam.camera,
    };
    let mut tracked = truth.clone();
    tracked.arm.tool = on_flange;
    tracked.config.noise_sigma_m = 0.15e-3;
    let points = tracked.measure(&fit, &[load_kg]).unwrap();
    let tracker_run = calibrate(&Request::new(&nominal, &points), &Silent).unwrap();
    let tracker_rig = &tracker_run.results[0].identified.rig;
    let rig = &result.identified.rig;
    let fitted_lens = rig.camera.as_ref().unwrap().lens_now();
    let frame = run.registration.frame;

    // The board in the camera frame: as a rig predicts it at `sample` (its
    // servo curves as fitted, the commands sent through the nominal ones;
    // the fit's world carried to the measurements' frame, the camera's or
    // the board's), and as it is.
    let predicted = |rig: &lrmcal_engine::calib::Rig, sample: &Sample| {
        let last = rig
            .evaluate(sample)
            .unwrap()
            .deflection
            .frames
            .frames
            .last_value();
        let carried = last * rig.arm.tool.isometry();
        match mount {
            Mount::EyeToHand => frame * carried,
            Mount::EyeInHand => carried.inverse() * frame.inverse(),
        }
    };
    let actual = |sample: &Sample| {
        let driven = truth.driven_angles(&sample.q, &sample.approach);
        let flange = truth
            .deflection(&driven, sample.load_kg)
            .unwrap()
            .frames
            .frames
            .last_value();
        let seen = mount.camera_from_board(&webcam.camera, &webcam.board_pose, &flange);
        (seen, flange * on_flange.isometry())
    };
    let origin = |iso: &IsometryMatrix3<f64>| iso * Point3::origin();
    let mut sum = 0.0;
    let mut nominal_sum = 0.0;
    let mut tracker_sum = 0.0;
    // A camera on the flange: where it stands before the board at each
    // unseen pose, predicted against true (mm, degrees summed).
    let (mut carried_mm, mut carried_deg) = (0.0, 0.0);
    let ways = lrmcal_core::dataset::approaches(check.iter().map(|p| &p.q));
    for (pose, approach) in check.iter().zip(ways) {
        let sample = Sample {
            id: pose.id,
            q: pose.q,
            load_kg,
            target: 0,
            approach,
        };
        let (seen, carried) = actual(&sample);
        let fitted = predicted(rig, &sample);
        sum += (origin(&fitted) - origin(&seen)).norm();
        let off = fitted * seen.inverse();
        carried_mm +=
            1e3 * (fitted.inverse() * Point3::origin() - seen.inverse() * Point3::origin()).norm();
        carried_deg += off.rotation.angle().to_degrees();
        let nominal_rig = lrmcal_engine::calib::Rig::from(nominal);
        nominal_sum += (origin(&predicted(&nominal_rig, &sample)) - origin(&seen)).norm();
        tracker_sum +=
            (Point3::from(tracker_rig.evaluate(&sample).unwrap().tool_m) - origin(&carried)).norm();
    }

    // The camera relative to the arm's first joint frame, the arm standing
    // at the zero command (rigid, no load): the base's yaw and height are
    // confounded with joint 1's theta and d (and its servo's shift at zero),
    // so the base frame alone is one of many the same arm can be written
    // in; frame 1 as the arm stands is the one every writing agrees on.
    let zero = Sample {
        id: 0,
        q: model::PerJoint::splat(nominal.joints.len(), 0.0),
        load_kg: 0.0,
        target: 0,
        approach: lrmcal_core::dataset::from_home(nominal.joints.len()),
    };
    // A camera on the flange is judged by where it stands before the board
    // at the unseen poses (its place on the flange is confounded the same
    // way with the last joint's parameters, and the zero command may be
    // far from any pose it saw the board at).
    let n = check.len() as f64;
    let (camera_mm, camera_deg) = match mount {
        Mount::EyeToHand => {
            let true_camera = webcam.camera.isometry();
            let fitted_frame1 =
                frame * rig.chain().frames(&rig.standing_angles(&zero), 0.0).frames[1];
            let true_frame1 = true_camera.inverse()
                * truth
                    .arm
                    .chain()
                    .frames(&truth.driven_angles(&zero.q, &zero.approach), 0.0)
                    .frames[1];
            let off = fitted_frame1.inverse() * true_frame1;
            (
                1e3 * off.translation.vector.norm(),
                off.rotation.angle().to_degrees(),
            )
        }
        Mount::EyeInHand => (carried_mm / n, carried_deg / n),
    };
    Trial {
        board_mm: 1e3 * sum / check.len() as f64,
        nominal_mm: 1e3 * nominal_sum / check.len() as f64,
        tracker_mm: 1e3 * tracker_sum / check.len() as f64,
        camera_mm,
        camera_deg,
        lens_px: lens_rms_px(&fitted_lens, &webcam.intrinsics),
    }
}
