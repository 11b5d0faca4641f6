//! `lrmcal identify` on measurements in a tracker's frame: registered by
//! default, printed and recorded; `--up`, `--no-register`; and the mistakes
//! that no rigid motion explains, each named with what to check.

mod common;

use common::{default_calibration_file, lrmcal, p, text};

use std::path::Path;
use std::process::Output;

use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::measurements;
use nalgebra::{Rotation3, Vector3};

/// Simulated measurements of the bundled arm (one load) rewritten by `edit`
/// into `dir/NAME`.
fn rewritten(dir: &Path, name: &str, edit: impl Fn(&mut Measurement)) -> String {
    let meas = dir.join("m.csv");
    if !meas.exists() {
        let out = lrmcal(&["simulate", "--loads", "0.0663", "--out", p(&meas)]);
        assert!(out.status.success(), "{}", text(&out));
    }
    let mut rows = measurements::read(&meas).expect("simulated file");
    rows.iter_mut().for_each(edit);
    let path = dir.join(name);
    measurements::write(&path, &rows, &[model::JointKind::Revolute; 6]).expect("write");
    p(&path).to_owned()
}

fn identify(meas: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "identify",
        "--measurements",
        meas,
        "--select",
        "40",
        "--starts",
        "2",
        "--out",
        p(out),
    ];
    args.extend_from_slice(extra);
    lrmcal(&args)
}

/// A Y-up tracker 1.5 m from the arm, turned 30 degrees about its up axis:
/// without registration the nominal arm is metres off and refused; with it
/// the base is found, printed and recorded, and the calibration is as good
/// as in the arm's own frame (same seed, same poses).
#[test]
fn a_y_up_tracker_frame_is_registered() {
    let dir = tempfile::tempdir().unwrap();
    // Arm z -> tracker y (Y-up), then 30 degrees about the tracker's y, 1.5 m away.
    let turn = Rotation3::from_axis_angle(&Vector3::y_axis(), 30f64.to_radians())
        * Rotation3::from_axis_angle(&Vector3::x_axis(), -90f64.to_radians());
    let shift = Vector3::new(1.5, 0.2, -0.4);
    let seen = rewritten(dir.path(), "y-up.csv", |m| {
        m.position = turn * m.position + shift;
    });
    let own = rewritten(dir.path(), "own.csv", |_| {});

    let refused = identify(
        &seen,
        &dir.path().join("no"),
        &["--no-register", "--up", "+y"],
    );
    assert_eq!(refused.status.code(), Some(3), "{}", text(&refused));
    let e = text(&refused);
    assert!(
        e.contains("from where the nominal arm puts the tool") && e.contains("joint columns"),
        "{e}"
    );

    let out = identify(&seen, &dir.path().join("cal"), &["--up", "+y"]);
    assert!(out.status.success(), "{}", text(&out));
    let printed = text(&out);
    assert!(
        printed.contains("Registered the arm in the measurement frame: base at (")
            && printed.contains("after registration"),
        "{printed}"
    );
    assert!(
        !printed.contains("warning: the registered base is tilted"),
        "{printed}"
    );
    let cal = CalibrationFile::read(&dir.path().join("cal").join(default_calibration_file()))
        .expect("calibration file");
    let reg = cal.registration.expect("registration recorded");
    assert!(reg.registered);
    // Both arms are in the tracker's frame: the nominal on the closed-form
    // base, the calibrated one on the base the fit refined, where the
    // frame put the arm.
    assert_eq!(cal.nominal.base, reg.base);
    assert!(
        (Vector3::from(reg.base.xyz) - shift).norm() < 0.05,
        "{reg:?}"
    );
    let refined = cal.arm.base;
    assert!(
        (Vector3::from(refined.xyz) - shift).norm() < 0.01,
        "{refined:?}"
    );
    assert!(
        (refined.rpy[0].to_degrees() + 90.0).abs() < 2.0,
        "{refined:?}"
    );
    assert!(
        (refined.rpy[1].to_degrees() - 30.0).abs() < 2.0,
        "{refined:?}"
    );
    assert!((Vector3::from(cal.arm.gravity) - Vector3::new(0.0, -9.80665, 0.0)).norm() < 1e-9);
    assert!((Vector3::from(reg.gravity) - Vector3::new(0.0, -9.80665, 0.0)).norm() < 1e-9);
    assert!(reg.before_rms_m > 1.0 && reg.after_rms_m < 0.05, "{reg:?}");

    let out = identify(&own, &dir.path().join("own"), &[]);
    assert!(out.status.success(), "{}", text(&out));
    let own_cal =
        CalibrationFile::read(&dir.path().join("own").join(default_calibration_file())).unwrap();
    let (a, b) = (
        cal.validation.expect("validated").after.mean_m,
        own_cal.validation.expect("validated").after.mean_m,
    );
    assert!(
        (a - b).abs() < 0.02 * b,
        "tracker frame {a} m, own frame {b} m"
    );

    // validate takes measurements in the tracker's frame.
    let out = lrmcal(&[
        "validate",
        "--calibration",
        p(&dir.path().join("cal").join(default_calibration_file())),
        "--measurements",
        &seen,
    ]);
    assert!(out.status.success(), "{}", text(&out));

    // Without --up, the arm file's Z gravity makes the registered base lie on its side.
    let out = identify(&seen, &dir.path().join("tilted"), &[]);
    assert!(
        text(&out).contains("warning: the registered base is tilted"),
        "{}",
        text(&out)
    );
}

#[test]
fn metres_and_swapped_joint_columns_say_what_to_check() {
    let dir = tempfile::tempdir().unwrap();
    let metres = rewritten(dir.path(), "metres.csv", |m| m.position /= 1000.0);
    let out = identify(&metres, &dir.path().join("a"), &[]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out));
    let e = text(&out);
    assert!(
        e.contains("register the arm") && e.contains("metres in millimetre columns"),
        "{e}"
    );

    let swapped = rewritten(dir.path(), "swapped.csv", |m| m.pose.q.swap(1, 2));
    let out = identify(&swapped, &dir.path().join("b"), &[]);
    assert_eq!(out.status.code(), Some(3), "{}", text(&out));
    let e = text(&out);
    assert!(e.contains("q2_deg and q3_deg look swapped"), "{e}");
}
