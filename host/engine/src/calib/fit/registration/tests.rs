//! Tests of `registration`.

use super::*;
use crate::calib::ModelOption;
use crate::calib::testing::{measure, rigid_nominal, small_samples, test_arm};
use nalgebra::Translation3;
use rand::{Rng, SeedableRng, rngs::StdRng};

const G: f64 = 9.80665;

fn random_frame(rng: &mut StdRng) -> IsometryMatrix3<f64> {
    let axis = Vector3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    );
    let angle = rng.random_range(-3.0..3.0);
    let t = Vector3::new(
        rng.random_range(-5.0..5.0),
        rng.random_range(-5.0..5.0),
        rng.random_range(-5.0..5.0),
    );
    IsometryMatrix3::from_parts(
        Translation3::from(t),
        Rotation3::from_scaled_axis(axis.normalize() * angle),
    )
}

fn moved(meas: &[Measurement], frame: &IsometryMatrix3<f64>) -> Vec<Measurement> {
    meas.iter()
        .map(|m| Measurement {
            position: frame.transform_point(&Point3::from(m.position)).coords,
            ..*m
        })
        .collect()
}

/// Registered poses must give the base's six coordinates on top of the
/// parameters; fewer coordinates than parameters are the fit's to refuse.
#[test]
fn a_registered_fit_needs_six_coordinates_more_than_its_parameters() {
    let option = ModelOption::ElastoKinematic;
    let e = check_registered_count(12, 36, 32, option).unwrap_err();
    assert!(
        e.to_string().contains("36 coordinates, fewer than the 6")
            && e.to_string().contains("--no-register"),
        "{e}"
    );
    assert!(check_registered_count(13, 39, 32, option).is_ok());
    assert!(check_registered_count(10, 30, 32, option).is_ok());
    // A camera's 29 views of 48 corners: 2784 coordinates.
    assert!(check_registered_count(29, 29 * 48 * 2, 84, option).is_ok());
}

/// A compliant arm measured from random frames: registration finds each
/// frame (to well below the fit's resolution), carries the gravity
/// along, and the nominal arm's distance after registration does not
/// depend on the frame.
#[test]
fn finds_the_frame_of_the_measurements() {
    let truth = test_arm();
    let meas = measure(&truth, &small_samples(30));
    let own = register(
        &rigid_nominal(),
        &meas,
        Gravity::Measured(truth.gravity_vector()),
    )
    .unwrap();
    let mut rng = StdRng::seed_from_u64(3);
    for _ in 0..5 {
        let frame = random_frame(&mut rng);
        let g = frame.rotation * truth.gravity_vector();
        let reg = register(
            &rigid_nominal(),
            &moved(&meas, &frame),
            Gravity::Measured(g),
        )
        .unwrap();
        let expected = frame * own.frame;
        assert!(
            (reg.frame.translation.vector - expected.translation.vector).norm() < 1e-9,
            "{reg:?}"
        );
        assert!((reg.frame.rotation.matrix() - expected.rotation.matrix()).norm() < 1e-9);
        assert!((reg.after_rms_m - own.after_rms_m).abs() < 1e-12);
        assert!((reg.gravity - g).norm() < 1e-12);
        assert!(reg.before_rms_m > 0.1, "{}", reg.before_rms_m);
        let in_arm = reg.arm_for_fit(&rigid_nominal()).gravity_vector();
        let own_arm = own.arm_for_fit(&rigid_nominal()).gravity_vector();
        assert!((in_arm - own_arm).norm() < 1e-9, "{in_arm} vs {own_arm}");
    }
}

/// Gross errors on a few points do not move the registration: they are
/// trimmed and named, and the rest is placed as without them.
#[test]
fn a_few_bad_points_are_trimmed() {
    let nominal = rigid_nominal();
    let meas = measure(&nominal, &small_samples(30));
    let clean = register(&nominal, &meas, Gravity::LevelBase(G)).unwrap();
    let mut bad = meas.clone();
    bad[4].position.x += 0.4;
    bad[17].position.z -= 0.25;
    let reg = register(&nominal, &bad, Gravity::LevelBase(G)).unwrap();
    assert_eq!(reg.trimmed, [(4, 0.0), (17, 0.0663)]);
    assert!(
        reg.frame.translation.vector.norm() < 1e-9,
        "{:?}",
        reg.frame
    );
    assert!(clean.trimmed.is_empty() && clean.after_rms_m < 1e-9);
    assert!(reg.after_max_m > 0.25);
}

/// A tool point 3 cm off in the file is found exactly from exact
/// measurements; with only joint 1 turning, a shift of the tool point
/// along its axis is one of the base, so the file's is kept.
#[test]
fn the_tool_point_is_found_when_the_last_link_turns() {
    let nominal = rigid_nominal();
    let mut truth = nominal;
    truth.tool.xyz[0] += 0.03;
    truth.tool.xyz[1] -= 0.01;
    let reg = register(
        &nominal,
        &measure(&truth, &small_samples(20)),
        Gravity::LevelBase(G),
    )
    .unwrap();
    let found = reg.tool.expect("found");
    assert!(
        (found - Vector3::from(truth.tool.xyz)).norm() < 1e-9,
        "{found}"
    );
    assert!(reg.after_rms_m < 1e-9 && reg.tool_turn > MIN_TOOL_TURN);
    assert_eq!(Vector3::from(reg.arm_for_fit(&nominal).tool.xyz), found);

    let pan: Vec<Sample> = (0..12)
        .map(|i| Sample {
            id: i,
            q: [0.3 * i as f64 - 1.5, 0.3, -0.4, 0.2, 0.5, 0.1].into(),
            load_kg: 0.0,
            target: 0,
            approach: lrmcal_core::dataset::from_home(6),
        })
        .collect();
    let reg = register(&nominal, &measure(&truth, &pan), Gravity::LevelBase(G)).unwrap();
    assert!(reg.tool.is_none() && reg.tool_turn < 1e-6, "{reg:?}");
    assert_eq!(reg.arm_for_fit(&nominal).tool, nominal.tool);
}

/// The level-base rule puts gravity along frame 0's -z, whatever frame the points are in.
#[test]
fn a_level_base_gives_gravity_along_its_z() {
    let nominal = rigid_nominal();
    let frame = random_frame(&mut StdRng::seed_from_u64(8));
    let meas = moved(&measure(&nominal, &small_samples(12)), &frame);
    let reg = register(&nominal, &meas, Gravity::LevelBase(G)).unwrap();
    assert!((reg.gravity - frame.rotation * Vector3::new(0.0, 0.0, -G)).norm() < 1e-9);
    assert!(reg.base_tilt_rad < 1e-9);
}

fn refused(meas: &[Measurement]) -> String {
    register(&rigid_nominal(), meas, Gravity::LevelBase(G))
        .unwrap_err()
        .to_string()
}

#[test]
fn metres_radians_swapped_columns_and_mirrors_are_named() {
    let meas = measure(&rigid_nominal(), &small_samples(30));
    let mut metres = meas.clone();
    metres.iter_mut().for_each(|m| m.position /= 1000.0);
    let e = refused(&metres);
    assert!(e.contains("metres in millimetre columns"), "{e}");
    let mut swapped = meas.clone();
    swapped.iter_mut().for_each(|m| m.pose.q.swap(1, 2));
    let e = refused(&swapped);
    assert!(e.contains("q2_deg and q3_deg look swapped"), "{e}");
    let mut radians = meas.clone();
    radians
        .iter_mut()
        .for_each(|m| m.pose.q = m.pose.q.map(f64::to_radians));
    let e = refused(&radians);
    assert!(e.contains("radians in degree columns"), "{e}");
    let mut mirrored = meas.clone();
    mirrored
        .iter_mut()
        .for_each(|m| m.position.y = -m.position.y);
    let e = refused(&mirrored);
    assert!(e.contains("mirrored"), "{e}");
    let mut line = meas[..2].to_vec();
    line.push(meas[0]);
    let e = refused(&line);
    assert!(e.contains("on a line"), "{e}");
}

/// Nothing that a usual mistake explains gets the general advice.
#[test]
fn an_unexplained_misfit_says_what_to_check() {
    let meas = measure(&rigid_nominal(), &small_samples(30));
    let mut rng = StdRng::seed_from_u64(1);
    let scrambled: Vec<Measurement> = meas
        .iter()
        .map(|m| Measurement {
            position: Vector3::new(
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
            ),
            ..*m
        })
        .collect();
    let e = refused(&scrambled);
    assert!(
        e.contains(GENERIC_HINT) && e.contains("expected within 150 mm"),
        "{e}"
    );
}
