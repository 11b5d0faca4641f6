//! Tests of `ik`.

use super::*;
use crate::sim::test_support::bundled_arm;
use model::testing::TEST_ARM_JOINTS as JOINTS;
use nalgebra::{Matrix3x6, Vector6};

/// A pose drawn within `margin_rad` of every limit of `arm`.
fn random_pose(rng: &mut ChaCha8Rng, arm: &Arm<f64>, margin_rad: f64) -> [f64; JOINTS] {
    std::array::from_fn(|i| {
        let [lo, hi] = arm.joints[i].limits;
        rng.random_range(lo + margin_rad..=hi - margin_rad)
    })
}

/// Why the bundled arm cannot put its tool point at `target` from home.
fn refusal(arm: &Arm<f64>, target: [f64; 3]) -> IkError {
    let target = Vector3::from(target);
    match solve_position(arm, &target, &[0.0; JOINTS], &IkOptions::default()) {
        Ok(s) => panic!("solved: {:?}", s.q),
        Err(e) => e,
    }
}

fn no_collisions() -> IkOptions {
    IkOptions {
        collisions: None,
        ..IkOptions::default()
    }
}

#[test]
fn random_poses_round_trip_from_another_start() {
    let arm = bundled_arm();
    let chain = arm.chain();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..300 {
        let q = random_pose(&mut rng, &arm, 0.0);
        let start = random_pose(&mut rng, &arm, 0.0);
        let target = chain.rigid_tool_point(&q);
        let s = solve_position(&arm, &target, &start, &no_collisions())
            .unwrap_or_else(|e| panic!("{q:?} from {start:?}: {e}"));
        let reached = chain.rigid_tool_point(&s.q);
        assert!(
            (reached - target).norm() <= 1e-9,
            "{q:?}: {:e} m",
            s.error_m
        );
        assert_eq!(reached, s.tool_m);
        assert!(arm.within_limits(&s.q), "{:?}", s.q);
        assert!((s.distance_rad - solver::joint_distance(&s.q, &start)).abs() < 1e-15);
    }
}

/// A target a small joint change `δ` away is reached by a pose at most
/// `|δ|` from the start, and that pose is a nearest one: what separates
/// it from the start is normal to the solutions, `q − q0 = Jᵀ μ`.
#[test]
fn a_nearby_target_gets_a_nearby_pose_and_the_locally_nearest() {
    let arm = bundled_arm();
    let chain = arm.chain();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for _ in 0..100 {
        let q0 = random_pose(&mut rng, &arm, 0.2);
        let delta: [f64; JOINTS] = std::array::from_fn(|_| rng.random_range(-0.05..0.05));
        let moved: [f64; JOINTS] = std::array::from_fn(|i| q0[i] + delta[i]);
        let target = chain.rigid_tool_point(&moved);
        let s = solve_position(&arm, &target, &q0, &no_collisions()).unwrap();
        let delta_norm = solver::joint_distance(&moved, &q0);
        assert!(
            s.distance_rad <= delta_norm + 1e-9,
            "{} > {delta_norm}",
            s.distance_rad
        );
        let (_, j) = solver::position_jacobian(&chain, &s.q);
        let j: Matrix3x6<f64> = j.fixed_columns::<JOINTS>(0).into_owned();
        let away = Vector6::from_fn(|i, _| s.q[i] - q0[i]);
        let normal = j.transpose() * (j * j.transpose()).cholesky().unwrap().solve(&(j * away));
        assert!(
            (away - normal).norm() < 1e-9,
            "tangential part {:e}",
            (away - normal).norm()
        );
    }
}

#[test]
fn a_target_beyond_the_links_is_refused_at_once_with_the_distance() {
    let arm = bundled_arm();
    let e = refusal(&arm, [0.6, 0.0, 0.3]);
    let IkError::BeyondReach {
        distance_m,
        reach_m,
    } = e
    else {
        panic!("{e}")
    };
    assert!((distance_m - 0.6f64.hypot(0.3)).abs() < 1e-12);
    // 0.09 + 0.17 + 0.17 + 0.06 of links and |(0.02, 0, 0.05)| of tool offset.
    assert!((reach_m - (0.49 + 0.02f64.hypot(0.05))).abs() < 1e-12);
    assert_eq!(
        e.to_string(),
        "out of reach: the target is 670.8 mm from the arm's base, 127.0 mm beyond the 543.9 mm \
             its links reach end to end"
    );
}

/// Straight above the shoulder, 1.2 mm farther than the stretched arm gets
/// (0.17 + 0.17 and the wrist-to-tool 0.06 + (0.02, 0.05)), but inside
/// the sum of the links: the nearest point is the stretched arm's.
#[test]
fn a_target_just_out_of_reach_names_the_nearest_point() {
    let arm = bundled_arm();
    let stretched = 0.09 + 0.34 + 0.02f64.hypot(0.11);
    let e = refusal(&arm, [0.0, 0.0, 0.543]);
    let IkError::OutOfReach {
        nearest_m,
        residual_m,
        q,
    } = &e
    else {
        panic!("{e}")
    };
    assert!(
        (residual_m - (0.543 - stretched)).abs() < 1e-6,
        "{residual_m}"
    );
    assert!(
        (nearest_m - Vector3::new(0.0, 0.0, stretched)).norm() < 1e-5,
        "{nearest_m}"
    );
    assert_eq!(arm.chain().rigid_tool_point(q), *nearest_m);
    assert!(
        e.to_string()
            .contains("(0.0, 0.0, 541.8) mm, 1.197 mm from the target"),
        "{e}"
    );
}

/// With every joint held to ±20° the arm only stands nearly upright: a
/// point reached leaning over is reachable, but only beyond the limits.
#[test]
fn a_target_reachable_only_beyond_the_limits_names_the_joints() {
    let mut arm = bundled_arm();
    let target = arm
        .chain()
        .rigid_tool_point(&[0.0, 1.0, 0.5, 0.0, 0.3, 0.0]);
    for j in &mut arm.joints {
        j.limits = [-0.35, 0.35];
    }
    let e = refusal(&arm, target.into());
    let IkError::OutsideLimits { violations, q } = &e else {
        panic!("{e}")
    };
    assert!(!violations.is_empty());
    // The pose reported does reach the target, and breaks exactly the limits named.
    assert!((arm.chain().rigid_tool_point(q) - target).norm() <= 1e-9);
    for (i, &qi) in q.iter().enumerate() {
        let named = violations.iter().find(|v| v.joint == i + 1);
        assert_eq!(named.is_some(), qi.abs() > 0.35, "joint {} at {qi}", i + 1);
        if let Some(v) = named {
            assert_eq!(v.angle_rad, qi);
            assert_eq!(v.limit_rad, 0.35f64.copysign(qi));
        }
    }
    let text = e.to_string();
    assert!(
        text.starts_with("reachable only with joints beyond their limits"),
        "{text}"
    );
    assert!(
        text.contains("(limit 20.1°,") || text.contains("(limit -20.1°,"),
        "{text}"
    );
}

/// Below the ground plane every pose collides; without the collision test
/// the same target is solved.
#[test]
fn a_target_below_the_ground_collides_and_names_the_bodies() {
    let arm = bundled_arm();
    let target = Vector3::new(0.3, 0.0, -0.02);
    let e = refusal(&arm, target.into());
    let IkError::Colliding { contacts, q } = &e else {
        panic!("{e}")
    };
    assert!(
        contacts.iter().all(|c| matches!(c, Contact::Ground { .. })),
        "{contacts:?}"
    );
    assert!((arm.chain().rigid_tool_point(q) - target).norm() <= 1e-9);
    let text = e.to_string();
    assert!(
        text.starts_with("every pose found that reaches it within the joint limits collides: ")
            && text.contains("too close to the ground (the nearest at "),
        "{text}"
    );
    let s = solve_position(&arm, &target, &[0.0; JOINTS], &no_collisions()).unwrap();
    assert_eq!(s.q, *q);
}

/// A start pose that reaches its target but lays a body on the ground is
/// its own nearest solution; a farther pose clear of everything is taken.
#[test]
fn a_colliding_nearest_pose_gives_way_to_a_clear_one() {
    let arm = bundled_arm();
    let chain = arm.chain();
    let config = PlanConfig::default();
    let contact = |q: &[f64]| config.contact(&chain.frames(q, 0.0));
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let mut tried = 0;
    while tried < 5 {
        let start = random_pose(&mut rng, &arm, 0.0);
        let target = chain.rigid_tool_point(&start);
        if target.z < 0.1 || !matches!(contact(&start), Some(Contact::Ground { .. })) {
            continue;
        }
        tried += 1;
        let itself = solve_position(&arm, &target, &start, &no_collisions()).unwrap();
        assert!(itself.distance_rad < 1e-9);
        let s = solve_position(&arm, &target, &start, &IkOptions::default())
            .unwrap_or_else(|e| panic!("{start:?}: {e}"));
        assert_eq!(contact(&s.q), None);
        assert!(s.distance_rad > 0.01);
        assert!((s.tool_m - target).norm() <= 1e-9);
    }
}

/// The tool point of any in-limit pose clear of collisions, from any
/// start: solved, clear, and no farther from the start than that pose.
#[test]
fn clear_poses_are_found_again_from_random_starts() {
    let arm = bundled_arm();
    let chain = arm.chain();
    let config = PlanConfig::default();
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let mut solved = 0;
    while solved < 150 {
        let q = random_pose(&mut rng, &arm, 0.0);
        if config.contact(&chain.frames(&q, 0.0)).is_some() {
            continue;
        }
        solved += 1;
        let start = random_pose(&mut rng, &arm, 0.0);
        let s = solve_position(
            &arm,
            &chain.rigid_tool_point(&q),
            &start,
            &IkOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{q:?} from {start:?}: {e}"));
        assert_eq!(config.contact(&chain.frames(&s.q, 0.0)), None);
        let source = solver::joint_distance(&q, &start);
        assert!(
            s.distance_rad <= source + 1e-9,
            "{} > {source}",
            s.distance_rad
        );
    }
}

#[test]
fn bad_input_is_named() {
    let arm = bundled_arm();
    let opts = IkOptions::default();
    let t = Vector3::new(0.2, 0.0, 0.3);
    let e = solve_position(
        &arm,
        &Vector3::new(f64::NAN, 0.0, 0.0),
        &[0.0; JOINTS],
        &opts,
    );
    assert_eq!(
        e.unwrap_err().to_string(),
        "the target has a non-finite number"
    );
    let e = solve_position(&arm, &t, &[0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0], &opts);
    assert_eq!(
        e.unwrap_err().to_string(),
        "the start pose has a non-finite number"
    );
    let bad = IkOptions {
        tolerance_m: 0.0,
        ..IkOptions::default()
    };
    let e = solve_position(&arm, &t, &[0.0; JOINTS], &bad).unwrap_err();
    assert!(e.to_string().contains("`tolerance_m`"), "{e}");
    let bad = IkOptions {
        max_iterations: 0,
        ..IkOptions::default()
    };
    let e = solve_position(&arm, &t, &[0.0; JOINTS], &bad).unwrap_err();
    assert!(e.to_string().contains("`max_iterations`"), "{e}");
    let bad = IkOptions {
        collisions: Some(PlanConfig {
            clearance_m: -1.0,
            ..PlanConfig::default()
        }),
        ..IkOptions::default()
    };
    let e = solve_position(&arm, &t, &[0.0; JOINTS], &bad).unwrap_err();
    assert!(e.to_string().contains("clearance_m"), "{e}");
    let mut swapped = arm;
    swapped.joints[3].limits = [1.0, -1.0];
    let e = solve_position(&swapped, &t, &[0.0; JOINTS], &opts).unwrap_err();
    assert_eq!(e, IkError::Limits { joint: 4 });
}
