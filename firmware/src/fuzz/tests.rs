//! The harness itself: the reference frame reading agrees with the encoder,
//! a short campaign passes, and each check fails on the violation it is for.

use protocol::frame::{self, MAX_FRAME};
use protocol::{CalibrationInfo, ModelOption, Request, Response, WireError};
use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::check::{Expect, Model, intact, unstuff};
use super::*;

fn source(seed: u64) -> impl FnMut() -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    move || rng.next_u64()
}

#[test]
fn the_reference_reading_agrees_with_the_encoder() {
    let mut src = source(1);
    for _ in 0..2000 {
        let n = src.below(300) as usize;
        let raw: Vec<u8> = (0..n).map(|_| src.word() as u8).collect();
        let mut encoded = vec![0u8; cobs::max_encoding_length(n)];
        let len = cobs::encode(&raw, &mut encoded);
        assert_eq!(unstuff(&encoded[..len]), Some(raw));
    }
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(513, &Request::Status, &mut out).unwrap();
    assert_eq!(intact(&out[..n - 1]), Some(513));
    // One flipped bit anywhere makes it corrupt.
    for bit in 0..(n - 1) * 8 {
        let mut bad = out[..n - 1].to_vec();
        bad[bit / 8] ^= 1 << (bit % 8);
        if !bad.contains(&0) {
            assert_eq!(intact(&bad), None, "bit {bit}");
        }
    }
    assert_eq!(unstuff(&[3, 1]), None, "a block running past the end");
    assert_eq!(unstuff(&[2, 1, 0]), None, "a 0x00 inside");
}

#[test]
fn a_short_campaign_holds_every_invariant() {
    let fixtures = Fixtures::new();
    let mut counts = Counts::default();
    let mut src = source(7);
    for _ in 0..40 {
        let case = frames_case(&mut src, &fixtures, generate::FRAMES_PER_CASE);
        run(&fixtures, &case, &mut counts).unwrap_or_else(|v| panic!("{v}\n{case:?}"));
    }
    for _ in 0..150 {
        let case = sequence_case(&mut src, &fixtures);
        run(&fixtures, &case, &mut counts).unwrap_or_else(|v| panic!("{v}\n{case:?}"));
    }
    // The generators reach what the invariants are about.
    assert!(
        counts.intact > 0 && counts.intact < counts.frames_read,
        "{counts:?}"
    );
    assert!(
        counts.overflows > 0 && counts.stored > 0 && counts.power_cuts > 0,
        "{counts:?}"
    );
}

#[test]
fn the_same_source_gives_the_same_case() {
    let fixtures = Fixtures::new();
    let a = sequence_case(&mut source(3), &fixtures);
    assert_eq!(a, sequence_case(&mut source(3), &fixtures));
    assert_ne!(a, sequence_case(&mut source(4), &fixtures));
}

fn held_model() -> Model {
    let mut model = Model::new(vec![None]);
    model.channels = [Expect::Held; CHANNELS];
    model
}

#[test]
fn the_pulse_checks_catch_unsafe_pulses_and_joints_past_their_limits() {
    let mut model = held_model();
    let frame = |pulses: [Option<u16>; CHANNELS]| -> Vec<(usize, Option<u16>)> {
        pulses.into_iter().enumerate().collect()
    };
    let fine = frame([Some(1650); CHANNELS]);
    assert_eq!(model.check_servo_frame(&fine), Ok(()));
    let mut unsafe_pulse = [Some(1650); CHANNELS];
    unsafe_pulse[2] = Some(2501);
    let fault = model.check_servo_frame(&frame(unsafe_pulse)).unwrap_err();
    assert_eq!(fault.invariant, Invariant::PulseRange);
    // Without a calibration the joints stop at ±100°: 900..2400 µs on the nominal curve.
    let mut past_limit = [Some(1650); CHANNELS];
    past_limit[0] = Some(2450);
    let fault = model.check_servo_frame(&frame(past_limit)).unwrap_err();
    assert_eq!(fault.invariant, Invariant::JointLimits);
    // A raw pulse is only held to the safe range.
    model.channels[0] = Expect::Raw(2450);
    assert_eq!(model.check_servo_frame(&frame(past_limit)), Ok(()));
}

#[test]
fn the_servo_frame_check_catches_a_stopped_or_skipped_channel() {
    let model = held_model();
    let mut pulses: Vec<(usize, Option<u16>)> = (0..CHANNELS).map(|c| (c, Some(1650))).collect();
    pulses[4].1 = None;
    let fault = model.check_servo_frame(&pulses).unwrap_err();
    assert_eq!(fault.invariant, Invariant::ServoFrame);
    pulses.remove(4);
    let fault = model.check_servo_frame(&pulses).unwrap_err();
    assert_eq!(fault.invariant, Invariant::ServoFrame);
    // A request may not touch a held servo.
    let fault = model.check_request_pulses(&[(1, Some(1500))]).unwrap_err();
    assert_eq!(fault.invariant, Invariant::ServoFrame);
}

#[test]
fn the_calibration_checks_catch_a_partial_or_unannounced_apply() {
    let fixtures = Fixtures::new();
    let bytes = &fixtures.uploads[0].bytes;
    let mut model = Model::new(vec![None]);
    let status = {
        let mut counts = Counts::default();
        let mut rig = Rig::boot(SimFlash::new(), vec![None], &mut counts);
        let mut out = [0u8; MAX_FRAME];
        let mut buf = [0u8; MAX_FRAME];
        let n = frame::encode(1, &Request::Status, &mut buf).unwrap();
        let m = rig.device.handle_frame(&buf[..n], &mut out);
        frame::decode::<Response>(&out[..m]).unwrap().1
    };
    model.on_reply(&Request::Status, &status).unwrap();
    let stored = Response::CalibrationStored(CalibrationInfo {
        id: 21,
        option: ModelOption::ElastoKinematic,
        joints: 6,
        sequence: 1,
    });
    // A commit with nothing uploaded, or half of it, must not store anything.
    let fault = model
        .on_reply(&Request::CalibrationCommit, &stored)
        .unwrap_err();
    assert_eq!(fault.invariant, Invariant::Calibration);
    let begin = Request::CalibrationBegin {
        len_bytes: bytes.len() as u32,
        crc: frame::crc32(bytes),
    };
    model
        .on_reply(&begin, &Response::CalibrationAck { received: 0 })
        .unwrap();
    let first = Request::CalibrationChunk {
        offset: 0,
        data: heapless::Vec::from_slice(&bytes[..CHUNK_LEN]).unwrap(),
    };
    let ack = Response::CalibrationAck {
        received: CHUNK_LEN as u32,
    };
    model.on_reply(&first, &ack).unwrap();
    let fault = model
        .on_reply(&Request::CalibrationCommit, &stored)
        .unwrap_err();
    assert_eq!(fault.invariant, Invariant::Calibration);
    // Nor may a flash error appear without a power cut.
    let flash = Response::Error(WireError::Flash);
    assert!(model.on_reply(&Request::CalibrationErase, &flash).is_err());
    // The status must then still say no calibration.
    let mut wrong = status.clone();
    if let Response::Status(s) = &mut wrong {
        s.calibration = Some(CalibrationInfo {
            id: 21,
            option: ModelOption::ElastoKinematic,
            joints: 6,
            sequence: 1,
        });
    }
    let fault = model.on_reply(&Request::Status, &wrong).unwrap_err();
    assert_eq!(fault.invariant, Invariant::Calibration);
}

/// On a board of the five-joint upload, a pulse on channel 6 is caught
/// whatever the model expects there, in a servo frame or a request; so is a
/// status whose joint vectors are not the arm's.
#[test]
fn the_joint_checks_catch_a_pulse_past_the_last_joint_and_a_wrong_status() {
    let fixtures = Fixtures::new();
    let five = fixtures
        .uploads
        .iter()
        .position(|u| {
            Calibration::decode(&u.bytes).is_some_and(|c| c.calibrated.joint_count() == 5)
        })
        .expect("an upload of five joints");
    let mut counts = Counts::default();
    let mut rig = Rig::boot(
        fixtures.flash(Some(five)),
        vec![fixtures.known(five)],
        &mut counts,
    );
    rig.settle().unwrap();
    assert_eq!(rig.model.joints(), 5);
    // A model that lost track of channel 6 still catches its pulse.
    rig.model.channels = [Expect::Held; CHANNELS];
    let frame: Vec<(usize, Option<u16>)> = (0..CHANNELS).map(|c| (c, Some(1650))).collect();
    let fault = rig.model.check_servo_frame(&frame).unwrap_err();
    assert_eq!(fault.invariant, Invariant::Joints);
    let fault = rig
        .model
        .check_request_pulses(&[(5, Some(1500))])
        .unwrap_err();
    assert_eq!(fault.invariant, Invariant::Joints);
    // A status of six targets, or one that counts six joints.
    let mut out = [0u8; MAX_FRAME];
    let mut buf = [0u8; MAX_FRAME];
    let n = frame::encode(1, &Request::Status, &mut buf).unwrap();
    let m = rig.device.handle_frame(&buf[..n], &mut out);
    let Response::Status(status) = frame::decode::<Response>(&out[..m]).unwrap().1 else {
        panic!("not a status")
    };
    let mut model = rig.model.clone();
    model.channels = [Expect::Limp; CHANNELS];
    assert_eq!(
        model.on_reply(&Request::Status, &Response::Status(status)),
        Ok(())
    );
    let mut six = status;
    six.targets_rad = [0.0; CHANNELS].into();
    let fault = model
        .on_reply(&Request::Status, &Response::Status(six))
        .unwrap_err();
    assert_eq!(fault.invariant, Invariant::Joints);
    let mut counted = status;
    counted.calibration = counted
        .calibration
        .map(|c| CalibrationInfo { joints: 6, ..c });
    assert!(
        model
            .on_reply(&Request::Status, &Response::Status(counted))
            .is_err()
    );
}

#[test]
fn the_boot_check_catches_a_lost_calibration() {
    let fixtures = Fixtures::new();
    let mut counts = Counts::default();
    // The flash is blank but the model knows a calibration was stored.
    let mut rig = Rig::boot(SimFlash::new(), vec![fixtures.known(0)], &mut counts);
    assert_eq!(rig.settle().unwrap_err().invariant, Invariant::Boot);
}

#[test]
fn shrinking_keeps_only_what_fails() {
    let steps = vec![
        Step::Frames(40),
        Step::Request(Request::Hello),
        Step::Reboot,
        Step::Frames(7),
    ];
    let case = Case {
        preload: Some(0),
        steps,
    };
    let fails = |c: &Case| {
        c.steps
            .iter()
            .any(|s| matches!(s, Step::Frames(n) if *n >= 5))
    };
    let small = shrink(&case, fails);
    assert_eq!(
        small,
        Case {
            preload: None,
            steps: vec![Step::Frames(7)]
        }
    );
}
