//! Frame rules: corruption is caught, versions are told apart, and no byte
//! sequence makes the decoder or the stream reader panic.

use model::bounds::{Bounds, Quantity};
use proptest::prelude::*;
use protocol::frame::{self, Feed, FrameError, FrameReader, MAX_FRAME};
use protocol::{Calibration, Request, Response, Timing, WireError};

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

#[test]
fn calibration_rejects_what_the_board_cannot_run() {
    let arm = model::Arm::<f32> {
        gravity: [0.0, 0.0, -9.8],
        base: model::Frame::identity(),
        base_compliance: 0.0,
        base_softening: 0.0,
        tool: model::Frame::identity(),
        payload_com: [0.0; 3],
        rated_payload_kg: 0.2,
        joints: [model::Joint {
            theta: 0.0,
            d: 0.1,
            a: 0.1,
            alpha: 0.0,
            compliance: 0.01,
            limits: [-1.0, 1.0],
            mass: 0.1,
            com: [0.0; 3],
            servo: model::ServoCurve::nominal(),
            backlash: 0.0,
            softening: 0.0,
        }; 6],
    };
    let good = Calibration {
        id: 1,
        option: protocol::ModelOption::Elastic,
        nominal: arm,
        calibrated: arm,
        home_rad: [0.0; 6],
        max_correction_rad: [0.3; 6],
    };
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
    .unwrap();
    let fault = curve.check().unwrap_err();
    assert_eq!(
        fault,
        protocol::CalibrationFault::ServoCurve {
            joint: 5,
            fault: model::servo::CurveFault::PulsesNotMonotonic { knot: 3 }
        }
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
        j.servo = j.servo.resampled(&angles).unwrap();
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
    fn moves_round_trip(seq in any::<u16>(), t in proptest::array::uniform6(any::<f32>()), ms in any::<u32>()) {
        let req = Request::Move { targets_rad: t, timing: Timing::DurationMs(ms) };
        let (s, back): (u16, Request) = frame::decode(&frame_of(seq, &req)).unwrap();
        prop_assert_eq!(s, seq);
        // Compare bit patterns: NaN != NaN but must survive the trip unchanged.
        let Request::Move { targets_rad, timing } = back else { panic!("not a move") };
        prop_assert_eq!(targets_rad.map(f32::to_bits), t.map(f32::to_bits));
        prop_assert_eq!(timing, Timing::DurationMs(ms));
    }

    #[test]
    fn chunks_round_trip(offset in any::<u32>(), data in proptest::collection::vec(any::<u8>(), 0..=protocol::CHUNK_LEN)) {
        let req = Request::CalibrationChunk { offset, data: heapless::Vec::from_slice(&data).unwrap() };
        let (_, back): (u16, Request) = frame::decode(&frame_of(1, &req)).unwrap();
        prop_assert_eq!(back, req);
    }
}
