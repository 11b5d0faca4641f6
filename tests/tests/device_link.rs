//! The host client and the firmware library together, over an in-memory
//! link, with the recording servo bus and a simulated flash that can lose
//! power: push → store → reboot → status → move, and the failure paths a
//! user meets (unplugged mid-upload, power cut while writing, garbage).

use std::io::Write;
use std::time::Duration;

use firmware::sim::SimFlash;
use lrmcal_core::io::calibration_file::{
    CalibrationFile, ErrorStats, SCHEMA, SCHEMA_VERSION, TargetTool,
};
use lrmcal_engine::calib::ModelOption;
use lrmcal_engine::device::memory::MemoryBoard;
use lrmcal_engine::device::{Client, ClientError, CommsError, calibration};
use model::{Arm, ParamId};
use protocol::frame::MAX_FRAME;
use protocol::{CompensationMode, Faults, Timing, WireError};

/// The board at the other end of a USB cable, run in-process: every read by
/// the host lets 20 ms of board time pass (one servo frame).
fn board(flash: SimFlash) -> MemoryBoard {
    MemoryBoard::new(flash).running()
}

fn client(board: MemoryBoard) -> Client<MemoryBoard> {
    Client::new(board, Duration::from_millis(50), 2)
}

/// A calibration file as `lrmcal identify` writes it, for the bundled arm
/// with millimetre/degree-level corrections and measured servo curves of 3
/// to 9 knots.
fn calibration_file() -> CalibrationFile {
    let nominal = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
    let ids: Vec<ParamId> = ParamId::all(6).collect();
    let errors: Vec<f64> = ids
        .iter()
        .enumerate()
        .map(|(i, id)| {
            let s = if i % 2 == 0 { 1.0 } else { -1.0 };
            match id.kind() {
                model::params::ParamKind::Length => 0.0015 * s,
                model::params::ParamKind::Angle => 0.01 * s,
                model::params::ParamKind::Compliance => 0.02,
            }
        })
        .collect();
    let mut arm: Arm<f64> = nominal.with_errors(&ids, &errors);
    for (i, j) in arm.joints.iter_mut().enumerate() {
        let n = 3 + i;
        let angles: Vec<f64> = (0..n)
            .map(|k| (-100.0 + 200.0 * k as f64 / (n - 1) as f64).to_radians())
            .collect();
        let ends = model::ServoCurve::from_three_points(
            880.0 + 9.0 * i as f64,
            1640.0,
            2410.0 - 5.0 * i as f64,
        );
        // A bow of a few µs between the ends, as a real servo's potentiometer has.
        let pulses: Vec<f64> = angles
            .iter()
            .map(|&a| ends.pulse_us(a) + 8.0 * (a * 1.5).sin())
            .collect();
        j.servo = model::ServoCurve::new(&angles, &pulses).ok();
    }
    CalibrationFile {
        schema: SCHEMA.into(),
        schema_version: SCHEMA_VERSION,
        option: ModelOption::ElastoKinematic,
        nominal,
        arm,
        parameters: vec![],
        at_bound: vec![],
        removed: vec![],
        poses_used: vec![],
        loads_kg: vec![0.0663],
        fit_residual: ErrorStats::of(&[0.001]),
        converged: true,
        arm_name: None,
        joint_names: vec![],
        validation: None,
        targets: vec![],
        registration: None,
    }
}

/// A calibration of two targets pushed for the second: the board stores and
/// hands back arms whose tool point is that target's, nothing else changed;
/// an unknown name is refused before anything is sent, listing the names.
#[test]
fn push_for_a_named_target_sends_its_tool_point() {
    let mut file = calibration_file();
    let marker = [0.01, 0.03, 0.05];
    for (name, tool_m) in [("m0", file.arm.tool.xyz), ("m1", marker)] {
        file.targets.push(TargetTool {
            name: name.into(),
            tool_m,
            fit_residual: ErrorStats::of(&[0.001]),
            validation_after: None,
        });
    }
    let chosen = file.for_target(Some("m1")).unwrap();
    let payload = calibration::payload(&chosen, [0.0; 6].into()).unwrap();
    let first = calibration::payload(&file, [0.0; 6].into()).unwrap();
    assert_ne!(payload.id, first.id);
    let mut c = client(board(SimFlash::new()));
    c.hello().unwrap();
    assert_eq!(
        c.push_calibration(&payload, |_, _| ()).unwrap().id,
        payload.id
    );
    let stored = c.pull_calibration().unwrap();
    assert_eq!(stored.calibrated.tool.xyz, marker.map(|x| x as f32));
    assert_eq!(stored.nominal.tool.xyz, marker.map(|x| x as f32));
    assert_eq!(stored.calibrated.joints, file.arm.map(|x| x as f32).joints);
    let e = file.for_target(Some("m7")).unwrap_err();
    assert!(e.contains("`m7`") && e.contains("m0, m1"), "{e}");
}

/// Ours, the default option, travels and is stored as itself: the payload
/// encodes and decodes it, `status` reports it after a reboot, and `pull`
/// hands it back. Its id differs from the same arms' elasto-kinematic one.
#[test]
fn an_elasto_kinematic_servo_calibration_keeps_its_option_on_the_board() {
    let file = CalibrationFile {
        option: ModelOption::ElastoKinematicServo,
        ..calibration_file()
    };
    let payload = calibration::payload(&file, [0.0; 6].into()).unwrap();
    assert_eq!(payload.option, ModelOption::ElastoKinematicServo);
    let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
    let decoded = protocol::Calibration::decode(payload.encode(&mut buf).unwrap()).unwrap();
    assert_eq!(decoded, payload);
    let paper = calibration::payload(&calibration_file(), [0.0; 6].into()).unwrap();
    assert_eq!(paper.option, ModelOption::ElastoKinematic);
    assert_ne!(payload.id, paper.id);

    let mut c = client(board(SimFlash::new()));
    c.hello().unwrap();
    assert_eq!(
        c.push_calibration(&payload, |_, _| ()).unwrap().option,
        ModelOption::ElastoKinematicServo
    );
    c.link_mut().reboot();
    let info = c.status().unwrap().calibration.unwrap();
    assert_eq!(
        (info.id, info.option),
        (payload.id, ModelOption::ElastoKinematicServo)
    );
    assert_eq!(c.pull_calibration().unwrap(), payload);
}

#[test]
fn push_store_reboot_status_move() {
    let file = calibration_file();
    let payload = calibration::payload(&file, [0.0; 6].into()).unwrap();
    let mut c = client(board(SimFlash::new()));

    let info = c.hello().unwrap();
    assert_eq!(info.protocol, protocol::frame::PROTOCOL_VERSION);
    let s = c.status().unwrap();
    assert!(s.faults.contains(Faults::NO_CALIBRATION) && s.calibration.is_none());

    let mut last = 0;
    let stored = c.push_calibration(&payload, |sent, _| last = sent).unwrap();
    assert_eq!(stored.id, payload.id);
    assert!(
        last > 600,
        "the payload went in several chunks ({last} bytes)"
    );
    assert_eq!(c.pull_calibration().unwrap(), payload);

    c.link_mut().reboot();
    let s = c.status().unwrap();
    assert_eq!(
        s.calibration.map(|i| i.id),
        Some(payload.id),
        "calibration survives the reboot"
    );
    assert!(!s.faults.contains(Faults::NO_CALIBRATION));
    assert_eq!(s.pulses_us, [0; 6], "starts limp after the reboot");

    c.set_payload(0.0663).unwrap();
    c.set_compensation(CompensationMode::Full).unwrap();
    let target = [0.3f32, 0.5, -0.6, 0.2, 0.7, -0.1];
    c.move_to(target.into(), Timing::DurationMs(1500)).unwrap();
    assert!(matches!(
        c.move_to(target.into(), Timing::DurationMs(1500)),
        Err(ClientError::Endpoint {
            error: WireError::Busy,
            ..
        })
    ));
    let s = c
        .wait_until_still(Duration::ZERO, Duration::from_secs(5))
        .unwrap();
    assert_eq!(s.nominal_rad, target);
    assert!(s.compensation.converged, "{:?}", s.compensation);

    // The pulses are the calibrated curves of the compensated joint angles, and
    // the compensated, deflected calibrated arm (f64) puts the tool where the
    // nominal arm would be.
    let arm64 = file.arm;
    let pulses = s.pulses_us;
    let commanded: [f64; 6] =
        std::array::from_fn(|i| arm64.joints[i].servo.unwrap().angle(pulses[i] as f64));
    let opts = model::SolverOptions::default();
    let want = file
        .board_arms()
        .0
        .chain()
        .tool_point(&target.map(f64::from), 0.0663, &opts)
        .unwrap();
    let got = arm64.chain().tool_point(&commanded, 0.0663, &opts).unwrap();
    // One microsecond of pulse is ~2.3 mrad of joint angle: the board's PWM resolution bounds this.
    assert!(
        (got - want).norm() < 2e-3,
        "tool {:.3} mm off",
        (got - want).norm() * 1e3
    );
    let uncompensated: [f64; 6] = target.map(f64::from);
    let off = arm64
        .chain()
        .tool_point(&uncompensated, 0.0663, &opts)
        .unwrap();
    assert!(
        (off - want).norm() > 3.0 * (got - want).norm(),
        "compensation must help"
    );
}

#[test]
fn unplugged_mid_upload_keeps_the_old_calibration_and_says_so() {
    let file = calibration_file();
    let first = calibration::payload(&file, [0.0; 6].into()).unwrap();
    let second = calibration::payload(&file, [0.1, 0.0, 0.0, 0.0, 0.0, 0.0].into()).unwrap();
    assert_ne!(first.id, second.id);
    let mut c = client(board(SimFlash::new()));
    c.push_calibration(&first, |_, _| {}).unwrap();

    c.link_mut().pull_cable_after(400);
    let err = c.push_calibration(&second, |_, _| {}).unwrap_err();
    assert!(
        matches!(err, ClientError::Comms(CommsError::Io { .. })),
        "{err:?}"
    );
    assert!(err.to_string().contains("unplugged"), "{err}");

    c.link_mut().reconnect_cable();
    c.link_mut().reboot();
    assert_eq!(
        c.status().unwrap().calibration.map(|i| i.id),
        Some(first.id)
    );
}

#[test]
fn power_cut_while_writing_flash_keeps_the_old_calibration() {
    let file = calibration_file();
    let first = calibration::payload(&file, [0.0; 6].into()).unwrap();
    let second = calibration::payload(&file, [0.1, 0.0, 0.0, 0.0, 0.0, 0.0].into()).unwrap();
    let mut flash = SimFlash::new();
    {
        let mut c = client(board(flash));
        c.push_calibration(&first, |_, _| {}).unwrap();
        flash = c.link_mut().power_off();
    }
    for cut in [0, 1, 500, 4095, 4096, 4200, 4700, 4900] {
        let mut f = flash.clone();
        f.cut_after(cut);
        let mut c = client(board(f));
        let err = c.push_calibration(&second, |_, _| {}).unwrap_err();
        assert!(
            matches!(
                err,
                ClientError::Endpoint {
                    error: WireError::Flash,
                    ..
                }
            ),
            "cut {cut}: {err:?}"
        );
        c.link_mut().reboot();
        assert_eq!(
            c.status().unwrap().calibration.map(|i| i.id),
            Some(first.id),
            "cut {cut}"
        );
    }
}

#[test]
fn garbage_on_the_line_is_survived_and_the_next_request_works() {
    // No retries: the first attempt after the garbage must get through.
    let mut c = Client::new(board(SimFlash::new()), Duration::from_millis(50), 0);
    let mut rng_state = 0x1234_5678u32;
    let garbage: Vec<u8> = (0..5000)
        .map(|_| {
            rng_state = rng_state
                .wrapping_mul(1_664_525)
                .wrapping_add(1_013_904_223);
            (rng_state >> 24) as u8
        })
        .collect();
    // No terminator after the garbage: the client's own leading 0x00 resynchronises.
    c.link_mut().write_all(&garbage).unwrap();
    c.link_mut().write_all(b"half a frame").unwrap();
    let s = c.status().unwrap();
    assert!(s.frames_dropped > 0);
}

/// What `hello` says to a board that answers every frame with `reply` under protocol `version`.
fn hello_to_a_board_of(version: u8, reply: &protocol::Response) -> ClientError {
    let mut out = [0u8; MAX_FRAME];
    let n = protocol::frame::encode_with_version(version, 1, reply, &mut out).unwrap();
    let mut c = client(board(SimFlash::new()));
    c.link_mut().answer_with(&out[..n]);
    c.hello().unwrap_err()
}

#[test]
fn a_board_of_another_protocol_version_is_named_clearly() {
    let err = hello_to_a_board_of(9, &protocol::Response::Done);
    assert!(
        matches!(err, ClientError::Comms(CommsError::Version { board: 9 })),
        "{err:?}"
    );
    assert!(err.to_string().contains("update lrmcal"), "{err}");
}

#[test]
fn a_board_of_an_older_protocol_is_told_to_be_reflashed() {
    // A board of protocol 1, or of the previous one, refuses every frame of
    // ours under its own version.
    for board in [1, protocol::PROTOCOL_VERSION - 1] {
        let err = hello_to_a_board_of(
            board,
            &protocol::Response::Error(WireError::VersionMismatch),
        );
        assert!(
            matches!(err, ClientError::Comms(CommsError::Version { board: b }) if b == board),
            "{err:?}"
        );
        let msg = err.to_string();
        assert!(
            msg.contains(&format!(
                "the board speaks protocol {board}, this lrmcal speaks {}: reflash the firmware",
                protocol::PROTOCOL_VERSION
            )),
            "{msg}"
        );
    }
}

#[test]
fn a_non_monotonic_curve_never_leaves_the_host() {
    let file = calibration_file();
    let mut bad = calibration::payload(&file, [0.0; 6].into()).unwrap();
    let pulses = bad.calibrated.joints[4]
        .servo
        .as_mut()
        .unwrap()
        .pulses_us_mut();
    pulses[3] = pulses[2] - 1.0;
    let mut c = client(board(SimFlash::new()));
    let err = c.push_calibration(&bad, |_, _| {}).unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Invalid(protocol::CalibrationFault::ServoCurve { joint: 4, .. })
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("not sent"), "{err}");
    let status = c.status().unwrap();
    assert_eq!(status.calibration, None, "nothing reached the board");
    assert_eq!(status.frames_dropped, 0);
}

#[test]
fn lost_replies_are_retried_and_a_lost_commit_answer_is_recovered() {
    let file = calibration_file();
    let payload = calibration::payload(&file, [0.0; 6].into()).unwrap();
    let mut c = client(board(SimFlash::new()));
    for path in ["status/get", "calib/chunk", "calib/chunk", "calib/commit"] {
        c.link_mut().lose_reply_to(path);
    }
    assert!(c.status().unwrap().calibration.is_none(), "status retried");
    // Chunks are re-sent (harmless), and the commit's lost answer is
    // recovered from the status: the board did store it.
    let info = c.push_calibration(&payload, |_, _| {}).unwrap();
    assert_eq!(info.id, payload.id);
    assert_eq!(c.link_mut().replies_to_lose(), 0);
    c.link_mut().reboot();
    assert_eq!(
        c.status().unwrap().calibration.map(|i| i.id),
        Some(payload.id)
    );
}

#[test]
fn a_silent_board_times_out_after_the_retries() {
    let mut c = client(board(SimFlash::new()));
    for _ in 0..3 {
        c.link_mut().lose_reply_to("status/get");
    }
    let err = c.status().unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Comms(CommsError::Timeout { attempts: 3, .. })
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("after 3 attempts"), "{err}");
}
