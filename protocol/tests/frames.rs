//! Frame rules: corruption is caught, versions are told apart, and no byte
//! sequence makes the decoder or the stream reader panic.

use model::bounds::{Bounds, Quantity};
use proptest::prelude::*;
use protocol::frame::{self, Feed, FrameError, FrameReader, MAX_FRAME};
use protocol::{
    CHANNELS, Calibration, CalibrationFault, PerChannel, Request, Response, Timing, WireError,
};

fn frame_of(seq: u16, msg: &Request) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(seq, msg, &mut out).unwrap();
    out[..n].to_vec()
}

#[test]
fn a_flipped_bit_anywhere_is_caught() {
    let good = frame_of(77, &Request::SetPayload { mass_kg: 0.0663 });
    for i in 0..good.len() - 1 {
        for bit in 0..8 {
            let mut bad = good.clone();
            bad[i] ^= 1 << bit;
            let r = frame::decode::<Request>(&bad);
            assert!(
                matches!(
                    r,
                    Err(FrameError::Crc | FrameError::Cobs | FrameError::TooShort)
                ),
                "byte {i} bit {bit}: {r:?}"
            );
        }
    }
}

#[test]
fn another_version_is_reported_not_misread() {
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode_with_version(1, 5, &Request::Status, &mut out).unwrap();
    assert_eq!(
        frame::decode::<Request>(&out[..n]),
        Err(FrameError::Version { theirs: 1, seq: 5 })
    );
    let msg = FrameError::Version { theirs: 1, seq: 5 }.to_string();
    assert!(
        msg.contains("version 1")
            && msg.contains(&format!("speaks {}", protocol::PROTOCOL_VERSION)),
        "{msg}"
    );
}

/// The previous protocol (an lrmcal or a board not yet updated) is refused,
/// not misread, and the error names both versions, so the user knows which
/// side to update.
#[test]
fn a_frame_of_the_previous_version_is_refused_naming_both_versions() {
    assert_eq!(protocol::PROTOCOL_VERSION, 7);
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode_with_version(6, 12, &Request::Status, &mut out).unwrap();
    let err = frame::decode::<Request>(&out[..n]).unwrap_err();
    assert_eq!(err, FrameError::Version { theirs: 6, seq: 12 });
    let msg = err.to_string();
    assert!(
        msg.contains("protocol version 6") && msg.contains("speaks 7"),
        "{msg}"
    );
    // The same for a reply: the host tells a board of protocol 6 apart.
    let n = frame::encode_with_version(6, 13, &Response::Done, &mut out).unwrap();
    assert_eq!(
        frame::decode::<Response>(&out[..n]),
        Err(FrameError::Version { theirs: 6, seq: 13 })
    );
}

/// The reverse: a peer of protocol 6 reads only the frozen header of our
/// frames before it refuses them, and that header says 7. (Its decoder is
/// not in this crate; what it reads is.) A newer peer's frame is refused here
/// the same way as an older one's.
#[test]
fn our_frames_say_version_7_where_a_version_6_peer_looks() {
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(14, &Request::Status, &mut out).unwrap();
    let mut raw = [0u8; frame::MAX_RAW];
    let (version, seq, _) = frame::decode_raw(&out[..n], &mut raw).unwrap();
    assert_eq!((version, seq), (7, 14));
    assert_eq!(raw[0], 7, "the version is the first byte of every frame");
    let n = frame::encode_with_version(8, 15, &Request::Status, &mut out).unwrap();
    let err = frame::decode::<Request>(&out[..n]).unwrap_err();
    assert_eq!(err, FrameError::Version { theirs: 8, seq: 15 });
    assert!(err.to_string().contains("version 8"), "{err}");
}

/// A move carries one target per joint behind their count: 1 to 6 targets
/// round-trip; more than the board's channels is not a request.
#[test]
fn moves_carry_one_target_per_joint_and_no_more_than_the_channels() {
    for joints in 1..=CHANNELS {
        let req = Request::Move {
            targets_rad: PerChannel::from_fn(joints, |i| 0.1 * i as f32),
            timing: Timing::DurationMs(100),
        };
        let (_, back): (u16, Request) = frame::decode(&frame_of(1, &req)).unwrap();
        assert_eq!(back, req, "{joints} joints");
    }
    // The same body with seven targets, encoded by hand: variant 2 (move), the
    // count, the floats, then the timing.
    #[derive(serde::Serialize)]
    enum Like {
        _Hello,
        _Status,
        Move {
            targets_rad: &'static [f32],
            timing: Timing,
        },
    }
    let seven = Like::Move {
        targets_rad: &[0.0; CHANNELS + 1],
        timing: Timing::DurationMs(100),
    };
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(2, &seven, &mut out).unwrap();
    assert_eq!(
        frame::decode::<Request>(&out[..n]),
        Err(FrameError::Body { seq: 2 })
    );
    let six = Like::Move {
        targets_rad: &[0.0; CHANNELS],
        timing: Timing::DurationMs(100),
    };
    let n = frame::encode(3, &six, &mut out).unwrap();
    assert!(
        frame::decode::<Request>(&out[..n]).is_ok(),
        "the mirror is faithful"
    );
}

#[test]
fn a_response_is_not_taken_for_a_request() {
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(9, &Response::Error(WireError::Flash), &mut out).unwrap();
    assert!(matches!(
        frame::decode::<Request>(&out[..n]),
        Err(FrameError::Body { seq: 9 })
    ));
}

#[test]
fn trailing_bytes_after_a_message_are_refused() {
    // A valid frame whose body is Request::Hello followed by one extra byte.
    let raw_body = [0u8, 0x55];
    let mut raw = vec![protocol::PROTOCOL_VERSION, 3, 0];
    raw.extend_from_slice(&raw_body);
    let crc = frame::crc32(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut enc = vec![0u8; MAX_FRAME];
    let n = cobs::encode(&raw, &mut enc);
    assert_eq!(
        frame::decode::<Request>(&enc[..n]),
        Err(FrameError::Body { seq: 3 })
    );
}

#[test]
fn reader_splits_a_stream_and_drops_overlong_frames() {
    let a = frame_of(1, &Request::Hello);
    let b = frame_of(2, &Request::Status);
    let mut stream = vec![0u8, 0];
    stream.extend_from_slice(&a);
    stream.extend(std::iter::repeat_n(0x41u8, 3 * MAX_FRAME));
    stream.push(0);
    stream.extend_from_slice(&b);
    let mut reader = FrameReader::<MAX_FRAME>::new();
    let mut seen = Vec::new();
    for byte in stream {
        match reader.feed(byte) {
            Feed::Pending => {}
            Feed::Overflow => seen.push(Err(())),
            Feed::Frame(f) => seen.push(Ok(frame::decode::<Request>(f).unwrap())),
        }
    }
    assert_eq!(
        seen,
        vec![Ok((1, Request::Hello)), Err(()), Ok((2, Request::Status))]
    );
}

/// A plain arm of `joints` joints that the board can run.
fn arm_of(joints: usize) -> model::Arm<f32> {
    model::Arm::<f32> {
        gravity: [0.0, 0.0, -9.8],
        base: model::Frame::identity(),
        base_compliance: 0.0,
        base_softening: 0.0,
        tool: model::Frame::identity(),
        payload_com: [0.0; 3],
        rated_payload_kg: 0.2,
        joints: model::PerJoint::splat(
            joints,
            model::Joint {
                theta: 0.0,
                d: 0.1,
                a: 0.1,
                alpha: 0.0,
                beta: 0.0,
                kind: model::JointKind::Revolute,
                compliance: 0.01,
                limits: [-1.0, 1.0],
                mass: 0.1,
                com: [0.0; 3],
                servo: Some(model::ServoCurve::nominal()),
                backlash: 0.0,
                softening: 0.0,
            },
        ),
    }
}

/// A calibration of [`arm_of`]`(joints)` that the board accepts.
fn calibration_of(joints: usize) -> Calibration {
    let arm = arm_of(joints);
    Calibration {
        id: 1,
        option: protocol::ModelOption::Elastic,
        nominal: arm,
        calibrated: arm,
        home_rad: PerChannel::splat(joints, 0.0),
        max_correction_rad: PerChannel::splat(joints, 0.3),
    }
}

#[test]
fn calibration_rejects_what_the_board_cannot_run() {
    let good = calibration_of(6);
    assert_eq!(good.check(), Ok(()));
    let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
    let bytes = good.encode(&mut buf).unwrap().to_vec();
    assert_eq!(Calibration::decode(&bytes), Some(good));
    assert_eq!(Calibration::decode(&bytes[..bytes.len() - 1]), None);

    let mut nan = good;
    nan.calibrated.joints[3].a = f32::NAN;
    assert_eq!(nan.check(), Err(protocol::CalibrationFault::NotFinite));
    let mut limits = good;
    limits.calibrated.joints[2].limits = [0.5, 0.5];
    assert_eq!(
        limits.check(),
        Err(protocol::CalibrationFault::Limits { joint: 2 })
    );
    // Five knots whose pulse turns back between the third and fourth.
    let d = |x: f32| x.to_radians();
    let mut curve = good;
    curve.calibrated.joints[5].servo = model::ServoCurve::new(
        &[d(-100.0), d(-50.0), d(0.0), d(50.0), d(100.0)],
        &[900.0, 1280.0, 1650.0, 1640.0, 2400.0],
    )
    .ok();
    let fault = curve.check().unwrap_err();
    assert_eq!(
        fault,
        protocol::CalibrationFault::ServoCurve {
            joint: 5,
            fault: model::servo::CurveFault::PulsesNotMonotonic { knot: 3 }
        }
    );
    // A joint no servo drives: refused whole, naming the joint.
    let mut none = good;
    none.calibrated.joints[2].servo = None;
    assert_eq!(
        none.check(),
        Err(protocol::CalibrationFault::NoServo { joint: 2 })
    );
    let msg = fault.to_string();
    assert!(
        msg.contains("joint 6") && msg.contains("knot 3 to knot 4"),
        "{msg}"
    );
    let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
    let bytes = curve.encode(&mut buf).unwrap().to_vec();
    assert_eq!(
        Calibration::decode(&bytes),
        None,
        "the board refuses it whole"
    );
    let mut nine = good;
    let angles: Vec<f32> = (0..9).map(|k| d(-100.0 + 25.0 * k as f32)).collect();
    for j in nine
        .nominal
        .joints
        .iter_mut()
        .chain(&mut nine.calibrated.joints)
    {
        j.servo = j.servo.map(|c| c.resampled(&angles).unwrap());
    }
    let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
    let bytes = nine.encode(&mut buf).unwrap().to_vec();
    assert_eq!(Calibration::decode(&bytes), Some(nine));
    assert!(
        bytes.len() > 1024,
        "nine knots per joint: {} bytes",
        bytes.len()
    );
    let mut home = good;
    home.home_rad[0] = 1.5;
    assert_eq!(home.check(), Err(protocol::CalibrationFault::Home));
    let mut negative = good;
    negative.calibrated.joints[1].mass = -0.01;
    assert_eq!(negative.check(), Err(protocol::CalibrationFault::Negative));
    negative = good;
    negative.nominal.rated_payload_kg = -0.1;
    assert_eq!(negative.check(), Err(protocol::CalibrationFault::Negative));
    // Compliances, softenings and plays within the bounds worked out from
    // the nominal arm (`model::bounds`), in either arm; outside, refused whole,
    // naming the quantity as the calibration file does.
    let bounds = Bounds::of(&good.nominal);
    let refused = |c: &Calibration, quantity, calibrated| {
        let fault = c.check().unwrap_err();
        assert_eq!(
            fault,
            protocol::CalibrationFault::Bound {
                quantity,
                calibrated
            }
        );
        let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
        let bytes = c.encode(&mut buf).unwrap().to_vec();
        assert_eq!(
            Calibration::decode(&bytes),
            None,
            "the board refuses it whole"
        );
        fault.to_string()
    };
    let mut bent = good;
    bent.calibrated.joints[1].compliance = -0.01;
    let msg = refused(&bent, Quantity::Compliance { spring: 2 }, true);
    assert!(msg.contains("`k2`") && msg.contains("calibrated"), "{msg}");
    let ceiling = bounds.range(Quantity::Compliance { spring: 2 }).max;
    bent.calibrated.joints[1].compliance = ceiling * 0.99;
    assert_eq!(bent.check(), Ok(()));
    bent.calibrated.joints[1].compliance = ceiling * 1.01;
    refused(&bent, Quantity::Compliance { spring: 2 }, true);
    // Backlash: up to 5° full width is a worn hobby servo; beyond, or negative, is refused whole.
    let mut play = good;
    play.calibrated.joints[4].backlash = 4.9f32.to_radians();
    assert_eq!(play.check(), Ok(()));
    for width in [5.1f32.to_radians(), -0.001] {
        play.calibrated.joints[4].backlash = width;
        let msg = refused(&play, Quantity::Backlash { joint: 4 }, true);
        assert!(msg.contains("j5.backlash"), "{msg}");
    }
    play.calibrated.joints[4].backlash = f32::INFINITY;
    assert_eq!(play.check(), Err(protocol::CalibrationFault::NotFinite));
    // A spring may soften or stiffen, as far as the arm's largest torque allows.
    let mut soft = good;
    let floor = bounds.range(Quantity::Softening { spring: 3 }).min;
    soft.calibrated.base_softening = 0.5 * bounds.range(Quantity::Softening { spring: 0 }).max;
    soft.calibrated.joints[2].softening = floor * 0.99;
    assert_eq!(soft.check(), Ok(()));
    soft.calibrated.joints[2].softening = floor * 1.01;
    refused(&soft, Quantity::Softening { spring: 3 }, true);
    soft.calibrated.joints[2].softening = 0.0;
    soft.nominal.base_softening = -1.0;
    refused(&soft, Quantity::Softening { spring: 0 }, false);
    // Each joint's largest correction: an angle above 0 up to the protocol's cap.
    for bad in [
        0.0,
        -0.1,
        f32::NAN,
        protocol::calibration::MAX_CORRECTION_RAD * 1.01,
    ] {
        let mut c = good;
        c.max_correction_rad[3] = bad;
        assert_eq!(
            c.check(),
            Err(protocol::CalibrationFault::Correction { joint: 3 })
        );
    }
}

/// Arms of 1 to 6 joints: a calibration of a five-joint arm round-trips and
/// passes the check like a six-joint one, and so does one of a single joint.
#[test]
fn a_calibration_of_fewer_joints_round_trips_and_passes() {
    for joints in [5, 1] {
        let mut c = calibration_of(joints);
        c.home_rad[joints - 1] = 0.2;
        c.max_correction_rad[0] = 0.1;
        assert_eq!(c.check(), Ok(()), "{joints} joints");
        let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
        let bytes = c.encode(&mut buf).unwrap().to_vec();
        let back = Calibration::decode(&bytes).expect("decodes and passes");
        assert_eq!(back, c);
        assert_eq!(back.calibrated.joint_count(), joints);
        assert_eq!(
            (back.home_rad.len(), back.max_correction_rad.len()),
            (joints, joints)
        );
    }
    // Fewer joints, fewer bytes: each arm's joints, the home pose and the corrections.
    let len = |c: &Calibration| {
        let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
        c.encode(&mut buf).unwrap().len()
    };
    assert!(len(&calibration_of(5)) < len(&calibration_of(6)));
}

/// A prismatic joint, in either arm: the board drives revolute servo joints
/// only, so the calibration is refused whole, naming the joint.
#[test]
fn a_sliding_joint_is_refused_by_the_board() {
    for which in [0, 1] {
        let mut c = calibration_of(5);
        let arm = if which == 0 {
            &mut c.nominal
        } else {
            &mut c.calibrated
        };
        arm.joints[2].kind = model::JointKind::Prismatic;
        let fault = c.check().unwrap_err();
        assert_eq!(fault, CalibrationFault::Prismatic { joint: 2 });
        assert!(
            fault.to_string().contains("joint 3 is prismatic"),
            "{fault}"
        );
        let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
        let bytes = c.encode(&mut buf).unwrap().to_vec();
        assert_eq!(Calibration::decode(&bytes), None, "refused whole");
    }
}

/// No joint, more joints than the board has channels, or arms, home pose and
/// corrections of different lengths: refused with `JointCount`, naming the
/// calibrated arm's joints, and refused whole by the board's decoder.
#[test]
fn joint_counts_the_board_cannot_drive_are_refused() {
    let refused = |c: &Calibration, joints: u8| {
        let fault = c.check().unwrap_err();
        assert_eq!(fault, CalibrationFault::JointCount { joints });
        let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
        let bytes = c.encode(&mut buf).unwrap().to_vec();
        assert_eq!(Calibration::decode(&bytes), None, "refused whole");
        fault.to_string()
    };
    // No joint at all.
    let none = Calibration {
        nominal: arm_of(0),
        calibrated: arm_of(0),
        home_rad: PerChannel::splat(0, 0.0),
        max_correction_rad: PerChannel::splat(0, 0.3),
        ..calibration_of(1)
    };
    let msg = refused(&none, 0);
    assert!(msg.contains("0 joints") && msg.contains("1 to 6"), "{msg}");
    // Seven joints: more than the six channels (the home pose and the
    // corrections cannot even say seven values).
    let seven = Calibration {
        nominal: arm_of(7),
        calibrated: arm_of(7),
        ..calibration_of(6)
    };
    let msg = refused(&seven, 7);
    assert!(msg.contains("7 joints"), "{msg}");
    // Lengths that do not agree, each part in turn.
    let mut nominal = calibration_of(5);
    nominal.nominal = arm_of(6);
    refused(&nominal, 5);
    let mut calibrated = calibration_of(5);
    calibrated.calibrated = arm_of(4);
    refused(&calibrated, 4);
    let mut home = calibration_of(5);
    home.home_rad = PerChannel::splat(6, 0.0);
    refused(&home, 5);
    let mut corrections = calibration_of(5);
    corrections.max_correction_rad = PerChannel::splat(4, 0.3);
    refused(&corrections, 5);
}

/// A payload whose home pose says seven values is not a calibration: the
/// decoder stops at the sixth, whatever the arms say.
#[test]
fn a_payload_with_more_values_than_channels_does_not_decode() {
    #[derive(serde::Serialize)]
    struct Like<'a> {
        id: u32,
        option: protocol::ModelOption,
        nominal: model::Arm<f32>,
        calibrated: model::Arm<f32>,
        home_rad: &'a [f32],
        max_correction_rad: &'a [f32],
    }
    let like = |n: usize| {
        let c = calibration_of(6);
        Like {
            id: c.id,
            option: c.option,
            nominal: c.nominal,
            calibrated: c.calibrated,
            home_rad: &[0.0; 7][..n],
            max_correction_rad: &[0.3; 6],
        }
    };
    let bytes = |l: &Like| {
        let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
        postcard::to_slice(l, &mut buf).unwrap().to_vec()
    };
    assert_eq!(
        Calibration::decode(&bytes(&like(6))),
        Some(calibration_of(6)),
        "the mirror is faithful"
    );
    assert_eq!(Calibration::decode(&bytes(&like(7))), None);
}

proptest! {
    #[test]
    fn decoding_any_bytes_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = frame::decode::<Request>(&bytes);
        let _ = frame::decode::<Response>(&bytes);
        let mut reader = FrameReader::<MAX_FRAME>::new();
        for b in bytes {
            if let Feed::Frame(f) = reader.feed(b) {
                let _ = frame::decode::<Request>(f);
            }
        }
    }

    #[test]
    fn moves_round_trip(seq in any::<u16>(), t in proptest::collection::vec(any::<f32>(), 1..=CHANNELS), ms in any::<u32>()) {
        let req = Request::Move { targets_rad: PerChannel::from_slice(&t).unwrap(), timing: Timing::DurationMs(ms) };
        let (s, back): (u16, Request) = frame::decode(&frame_of(seq, &req)).unwrap();
        prop_assert_eq!(s, seq);
        // Compare bit patterns: NaN != NaN but must survive the trip unchanged.
        let Request::Move { targets_rad, timing } = back else { panic!("not a move") };
        let bits: Vec<u32> = targets_rad.iter().map(|x| x.to_bits()).collect();
        prop_assert_eq!(bits, t.iter().map(|x| x.to_bits()).collect::<Vec<_>>());
        prop_assert_eq!(timing, Timing::DurationMs(ms));
    }

    #[test]
    fn chunks_round_trip(offset in any::<u32>(), data in proptest::collection::vec(any::<u8>(), 0..=protocol::CHUNK_LEN)) {
        let req = Request::CalibrationChunk { offset, data: heapless::Vec::from_slice(&data).unwrap() };
        let (_, back): (u16, Request) = frame::decode(&frame_of(1, &req)).unwrap();
        prop_assert_eq!(back, req);
    }
}
