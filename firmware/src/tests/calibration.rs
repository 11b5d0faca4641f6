//! Calibrations received, checked, stored and used: uploads, curves, play,
//! springs, reboots and power cuts.

use super::*;

#[test]
fn calibration_upload_is_applied_only_when_complete_and_intact() {
    let mut h = Harness::boot(SimFlash::new());
    let cal = test_calibration(7);
    let mut buf = [0u8; MAX_CALIBRATION_LEN];
    let bytes = cal.encode(&mut buf).unwrap().to_vec();
    assert_eq!(
        h.request(&Request::CalibrationCommit),
        Response::Error(WireError::NoTransfer)
    );
    let begin = Request::CalibrationBegin {
        len_bytes: bytes.len() as u32,
        crc: frame::crc32(&bytes) ^ 1,
    };
    h.request(&begin);
    let chunk = |o: usize| Request::CalibrationChunk {
        offset: o as u32,
        data: heapless::Vec::from_slice(&bytes[o..(o + CHUNK_LEN).min(bytes.len())]).unwrap(),
    };
    assert_eq!(
        h.request(&chunk(CHUNK_LEN)),
        Response::Error(WireError::BadChunk),
        "gap"
    );
    h.request(&chunk(0));
    assert_eq!(
        h.request(&chunk(0)),
        Response::CalibrationAck {
            received: CHUNK_LEN as u32
        },
        "retry is harmless"
    );
    assert_eq!(
        h.request(&Request::CalibrationCommit),
        Response::Error(WireError::TransferIncomplete)
    );
    for o in (CHUNK_LEN..bytes.len()).step_by(CHUNK_LEN) {
        h.request(&chunk(o));
    }
    assert_eq!(
        h.request(&Request::CalibrationCommit),
        Response::Error(WireError::CalibrationCrc)
    );
    assert_eq!(h.status().calibration, None);

    // A calibration that decodes but has a NaN is refused by the board's own check.
    let mut bad = cal;
    bad.calibrated.joints[2]
        .servo
        .as_mut()
        .unwrap()
        .pulses_us_mut()[1] = f32::NAN;
    let mut bad_buf = [0u8; MAX_CALIBRATION_LEN];
    let bad_bytes = bad.encode(&mut bad_buf).unwrap().to_vec();
    h.request(&Request::CalibrationBegin {
        len_bytes: bad_bytes.len() as u32,
        crc: frame::crc32(&bad_bytes),
    });
    for o in (0..bad_bytes.len()).step_by(CHUNK_LEN) {
        let data =
            heapless::Vec::from_slice(&bad_bytes[o..(o + CHUNK_LEN).min(bad_bytes.len())]).unwrap();
        h.request(&Request::CalibrationChunk {
            offset: o as u32,
            data,
        });
    }
    assert_eq!(
        h.request(&Request::CalibrationCommit),
        Response::Error(WireError::CalibrationInvalid)
    );
    assert_eq!(h.status().calibration, None);

    let Response::CalibrationStored(info) = h.push(&cal) else {
        panic!()
    };
    assert_eq!((info.id, info.sequence), (7, 1));
    assert_eq!(h.status().calibration, Some(info));
    assert!(!h.status().faults.contains(Faults::NO_CALIBRATION));
}

#[test]
fn calibrated_curves_and_limits_drive_the_servos() {
    let mut h = Harness::boot(SimFlash::new());
    let mut cal = test_calibration(1);
    cal.calibrated.joints[0].limits = [-0.5, 0.4];
    h.push(&cal);
    assert_eq!(
        h.move_to([0.45, 0.0, 0.0, 0.0, 0.0, 0.0]),
        Response::Error(WireError::OutOfRange)
    );
    assert_eq!(
        h.request(&Request::Home {
            timing: Timing::DurationMs(0)
        }),
        Response::Done
    );
    h.frames(100);
    for (i, (joint, home)) in cal.calibrated.joints.iter().zip(cal.home_rad).enumerate() {
        let expected = joint.servo.unwrap().pulse_us(home).round() as u16;
        assert_eq!(h.dev.bus().now[i], Some(expected), "joint {i}");
    }
}

/// Each joint's play in [`backlash_calibration`], full width, rad: 0.5° to 3°.
const PLAY_RAD: [f32; 6] = [0.0087, 0.02, 0.035, 0.05, 0.01, 0.03];

/// The test calibration with [`PLAY_RAD`] of play in its joints.
fn backlash_calibration(id: u32) -> Calibration {
    let mut cal = test_calibration(id);
    for (j, w) in cal.calibrated.joints.iter_mut().zip(PLAY_RAD) {
        j.backlash = w;
    }
    cal
}

#[test]
fn the_play_is_offset_by_half_its_width_the_way_each_joint_arrived() {
    use model::backlash::{ApproachTracker, command_for};
    let mut h = Harness::boot(SimFlash::new());
    let cal = backlash_calibration(1);
    assert!(matches!(h.push(&cal), Response::CalibrationStored(_)));
    h.request(&Request::SetCompensation {
        mode: CompensationMode::Off,
    });
    // From home, each joint rising, falling or staying put (and keeping its way in).
    let mut tracker = ApproachTracker::new(&cal.home_rad);
    let targets = [
        [0.4, 0.3, -0.6, 0.0, 0.9, 0.0],
        [0.1, 0.3, -0.2, 0.5, 0.9, -0.7],
        [0.1, -0.5, -0.2, -0.1, 0.6, -0.7],
        [0.6, -0.5, 0.3, -0.1, 1.2, 0.2],
    ];
    let mut flipped = [false; 6];
    let mut last = tracker.approach();
    for q in targets {
        assert_eq!(h.move_to(q), Response::Done);
        h.frames(150);
        assert!(!h.status().moving);
        let ways = tracker.visit(&q);
        for (i, joint) in cal.calibrated.joints.iter().enumerate() {
            let command = command_for(q[i], PLAY_RAD[i], ways[i]);
            let expected = joint.servo.unwrap().pulse_us(command).round() as u16;
            assert_eq!(h.dev.bus().now[i], Some(expected), "joint {i} to {q:?}");
            // Half the play is a few µs: the offset shows in the pulse.
            let plain = joint.servo.unwrap().pulse_us(q[i]).round() as u16;
            assert!(h.dev.bus().now[i] != Some(plain), "joint {i}: no offset");
            flipped[i] |= ways[i] != last[i];
        }
        last = ways;
    }
    assert_eq!(flipped, [true; 6], "every joint arrived both ways");
    assert!(!h.status().faults.contains(Faults::LIMIT_CLAMPED));

    // At the top of its range a joint arriving rising is clamped to the limit, and says so.
    let [_, hi] = cal.calibrated.joints[0].limits;
    assert_eq!(h.move_to([hi, -0.5, 0.3, -0.1, 1.2, 0.2]), Response::Done);
    h.frames(150);
    let top = cal.calibrated.joints[0].servo.unwrap().pulse_us(hi).round() as u16;
    assert_eq!(h.dev.bus().now[0], Some(top));
    assert!(h.status().faults.contains(Faults::LIMIT_CLAMPED));
}

#[test]
fn a_play_too_wide_or_negative_is_refused_whole_and_the_old_calibration_stays() {
    let mut h = Harness::boot(SimFlash::new());
    let Response::CalibrationStored(first) = h.push(&backlash_calibration(1)) else {
        panic!("the test calibration is valid")
    };
    for width in [6f32.to_radians(), -1e-3] {
        let mut bad = backlash_calibration(2);
        bad.calibrated.joints[2].backlash = width;
        assert_eq!(h.push(&bad), Response::Error(WireError::CalibrationInvalid));
        assert_eq!(h.status().calibration, Some(first));
    }
}

#[test]
fn a_sweep_follows_every_knot_of_the_curves_in_use() {
    let mut h = Harness::boot(SimFlash::new());
    let cal = test_calibration(1);
    h.push(&cal);
    h.request(&Request::SetCompensation {
        mode: CompensationMode::Off,
    });
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(50);
    for target in [-1.65, 1.65] {
        h.move_to([target; 6]);
        let mut frames = 0;
        while h.status().moving {
            h.frames(1);
            frames += 1;
            let q = h.status().nominal_rad;
            for (i, joint) in cal.calibrated.joints.iter().enumerate() {
                let expected = joint.servo.unwrap().pulse_us(q[i]).round() as u16;
                assert_eq!(h.dev.bus().now[i], Some(expected), "joint {i} at {}", q[i]);
            }
        }
        assert!(frames > 50, "the sweep took {frames} frames");
    }
}

#[test]
fn a_curve_that_turns_back_is_refused_whole_and_the_old_calibration_stays() {
    let mut h = Harness::boot(SimFlash::new());
    let Response::CalibrationStored(first) = h.push(&test_calibration(1)) else {
        panic!("the test calibration is valid")
    };
    h.request(&Request::Home {
        timing: Timing::DurationMs(0),
    });
    h.frames(100);
    let held = h.dev.bus().now;
    // Joint 4's nine-knot curve: the pulse at its sixth knot drops below the fifth's.
    let mut turned = test_calibration(2);
    let pulses = turned.calibrated.joints[3]
        .servo
        .as_mut()
        .unwrap()
        .pulses_us_mut();
    assert_eq!(pulses.len(), 9);
    pulses[5] = pulses[4] - 5.0;
    assert_eq!(
        h.push(&turned),
        Response::Error(WireError::CalibrationInvalid)
    );
    assert_eq!(h.status().calibration, Some(first));
    h.frames(100);
    assert_eq!(h.dev.bus().now, held, "the servos stay on the old curves");
    let (_, mut flash) = h.dev.release();
    flash.power_on();
    let mut h = Harness::boot(flash);
    assert_eq!(h.status().calibration, Some(first), "and after a reboot");
}

/// A softening calibration is stored and used; one whose spring stiffens so
/// fast it would stop yielding under the arm's largest torque (below its
/// floor in `model::bounds`, worked out on the board from the nominal arm),
/// or is not finite, is refused whole.
#[test]
fn a_spring_that_stiffens_too_fast_is_refused_whole() {
    let mut h = Harness::boot(SimFlash::new());
    let mut soft = test_calibration(1);
    soft.calibrated.base_softening = 0.3;
    soft.calibrated
        .joints
        .iter_mut()
        .for_each(|j| j.softening = 0.3);
    assert!(
        matches!(h.push(&soft), Response::CalibrationStored(_)),
        "a softening calibration is valid"
    );
    let floor = model::bounds::Bounds::of(&soft.nominal)
        .range(model::bounds::Quantity::Softening { spring: 2 })
        .min;
    let mut stiff = test_calibration(3);
    stiff.calibrated.joints[1].softening = 0.99 * floor;
    assert!(
        matches!(h.push(&stiff), Response::CalibrationStored(_)),
        "a spring that stiffens, just above its floor, is valid"
    );
    let Response::CalibrationStored(first) = h.push(&soft) else {
        panic!("a softening calibration is valid")
    };
    for bad in [1.01 * floor, f32::NAN] {
        let mut stiff = test_calibration(2);
        stiff.calibrated.joints[1].softening = bad;
        assert_eq!(
            h.push(&stiff),
            Response::Error(WireError::CalibrationInvalid),
            "softening {bad}"
        );
        assert_eq!(h.status().calibration, Some(first));
    }
}

#[test]
fn a_reboot_keeps_the_calibration_and_a_cut_write_keeps_the_old_one() {
    let mut h = Harness::boot(SimFlash::new());
    h.push(&test_calibration(1));
    let (_, mut flash) = h.dev.release();
    flash.power_on();
    let mut h = Harness::boot(flash);
    assert_eq!(h.status().calibration.map(|c| c.id), Some(1));
    // Power fails 3000 byte operations into writing calibration 2: inside the
    // erase of slot 1 (4096 bytes), the slot not in use, which was blank.
    let (bus, mut flash) = h.dev.release();
    flash.cut_after(3000);
    h.dev = Device::new(bus, flash, Config::default(), h.now);
    assert_eq!(
        h.push(&test_calibration(2)),
        Response::Error(WireError::Flash)
    );
    assert_eq!(
        h.status().calibration.map(|c| c.id),
        Some(1),
        "old one stays in use"
    );
    let (_, mut flash) = h.dev.release();
    flash.power_on();
    let mut h = Harness::boot(flash);
    let status = h.status();
    assert_eq!(
        status.calibration.map(|c| c.id),
        Some(1),
        "and after the reboot"
    );
    // A half-erased blank slot is still blank, and the header that would make
    // it a record is written last: slot 1 reads as empty, not damaged.
    assert!(
        !status.faults.contains(Faults::STORAGE_DAMAGED),
        "{:?}",
        status.faults
    );
}

/// Power lost at every byte operation of a `calib/commit`: so at the start,
/// inside and at the end of the sector erase and of every page program, the
/// payload's pages and last the header's (every byte boundary of it). After
/// the reboot the board runs on the previous calibration or the new one,
/// byte for byte and on its servos, never a mixture, and never on none when
/// one existed; it reports the commit stored only when the new one is in flash.
#[test]
fn a_power_cut_at_every_write_step_of_a_commit_boots_the_old_or_the_new_calibration() {
    let mut new = test_calibration(2);
    for j in &mut new.calibrated.joints {
        j.servo.as_mut().unwrap().pulses_us_mut()[1] += 30.0;
    }
    let encoded = |c: &Calibration| {
        let mut buf = [0u8; MAX_CALIBRATION_LEN];
        c.encode(&mut buf).unwrap().to_vec()
    };
    for old in [None, Some(test_calibration(1))] {
        let mut h = Harness::boot(SimFlash::new());
        if let Some(old) = &old {
            h.push(old);
        }
        let (_, flash) = h.dev.release();
        let mut h = Harness::boot(flash.clone());
        let before = h.dev.flash_mut().operations();
        assert!(matches!(h.push(&new), Response::CalibrationStored(_)));
        let commit = h.dev.flash_mut().operations() - before;
        // One sector erase, the payload's pages and the 24-byte header.
        assert_eq!(commit, crate::sim::SLOT_SIZE + encoded(&new).len() + 24);
        for cut in 0..=commit {
            let mut h = Harness::boot(flash.clone());
            h.dev.flash_mut().cut_after(cut);
            let reply = h.push(&new);
            let (_, mut cut_flash) = h.dev.release();
            cut_flash.power_on();
            let mut h = Harness::boot(cut_flash);
            let in_use = h.status().calibration;
            let bytes = h.read_back();
            let running = bytes.as_deref().and_then(Calibration::decode);
            assert!(
                running == Some(new) || running == old,
                "cut after {cut} of {commit}: boots with {:?}",
                running.map(|c| c.id)
            );
            assert_eq!(in_use.map(|i| i.id), running.map(|c| c.id), "cut {cut}");
            assert_eq!(
                matches!(reply, Response::CalibrationStored(_)),
                cut == commit,
                "cut {cut}: {reply:?}"
            );
            if cut < commit - 24 {
                assert_eq!(
                    running, old,
                    "cut {cut}: before the header the old one stays"
                );
            }
            // The servos follow that calibration's curves, not a mixture of two.
            let curves = running.map_or([Some(model::ServoCurve::nominal()); 6].into(), |c| {
                c.calibrated.joints.map(|j| j.servo)
            });
            let home = running.map_or([0.0; 6].into(), |c| c.home_rad);
            h.request(&Request::Home {
                timing: Timing::DurationMs(0),
            });
            h.frames(1);
            let pulses: [Option<u16>; 6] =
                core::array::from_fn(|i| Some(curves[i].unwrap().pulse_us(home[i]).round() as u16));
            assert_eq!(h.dev.bus().now, pulses, "cut {cut}");
        }
    }
}
