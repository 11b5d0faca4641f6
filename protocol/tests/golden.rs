//! Golden bytes: the exact frames of a few messages, kept in
//! `tests/snapshots/wire_frames.snap`. Any drift of the encoding fails here,
//! which is the reminder to bump `PROTOCOL_VERSION` (see `protocol::frame`).
//! After a deliberate, version-bumped change, replace the snapshot with the
//! text this test prints.

use std::fmt::Write as _;

use model::{Arm, Frame, Joint, PerJoint, ServoCurve};
use protocol::frame::{self, MAX_FRAME};
use protocol::messages::{
    CalibrationInfo, CompensationReport, DeviceInfo, Faults, FirmwareVersion, Status,
};
use protocol::{
    Calibration, CompensationMode, ModelOption, PerChannel, Request, Response, Timing, WireError,
};

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn frame_of<M: serde::Serialize>(seq: u16, msg: &M) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let n = frame::encode(seq, msg, &mut out).unwrap();
    out[..n].to_vec()
}

/// A small, fixed arm of `joints` joints so the calibration bytes are stable.
pub fn fixed_arm(joints: usize) -> Arm<f32> {
    let joint = |i: usize| Joint {
        theta: 0.0,
        d: 0.01 * i as f32,
        a: 0.1,
        alpha: 1.5,
        beta: 0.0,
        kind: model::JointKind::Revolute,
        compliance: 0.02,
        limits: [-1.5, 1.5],
        mass: 0.1,
        com: [0.0, 0.0, 0.01],
        servo: Some(if i == 0 {
            let d = |x: f32| x.to_radians();
            ServoCurve::new(
                &[d(-100.0), d(-50.0), d(0.0), d(50.0), d(100.0)],
                &[900.0, 1280.0, 1650.0, 2020.0, 2400.0],
            )
            .unwrap()
        } else {
            ServoCurve::from_three_points(900.0, 1650.0, 2400.0)
        }),
        backlash: 0.001 * i as f32,
        softening: 0.05 * i as f32,
    };
    Arm {
        gravity: [0.0, 0.0, -9.80665],
        base: Frame::identity(),
        base_compliance: 0.03,
        base_softening: -0.02,
        tool: Frame {
            xyz: [0.0, 0.0, 0.04],
            rpy: [0.0; 3],
        },
        payload_com: [0.0; 3],
        rated_payload_kg: 0.1,
        joints: PerJoint::from_fn(joints, joint),
    }
}

fn samples() -> Vec<(&'static str, Vec<u8>)> {
    let status = Status {
        device: DeviceInfo {
            protocol: 2,
            firmware: FirmwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
            channels: 6,
        },
        calibration: Some(CalibrationInfo {
            id: 0xC0FFEE,
            option: ModelOption::ElastoKinematic,
            joints: 6,
            sequence: 7,
        }),
        mode: CompensationMode::Full,
        compensation: CompensationReport {
            converged: true,
            iterations: 2,
            error_um: 0.5,
            fallbacks: 1,
        },
        payload_kg: 0.0663,
        moving: false,
        targets_rad: [0.0, 0.5, -0.5, 0.0, 1.0, 0.0].into(),
        nominal_rad: [0.0, 0.5, -0.5, 0.0, 1.0, 0.0].into(),
        pulses_us: [1650, 1865, 1435, 1650, 2080, 0],
        faults: Faults::LIMIT_CLAMPED,
        frames_dropped: 3,
        uptime_ms: 123_456,
    };
    let calibration = Calibration {
        id: 42,
        option: ModelOption::Kinematic,
        nominal: fixed_arm(6),
        calibrated: fixed_arm(6),
        home_rad: PerChannel::splat(6, 0.0),
        max_correction_rad: [0.1, 0.2, 0.3, 0.4, 0.5, 0.6].into(),
    };
    let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
    let cal = calibration.encode(&mut buf).unwrap().to_vec();
    // An arm of two joints: the counts in front of each arm's joints, the home
    // pose and the corrections say 2.
    let short = Calibration {
        nominal: fixed_arm(2),
        calibrated: fixed_arm(2),
        home_rad: PerChannel::splat(2, 0.0),
        max_correction_rad: [0.1, 0.2].into(),
        ..calibration
    };
    assert_eq!(short.check(), Ok(()));
    let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
    let short = short.encode(&mut buf).unwrap().to_vec();
    // A status of a five-joint arm: five targets and angles, six pulses.
    let five = Status {
        calibration: status
            .calibration
            .map(|c| CalibrationInfo { joints: 5, ..c }),
        targets_rad: [0.0, 0.5, -0.5, 0.0, 1.0].into(),
        nominal_rad: [0.0, 0.5, -0.5, 0.0, 1.0].into(),
        pulses_us: [1650, 1865, 1435, 1650, 2080, 0],
        ..status
    };
    let options: Vec<u8> = ModelOption::ALL
        .iter()
        .flat_map(|o| postcard::to_slice(o, &mut [0u8; 1]).unwrap().to_vec())
        .collect();
    vec![
        ("request hello", frame_of(1, &Request::Hello)),
        ("request status", frame_of(2, &Request::Status)),
        (
            "request move",
            frame_of(
                3,
                &Request::Move {
                    targets_rad: [0.0, 0.5, -0.5, 0.0, 1.0, 0.0].into(),
                    timing: Timing::DurationMs(1500),
                },
            ),
        ),
        (
            "request move, five joints",
            frame_of(
                3,
                &Request::Move {
                    targets_rad: [0.0, 0.5, -0.5, 0.0, 1.0].into(),
                    timing: Timing::DurationMs(1500),
                },
            ),
        ),
        (
            "request home",
            frame_of(
                4,
                &Request::Home {
                    timing: Timing::SpeedRadPerS(0.5),
                },
            ),
        ),
        (
            "request detach all",
            frame_of(5, &Request::Detach { channel: None }),
        ),
        (
            "request raw pulse",
            frame_of(
                6,
                &Request::RawPulse {
                    channel: 2,
                    pulse_us: 1500,
                },
            ),
        ),
        (
            "request payload",
            frame_of(7, &Request::SetPayload { mass_kg: 0.0663 }),
        ),
        (
            "request mode",
            frame_of(
                8,
                &Request::SetCompensation {
                    mode: CompensationMode::ElasticOnly,
                },
            ),
        ),
        (
            "request calib begin",
            frame_of(
                9,
                &Request::CalibrationBegin {
                    len_bytes: 830,
                    crc: 0xDEADBEEF,
                },
            ),
        ),
        (
            "request calib chunk",
            frame_of(
                10,
                &Request::CalibrationChunk {
                    offset: 128,
                    data: heapless::Vec::from_slice(&[0, 1, 2, 0, 255]).unwrap(),
                },
            ),
        ),
        (
            "request bootloader",
            frame_of(0xFFFF, &Request::RebootToBootloader),
        ),
        ("response done", frame_of(3, &Response::Done)),
        (
            "response hello",
            frame_of(1, &Response::Hello(status.device)),
        ),
        ("response status", frame_of(2, &Response::Status(status))),
        (
            "response status, five joints",
            frame_of(2, &Response::Status(five)),
        ),
        (
            "response error",
            frame_of(9, &Response::Error(WireError::CalibrationCrc)),
        ),
        (
            "response error, target count",
            frame_of(9, &Response::Error(WireError::TargetCount)),
        ),
        (
            "response error, unused channel",
            frame_of(9, &Response::Error(WireError::UnusedChannel)),
        ),
        ("calibration payload", cal),
        ("calibration payload, two joints", short),
        ("model options, table order", options),
    ]
}

#[test]
fn frames_match_the_snapshot() {
    let mut now = String::new();
    for (name, bytes) in samples() {
        writeln!(now, "{name}: {}", hex(&bytes)).unwrap();
    }
    let golden = include_str!("snapshots/wire_frames.snap");
    assert!(
        now == golden,
        "wire encoding drifted; bump PROTOCOL_VERSION and use:\n{now}"
    );
}

#[test]
fn every_sample_decodes_back() {
    for (name, bytes) in samples() {
        if name.starts_with("request") {
            let (_, r): (u16, Request) = frame::decode(&bytes).unwrap();
            assert_eq!(
                frame_of(frame::decode::<Request>(&bytes).unwrap().0, &r),
                bytes,
                "{name}"
            );
        } else if name.starts_with("response") {
            let (_, r): (u16, Response) = frame::decode(&bytes).unwrap();
            assert_eq!(
                frame_of(frame::decode::<Response>(&bytes).unwrap().0, &r),
                bytes,
                "{name}"
            );
        }
    }
}
