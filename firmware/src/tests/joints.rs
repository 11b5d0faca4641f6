//! Arms of fewer joints than channels: joint `i` on channel `i`, the channels
//! past the last joint limp whatever the requests; moves of one target per
//! joint; calibrations of another size applied without a step, and arms the
//! board cannot drive refused whole.

use protocol::CalibrationFault;

use super::*;

/// Whether no channel from `joints` on ever got a pulse.
fn limp_past(h: &Harness, joints: usize) -> bool {
    h.dev
        .bus()
        .log
        .iter()
        .all(|&(channel, pulse)| channel < joints || pulse.is_none())
}

/// Pushes `test_calibration_of(id, joints)` and checks that it is stored.
fn push_arm(h: &mut Harness, id: u32, joints: usize) -> (Calibration, protocol::CalibrationInfo) {
    let cal = test_calibration_of(id, joints);
    let Response::CalibrationStored(info) = h.push(&cal) else {
        panic!("a calibration of {joints} joints is valid")
    };
    assert_eq!(usize::from(info.joints), joints);
    (cal, info)
}

/// A calibrated arm of `joints` joints goes home on its curves, compensates,
/// moves, and the channels past its last joint never get a pulse.
fn moves_and_compensates_with_the_rest_limp(joints: usize) {
    let mut h = Harness::boot(SimFlash::new());
    let (cal, info) = push_arm(&mut h, 3, joints);
    // The joints keep the angles they had (the board's start, all zeros),
    // now one per joint of the new arm.
    let s = h.status();
    assert_eq!(s.calibration, Some(info));
    let zeros = PerChannel::splat(joints, 0.0);
    assert_eq!((s.targets_rad, s.nominal_rad), (zeros, zeros));
    assert_eq!(
        h.request(&Request::Home {
            timing: Timing::DurationMs(0)
        }),
        Response::Done
    );
    h.frames(100);
    // Compensation off: each joint's pulse is its calibrated curve at home.
    let now = h.dev.bus().now;
    for (i, (joint, home)) in cal.calibrated.joints.iter().zip(cal.home_rad).enumerate() {
        let expected = joint.servo.unwrap().pulse_us(home).round() as u16;
        assert_eq!(now[i], Some(expected), "joint {i}");
    }
    assert!(now[joints..].iter().all(Option::is_none), "{now:?}");
    let off = now;
    h.request(&Request::SetPayload { mass_kg: 0.0663 });
    assert_eq!(
        h.request(&Request::SetCompensation {
            mode: CompensationMode::Full
        }),
        Response::Done
    );
    h.frames(60);
    assert_ne!(h.dev.bus().now, off, "compensation changes the pulses");
    let targets = PerChannel::from_slice(&[0.3, 0.6, -0.4, 0.2, 0.8, 0.1][..joints]).unwrap();
    assert_eq!(
        h.request(&Request::Move {
            targets_rad: targets,
            timing: Timing::DurationMs(1000),
        }),
        Response::Done
    );
    h.frames(10);
    let s = h.status();
    assert!(s.moving);
    assert_eq!((s.targets_rad, s.nominal_rad.len()), (targets, joints));
    assert_ne!(s.nominal_rad, targets, "on the way");
    h.frames(150);
    let s = h.status();
    assert!(!s.moving, "{s:?}");
    assert_eq!((s.targets_rad, s.nominal_rad), (targets, targets));
    assert_eq!(s.pulses_us[joints..], [0; 6][joints..]);
    if joints > 2 {
        // Three or more joints reach the nominal arm's tool point (a single
        // one cannot: its solve ends on its best command).
        assert!(
            s.compensation.converged && !s.faults.contains(Faults::COMPENSATION_FALLBACK),
            "{s:?}"
        );
    }
    assert!(
        h.request(&Request::Attach { channel: None }) == Response::Done
            && h.request(&Request::Detach { channel: None }) == Response::Done
    );
    h.frames(5);
    assert!(
        limp_past(&h, joints),
        "a channel past joint {joints} got a pulse"
    );
}

#[test]
fn a_five_joint_arm_moves_and_compensates_with_channel_6_limp_throughout() {
    moves_and_compensates_with_the_rest_limp(5);
}

#[test]
fn a_one_joint_arm_moves_and_compensates_with_channels_2_to_6_limp_throughout() {
    moves_and_compensates_with_the_rest_limp(1);
}

/// A move gives one target per joint of the arm: six without a calibration,
/// the calibration's number with one. Any other count is refused with
/// `TargetCount` and changes nothing; a busy board says so first.
#[test]
fn a_move_without_one_target_per_joint_is_refused_and_changes_nothing() {
    let mut h = Harness::boot(SimFlash::new());
    let refused = Response::Error(WireError::TargetCount);
    assert_eq!(h.move_to([0.1; 5]), refused, "no calibration: six joints");
    assert_eq!(h.move_to::<0>([]), refused);
    push_arm(&mut h, 1, 5);
    for wrong in [&[0.1; 6][..], &[0.1; 4], &[0.1], &[]] {
        let targets_rad = PerChannel::from_slice(wrong).unwrap();
        let timing = Timing::DurationMs(0);
        assert_eq!(
            h.request(&Request::Move {
                targets_rad,
                timing
            }),
            refused,
            "{} targets",
            wrong.len()
        );
    }
    // A wrong count is refused before the values are looked at.
    assert_eq!(h.move_to([f32::NAN; 6]), refused);
    h.frames(5);
    assert!(h.dev.bus().log.iter().all(|(_, p)| p.is_none()));
    let s = h.status();
    assert!(!s.moving && s.targets_rad.len() == 5);
    assert_eq!(h.move_to([0.1; 5]), Response::Done);
    assert_eq!(h.move_to([0.1; 6]), Response::Error(WireError::Busy));
}

/// `servo/attach` and `servo/raw` refuse a channel past the arm's last joint
/// (`UnusedChannel`; past the board's channels, `OutOfRange` as before);
/// `servo/detach` of it is allowed and leaves it limp; attaching all drives
/// the joints' channels only.
#[test]
fn the_channels_past_the_last_joint_cannot_be_attached_or_driven_raw() {
    let mut h = Harness::boot(SimFlash::new());
    push_arm(&mut h, 1, 5);
    let unused = Response::Error(WireError::UnusedChannel);
    let out_of_range = Response::Error(WireError::OutOfRange);
    assert_eq!(h.request(&Request::Attach { channel: Some(5) }), unused);
    let raw = |channel| Request::RawPulse {
        channel,
        pulse_us: 1500,
    };
    assert_eq!(h.request(&raw(5)), unused);
    assert_eq!(h.request(&raw(6)), out_of_range);
    assert_eq!(
        h.request(&Request::Attach { channel: Some(6) }),
        out_of_range
    );
    assert_eq!(
        h.request(&Request::Detach { channel: Some(5) }),
        Response::Done
    );
    assert_eq!(
        h.request(&Request::Attach { channel: None }),
        Response::Done
    );
    h.frames(3);
    let now = h.dev.bus().now;
    assert!(
        now[..5].iter().all(Option::is_some) && now[5].is_none(),
        "{now:?}"
    );
    assert_eq!(h.status().pulses_us[5], 0);
    assert_eq!(h.request(&raw(4)), Response::Pulse { applied_us: 1500 });
    assert_eq!(
        h.request(&Request::Detach { channel: None }),
        Response::Done
    );
    h.frames(2);
    assert_eq!(h.dev.bus().now, [None; 6]);
    assert!(limp_past(&h, 5));
}

/// A calibration of fewer joints makes the channels past its arm limp as it
/// is applied, in the commit's reply, and the joints both arms have go on
/// without a step; a calibration of more joints leaves the new joint's
/// channel limp until it is attached, then holds it at the home pose; an
/// erase goes back to six joints on the data-sheet curve.
#[test]
fn a_calibration_of_another_size_refits_the_arm_without_a_step() {
    let mut h = Harness::boot(SimFlash::new());
    h.push(&test_calibration(1));
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(100);
    assert!(h.dev.bus().now.iter().all(Option::is_some));
    let five = test_calibration_of(2, 5);
    let before = h.dev.bus().now;
    let logged = h.dev.bus().log.len();
    assert!(matches!(h.push(&five), Response::CalibrationStored(_)));
    assert_eq!(
        h.dev.bus().log[logged..],
        [(5, None)],
        "channel 6 limp at once"
    );
    let per_frame = largest_fading_step_us(&five);
    let mut last = before;
    for _ in 0..100 {
        h.frames(1);
        let now = h.dev.bus().now;
        for i in 0..5 {
            let jump = (f32::from(now[i].unwrap()) - f32::from(last[i].unwrap())).abs();
            assert!(jump <= per_frame, "joint {i} jumped {jump} µs");
        }
        assert_eq!(now[5], None);
        last = now;
    }
    let s = h.status();
    assert!(!s.moving);
    assert_eq!(s.calibration.map(|c| c.joints), Some(5));
    assert_eq!((s.targets_rad.len(), s.nominal_rad.len()), (5, 5));
    // The five joints sit where the new curves put the home pose.
    for (i, (joint, home)) in five.calibrated.joints.iter().zip(five.home_rad).enumerate() {
        let expected = joint.servo.unwrap().pulse_us(home).round() as u16;
        assert_eq!(h.dev.bus().now[i], Some(expected), "joint {i}");
    }

    // Six joints again: the sixth channel stays limp until attached.
    let six = test_calibration(3);
    assert!(matches!(h.push(&six), Response::CalibrationStored(_)));
    h.frames(10);
    assert_eq!(h.dev.bus().now[5], None);
    assert_eq!(h.status().targets_rad.len(), 6);
    assert_eq!(
        h.request(&Request::Attach { channel: Some(5) }),
        Response::Done
    );
    h.frames(1);
    let j6 = six.calibrated.joints[5]
        .servo
        .unwrap()
        .pulse_us(six.home_rad[5]);
    assert_eq!(h.dev.bus().now[5], Some(j6.round() as u16));

    // From five joints, an erase: six joints on the data-sheet curve, the
    // sixth still limp, moves of six targets.
    h.push(&five);
    h.frames(100);
    assert_eq!(h.dev.bus().now[5], None);
    assert_eq!(h.request(&Request::CalibrationErase), Response::Done);
    h.frames(100);
    let s = h.status();
    assert_eq!((s.calibration, s.targets_rad.len()), (None, 6));
    assert_eq!(h.dev.bus().now[5], None);
    assert_eq!(h.move_to([0.1; 5]), Response::Error(WireError::TargetCount));
    assert_eq!(h.move_to([0.0; 6]), Response::Done);
    h.frames(100);
    assert_eq!(h.dev.bus().now[5], Some(1650), "the data-sheet curve at 0");
}

/// The number of joints in `arm` made `joints`: the last joint repeated, or cut.
fn with_joints(arm: &mut model::Arm<f32>, joints: usize) {
    let last = arm.joints.last_value();
    arm.joints = model::PerJoint::from_fn(joints, |i| arm.joints.get(i).copied().unwrap_or(last));
}

/// No joint, more joints than channels, or arms, home pose and corrections of
/// different lengths: refused whole, through the same commit as any other
/// bad calibration; the one in use stays, on the servos and after a reboot.
#[test]
fn an_arm_the_board_cannot_drive_is_refused_whole_and_the_old_calibration_stays() {
    let mut h = Harness::boot(SimFlash::new());
    let (_, first) = push_arm(&mut h, 1, 5);
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(100);
    let held = h.dev.bus().now;
    let mut seven = test_calibration(2);
    with_joints(&mut seven.nominal, 7);
    with_joints(&mut seven.calibrated, 7);
    let mut none = test_calibration(2);
    with_joints(&mut none.nominal, 0);
    with_joints(&mut none.calibrated, 0);
    none.home_rad = PerChannel::splat(0, 0.0);
    none.max_correction_rad = PerChannel::splat(0, 0.3);
    let mut arms = test_calibration_of(2, 5);
    arms.nominal = test_calibration(2).nominal;
    let mut home = test_calibration_of(2, 5);
    home.home_rad = PerChannel::splat(6, 0.0);
    let mut corrections = test_calibration_of(2, 5);
    corrections.max_correction_rad = PerChannel::splat(4, 0.3);
    for (bad, joints) in [
        (seven, 7),
        (none, 0),
        (arms, 5),
        (home, 5),
        (corrections, 5),
    ] {
        assert_eq!(bad.check(), Err(CalibrationFault::JointCount { joints }));
        assert_eq!(
            h.push(&bad),
            Response::Error(WireError::CalibrationInvalid),
            "{joints} joints"
        );
        assert_eq!(h.status().calibration, Some(first));
    }
    h.frames(100);
    assert_eq!(
        h.dev.bus().now,
        held,
        "the servos stay on the old calibration"
    );
    assert!(limp_past(&h, 5));
    let (_, mut flash) = h.dev.release();
    flash.power_on();
    let mut h = Harness::boot(flash);
    let s = h.status();
    assert_eq!(s.calibration, Some(first), "and after a reboot");
    assert_eq!(s.targets_rad.len(), 5);
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(100);
    assert_eq!(
        h.dev.bus().now,
        held,
        "home on the same curves after the reboot"
    );
    assert!(limp_past(&h, 5));
}
