//! The compensation in every servo frame: its report, its fading in and
//! out, holding steady across a new calibration, and its accuracy against
//! the host's f64 model.

use super::*;

#[test]
fn compensation_runs_every_frame_and_reports() {
    let mut h = Harness::boot(SimFlash::new());
    h.push(&test_calibration(3));
    h.request(&Request::SetPayload { mass_kg: 0.0663 });
    assert_eq!(
        h.request(&Request::SetPayload { mass_kg: f32::NAN }),
        Response::Error(WireError::NotFinite)
    );
    assert_eq!(
        h.request(&Request::SetPayload { mass_kg: 5.0 }),
        Response::Error(WireError::OutOfRange)
    );
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(60);
    let off = h.dev.bus().now;
    assert_eq!(
        h.request(&Request::SetCompensation {
            mode: CompensationMode::Full
        }),
        Response::Done
    );
    h.frames(5);
    let s = h.status();
    assert!(s.compensation.converged, "{:?}", s.compensation);
    assert_ne!(h.dev.bus().now, off, "compensation changes the pulses");
    h.move_to([0.3, 0.6, -0.4, 0.2, 0.8, 0.1]);
    h.frames(150);
    let s = h.status();
    assert!(
        s.compensation.converged && !s.faults.contains(Faults::COMPENSATION_FALLBACK),
        "{s:?}"
    );
}

/// `status` counts the compensation's solver steps from the start of the
/// current move, not since boot: after a long move and a short one, it
/// shows the short one's steps.
#[test]
fn the_solver_steps_in_status_count_from_the_start_of_the_move() {
    let mut h = Harness::boot(SimFlash::new());
    h.push(&test_calibration(5));
    h.request(&Request::SetPayload { mass_kg: 0.0663 });
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(60);
    h.request(&Request::SetCompensation {
        mode: CompensationMode::Full,
    });
    h.frames(30);
    // A long move: a step every frame while the targets move.
    h.move_to([0.6, 0.8, -0.6, 0.4, 0.9, 0.2]);
    let mut frames = 0;
    while h.status().moving {
        h.frames(1);
        frames += 1;
    }
    let long = h.status().compensation;
    assert!(
        long.converged && usize::from(long.iterations) >= frames / 2,
        "{long:?}, {frames} frames"
    );
    // A short one after it.
    h.move_to([0.6, 0.8, -0.58, 0.4, 0.9, 0.2]);
    let mut short_frames = 0;
    while h.status().moving {
        h.frames(1);
        short_frames += 1;
    }
    let short = h.status().compensation;
    assert!(short.converged, "{short:?}");
    assert!(
        usize::from(short.iterations) <= short_frames,
        "{short:?} after {short_frames} frames (the long move took {} steps)",
        long.iterations
    );
}

#[test]
fn switching_compensation_fades_the_correction_in_and_out() {
    let mut h = Harness::boot(SimFlash::new());
    h.push(&test_calibration(4));
    h.request(&Request::SetPayload { mass_kg: 0.0663 });
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(100);
    let off = h.dev.bus().now;
    let per_frame = largest_fading_step_us(&test_calibration(4));
    for mode in [CompensationMode::Full, CompensationMode::Off] {
        assert_eq!(
            h.request(&Request::SetCompensation { mode }),
            Response::Done
        );
        h.frames(1);
        assert!(
            h.status().moving,
            "{mode:?}: the servos move while the correction fades"
        );
        let mut last = h.dev.bus().now;
        for _ in 0..100 {
            h.frames(1);
            let now = h.dev.bus().now;
            for i in 0..6 {
                let jump = (f32::from(now[i].unwrap()) - f32::from(last[i].unwrap())).abs();
                assert!(
                    jump <= per_frame,
                    "{mode:?} joint {i}: {jump} µs in one frame"
                );
            }
            last = now;
        }
        assert!(!h.status().moving, "{mode:?}: the fade is over");
        if mode == CompensationMode::Full {
            let moved = (0..6)
                .map(|i| (i32::from(last[i].unwrap()) - i32::from(off[i].unwrap())).abs())
                .max();
            assert!(
                moved.unwrap() as f32 > 2.0 * per_frame,
                "the correction spans several frames"
            );
        } else {
            assert_eq!(last, off, "off again: back to the plain curves");
        }
    }
}

#[test]
fn a_new_calibration_or_an_erase_does_not_step_the_held_servos() {
    let mut h = Harness::boot(SimFlash::new());
    h.push(&test_calibration(1));
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(100);
    // Calibration 2: every servo curve shifted by 40 µs (≈ 0.09 rad).
    let mut next = test_calibration(2);
    for j in &mut next.calibrated.joints {
        for p in j.servo.as_mut().unwrap().pulses_us_mut() {
            *p += 40.0;
        }
    }
    let per_frame = largest_fading_step_us(&next);
    for step in [Request::CalibrationErase, Request::Status] {
        let before = h.dev.bus().now;
        if step == Request::CalibrationErase {
            assert_eq!(h.request(&step), Response::Done);
        } else {
            assert!(matches!(h.push(&next), Response::CalibrationStored(_)));
        }
        let mut last = before;
        for _ in 0..100 {
            h.frames(1);
            let now = h.dev.bus().now;
            for i in 0..6 {
                let jump = (f32::from(now[i].unwrap()) - f32::from(last[i].unwrap())).abs();
                assert!(jump <= per_frame, "{step:?}: joint {i} jumped {jump} µs");
            }
            last = now;
        }
        assert!(!h.status().moving);
    }
    // In the end the servos sit where calibration 2's curves put the home pose.
    for (i, (joint, home)) in next.calibrated.joints.iter().zip(next.home_rad).enumerate() {
        let expected = joint.servo.unwrap().pulse_us(home).round() as u16;
        assert_eq!(h.dev.bus().now[i], Some(expected), "joint {i}");
    }
}

/// Committing the calibration in use again (another id, the same arm, a
/// twisted link) while the arm holds a compensated pose changes no pulse:
/// the solve goes on from the shape the arm holds, which has settled.
#[test]
fn the_same_calibration_committed_again_keeps_the_held_pulses() {
    let mut h = Harness::boot(SimFlash::new());
    let mut cal = test_calibration(1);
    cal.calibrated.joints[1].beta = 0.004;
    h.push(&cal);
    h.request(&Request::SetCompensation {
        mode: CompensationMode::Full,
    });
    h.move_to([0.4, -0.3, 0.5, 0.2, -0.6, 0.3]);
    while h.status().moving {
        h.frames(1);
    }
    h.frames(50);
    let held = h.dev.bus().now;
    cal.id = 2;
    assert!(matches!(h.push(&cal), Response::CalibrationStored(_)));
    for frame in 0..50 {
        h.frames(1);
        assert_eq!(h.dev.bus().now, held, "frame {frame} after the commit");
    }
}

/// Holding at a target the calibrated arm cannot reach exactly (the stretched,
/// singular zero pose), the per-frame solve ends on its best command instead
/// of creeping on: the command stops changing, and the report says so.
#[test]
fn an_unreachable_holding_target_ends_the_solve() {
    let cal = test_calibration(3);
    let mut comp = crate::compensator::Compensator::new(&cal, Config::default().compensation, 0.35);
    let q = [0.0f32; 6];
    let mut commands = std::vec::Vec::new();
    for _ in 0..60 {
        commands.push(comp.step(&q, CompensationMode::Full, 0.0663));
    }
    let last = commands[commands.len() - 1];
    assert!(
        commands[40..].iter().all(|c| *c == last),
        "{:?}",
        &commands[40..]
    );
    let report = comp.report();
    assert!(!report.converged && report.error_um > 100.0, "{report:?}");
}

/// The firmware's f32 compensation against the host's f64 model: the
/// calibrated arm (f64) commanded with the f32 solution reaches the nominal
/// target within 0.05 mm, over 1000 random reachable targets, both payloads.
/// "Reachable" is decided by the f64 model: its solve from the nominal
/// command converges to 0.1 µm within 60 iterations.
#[test]
fn f32_compensation_matches_the_f64_model_within_50_um() {
    f32_compensation_matches_the_f64_model(&test_calibration(5), 1000);
}

/// The same for an arm of five joints (the six-joint arm without its last
/// wrist joint), over 300 targets.
#[test]
fn f32_compensation_of_five_joints_matches_the_f64_model_within_50_um() {
    f32_compensation_matches_the_f64_model(&test_calibration_of(5, 5), 300);
}

fn f32_compensation_matches_the_f64_model(cal: &Calibration, targets: usize) {
    let joints = cal.calibrated.joint_count();
    let nominal64 = cal.nominal.map(f64::from).chain();
    let calibrated64 = cal.calibrated.map(f64::from).chain();
    let opts64 = model::CompensationOptions {
        tolerance_m: 1e-7,
        damping_m: 1e-6,
        max_iterations: 60,
        settle_rad: 1e-9,
    };
    let mut rng = StdRng::seed_from_u64(11);
    for payload in [0.0f32, 0.0663] {
        let mut comp =
            crate::compensator::Compensator::new(cal, Config::default().compensation, 0.35);
        let (mut worst, mut done, mut unreachable, mut frames) = (0.0f64, 0, 0, 0);
        while done < targets {
            let q: Vec<f32> = (0..joints)
                .map(|_| rng.random_range(-1.6f32..1.6))
                .collect();
            let q64: Vec<f64> = q.iter().map(|&x| f64::from(x)).collect();
            let target = nominal64
                .tool_point(&q64, payload as f64, &Default::default())
                .unwrap();
            let reference = calibrated64.compensate(&q64, &target, payload as f64, None, &opts64);
            if !reference.is_ok_and(|c| c.converged) {
                unreachable += 1;
                continue;
            }
            done += 1;
            comp.reset();
            // A new target from rest: one Newton step per servo frame, as on the
            // board; about three frames on average, a dozen near the correction bound.
            const FRAMES_FROM_REST: usize = 20;
            let mut cmd = model::PerJoint::splat(joints, 0.0f32);
            for _ in 0..FRAMES_FROM_REST {
                frames += 1;
                cmd = comp.step(&q, CompensationMode::Full, payload);
                if comp.report().converged {
                    break;
                }
            }
            assert!(comp.report().converged, "q {q:?}: {:?}", comp.report());
            assert_eq!(cmd.len(), joints);
            let reached = calibrated64
                .tool_point(&cmd.map(f64::from), payload as f64, &Default::default())
                .unwrap();
            worst = worst.max((reached - target).norm());
        }
        assert!(
            worst < 5e-5,
            "{joints} joints, payload {payload}: worst {:.4} mm",
            worst * 1e3
        );
        println!(
            "{joints} joints, payload {payload} kg: worst {:.4} mm over {targets} targets \
             ({unreachable} unreachable skipped, {frames} frames)",
            worst * 1e3
        );
    }
}

/// Where a held pose settles does not depend on how the solve got there: a
/// move into the pose and a solve started afresh at it (after a new
/// calibration is committed) command the same pulses. Of all the deflected
/// shapes that put the tool point on target, both end at the one closest to
/// the nominal targets, also with a twisted link (Hayati's `β`), whose null
/// space turns with the pose.
#[test]
fn a_held_pose_settles_where_a_fresh_solve_settles() {
    for beta in [0.0f32, 0.004, -0.01] {
        let mut cal = test_calibration(4);
        cal.calibrated.joints[1].beta = beta;
        let pose = [0.4f32, -0.3, 0.5, 0.2, -0.6, 0.3];
        let start = cal.home_rad;
        let options = Config::default().compensation;
        let settle = |comp: &mut crate::compensator::Compensator| {
            for _ in 0..200 {
                let q = comp.step(&pose, CompensationMode::Full, 0.0);
                if comp.settled() {
                    return q;
                }
            }
            panic!("β {beta}: the held pose never settles: {:?}", comp.report());
        };
        // Into the pose over 15 frames, then held.
        let mut moved = crate::compensator::Compensator::new(&cal, options, 0.35);
        for k in 1..=15 {
            let t = k as f32 / 15.0;
            let q: std::vec::Vec<f32> = (0..6)
                .map(|i| start[i] + t * (pose[i] - start[i]))
                .collect();
            moved.step(&q, CompensationMode::Full, 0.0);
        }
        let held = settle(&mut moved);
        let mut fresh = crate::compensator::Compensator::new(&cal, options, 0.35);
        let afresh = settle(&mut fresh);
        for i in 0..6 {
            let off = (held[i] - afresh[i]).abs();
            // 1e-4 rad: a tenth of a microsecond of pulse.
            assert!(
                off < 1e-4,
                "β {beta}: joint {i} held at {} and afresh at {} rad",
                held[i],
                afresh[i]
            );
        }
    }
}
