//! Behaviour of the whole [`Device`] through its two entry points, against
//! the recording servo bus and the simulated flash.

use proptest::prelude::*;
use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::{self, MAX_FRAME};
use protocol::{
    CHUNK_LEN, Calibration, CompensationMode, Faults, PerChannel, Request, Response, Status,
    Timing, WireError,
};
use rand::{Rng, SeedableRng, rngs::StdRng};

use crate::sim::{MockBus, SimFlash, test_calibration, test_calibration_of};
use crate::{Config, Device};

mod calibration;
mod compensation;
mod joints;

const FRAME_US: u64 = 20_000;

struct Harness {
    dev: Device<MockBus, SimFlash>,
    now: u64,
    seq: u16,
}

impl Harness {
    fn boot(flash: SimFlash) -> Self {
        Self {
            dev: Device::new(MockBus::default(), flash, Config::default(), 1_000),
            now: 1_000,
            seq: 0,
        }
    }

    fn request(&mut self, req: &Request) -> Response {
        self.seq = self.seq.wrapping_add(1);
        let mut buf = [0u8; MAX_FRAME];
        let n = frame::encode(self.seq, req, &mut buf).unwrap();
        let mut out = [0u8; MAX_FRAME];
        let m = self.dev.handle_frame(&buf[..n], &mut out);
        let (seq, resp) = frame::decode::<Response>(&out[..m]).unwrap();
        assert_eq!(seq, self.seq);
        resp
    }

    fn status(&mut self) -> Status {
        match self.request(&Request::Status) {
            Response::Status(s) => s,
            other => panic!("{other:?}"),
        }
    }

    fn frames(&mut self, n: usize) {
        for _ in 0..n {
            self.now += FRAME_US;
            self.dev.servo_frame(self.now);
        }
    }

    fn push(&mut self, cal: &Calibration) -> Response {
        let mut buf = [0u8; MAX_CALIBRATION_LEN];
        let bytes = cal.encode(&mut buf).unwrap();
        let begin = Request::CalibrationBegin {
            len_bytes: bytes.len() as u32,
            crc: frame::crc32(bytes),
        };
        assert_eq!(
            self.request(&begin),
            Response::CalibrationAck { received: 0 }
        );
        for (k, chunk) in bytes.chunks(CHUNK_LEN).enumerate() {
            let req = Request::CalibrationChunk {
                offset: (k * CHUNK_LEN) as u32,
                data: heapless::Vec::from_slice(chunk).unwrap(),
            };
            assert!(matches!(
                self.request(&req),
                Response::CalibrationAck { .. }
            ));
        }
        self.request(&Request::CalibrationCommit)
    }

    /// The stored calibration's bytes, read back over the link.
    fn read_back(&mut self) -> Option<Vec<u8>> {
        let mut got = Vec::new();
        loop {
            let reply = self.request(&Request::CalibrationRead {
                offset: got.len() as u32,
            });
            let Response::CalibrationData {
                len_bytes, data, ..
            } = reply
            else {
                assert_eq!(reply, Response::Error(WireError::NoCalibration));
                return None;
            };
            got.extend_from_slice(&data);
            if got.len() >= len_bytes as usize {
                return Some(got);
            }
        }
    }

    /// A move to `q`, one target per joint, as fast as the board allows.
    fn move_to<const N: usize>(&mut self, q: [f32; N]) -> Response {
        self.request(&Request::Move {
            targets_rad: q.into(),
            timing: Timing::DurationMs(0),
        })
    }
}

/// The most a held servo's pulse may change from one frame to the next while
/// a correction fades in or out, µs: the steepest segment of `cal`'s curves
/// (µs per rad) times the largest correction change per 20 ms frame, plus
/// one for rounding.
fn largest_fading_step_us(cal: &Calibration) -> f32 {
    let steepest = |curve: &model::ServoCurve<f32>| {
        let (a, p) = (curve.angles_rad(), curve.pulses_us());
        (1..a.len())
            .map(|k| ((p[k] - p[k - 1]) / (a[k] - a[k - 1])).abs())
            .fold(0.0, f32::max)
    };
    let slope = cal
        .calibrated
        .joints
        .iter()
        .filter_map(|j| j.servo.as_ref().map(steepest))
        .fold(0.0, f32::max);
    slope * Config::default().max_correction_rate_rad_s * 0.02 + 1.0
}

#[test]
fn starts_limp_without_calibration_and_says_so() {
    let mut h = Harness::boot(SimFlash::new());
    assert_eq!(
        h.dev.bus().log,
        (0..6).map(|c| (c, None)).collect::<Vec<_>>()
    );
    h.frames(10);
    assert!(
        h.dev.bus().log.iter().all(|(_, p)| p.is_none()),
        "no pulse before a command"
    );
    let s = h.status();
    assert!(s.faults.contains(Faults::NO_CALIBRATION));
    assert_eq!(s.calibration, None);
    assert_eq!(s.pulses_us, [0; 6]);
    // Without a calibration, an arm of one joint per channel, as before
    // arms of other sizes existed.
    assert_eq!(s.device.channels, 6);
    assert_eq!(
        (s.targets_rad, s.nominal_rad),
        ([0.0; 6].into(), [0.0; 6].into())
    );
    assert_eq!(
        h.request(&Request::SetCompensation {
            mode: CompensationMode::Full
        }),
        Response::Error(WireError::NoCalibration)
    );
}

#[test]
fn first_move_starts_at_home_without_a_jump_using_nominal_curves() {
    let mut h = Harness::boot(SimFlash::new());
    assert_eq!(h.move_to([0.5, 0.0, 0.0, 0.0, 0.0, 0.0]), Response::Done);
    h.frames(1);
    // Nominal curve: 1650 µs at 0 rad; the first frame has barely left home.
    let first = h.dev.bus().now[0].unwrap();
    assert!((1650..1660).contains(&first), "{first}");
    assert_eq!(h.dev.bus().now[1], Some(1650));
    h.frames(200);
    let expected = (1650.0 + 750.0 * 0.5 / 100f32.to_radians()).round() as u16;
    assert_eq!(h.dev.bus().now[0], Some(expected));
    assert!(!h.status().moving);
}

#[test]
fn moves_are_refused_outside_limits_or_with_nan_and_change_nothing() {
    let mut h = Harness::boot(SimFlash::new());
    assert_eq!(
        h.move_to([2.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        Response::Error(WireError::OutOfRange)
    );
    assert_eq!(
        h.move_to([f32::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]),
        Response::Error(WireError::NotFinite)
    );
    let slow = Request::Move {
        targets_rad: [0.1; 6].into(),
        timing: Timing::SpeedRadPerS(-1.0),
    };
    assert_eq!(h.request(&slow), Response::Error(WireError::OutOfRange));
    let forever = Request::Move {
        targets_rad: [0.1; 6].into(),
        timing: Timing::DurationMs(u32::MAX),
    };
    assert_eq!(h.request(&forever), Response::Error(WireError::OutOfRange));
    h.frames(5);
    assert!(h.dev.bus().log.iter().all(|(_, p)| p.is_none()));
    assert_eq!(h.move_to([0.1; 6]), Response::Done);
    assert_eq!(h.move_to([0.2; 6]), Response::Error(WireError::Busy));
    let attach = Request::Attach { channel: None };
    assert_eq!(
        h.request(&attach),
        Response::Error(WireError::Busy),
        "no abrupt stop"
    );
}

#[test]
fn raw_pulses_are_clamped_and_detach_goes_limp() {
    let mut h = Harness::boot(SimFlash::new());
    assert_eq!(
        h.request(&Request::RawPulse {
            channel: 3,
            pulse_us: 60_000
        }),
        Response::Pulse { applied_us: 2500 }
    );
    // On the servo at once, as a detach is, not only at the next frame.
    assert_eq!(h.dev.bus().now[3], Some(2500));
    assert_eq!(h.status().pulses_us, [0, 0, 0, 2500, 0, 0]);
    assert_eq!(
        h.request(&Request::RawPulse {
            channel: 2,
            pulse_us: 10
        }),
        Response::Pulse { applied_us: 500 }
    );
    assert_eq!(
        h.request(&Request::RawPulse {
            channel: 6,
            pulse_us: 1500
        }),
        Response::Error(WireError::OutOfRange)
    );
    h.frames(1);
    assert_eq!(
        h.dev.bus().now,
        [None, None, Some(500), Some(2500), None, None]
    );
    assert_eq!(
        h.request(&Request::Detach { channel: Some(3) }),
        Response::Done
    );
    h.frames(1);
    assert_eq!(h.dev.bus().now[3], None);
    assert_eq!(
        h.request(&Request::Detach { channel: None }),
        Response::Done
    );
    h.frames(1);
    assert_eq!(h.dev.bus().now, [None; 6]);
}

#[test]
fn read_back_returns_the_stored_bytes_and_erase_forgets_them() {
    let mut h = Harness::boot(SimFlash::new());
    assert_eq!(
        h.request(&Request::CalibrationRead { offset: 0 }),
        Response::Error(WireError::NoCalibration)
    );
    let cal = test_calibration(9);
    h.push(&cal);
    let got = h.read_back().unwrap();
    assert_eq!(Calibration::decode(&got), Some(cal));
    h.request(&Request::SetCompensation {
        mode: CompensationMode::Full,
    });
    assert_eq!(h.request(&Request::CalibrationErase), Response::Done);
    let s = h.status();
    assert_eq!((s.calibration, s.mode), (None, CompensationMode::Off));
}

#[test]
fn bootloader_request_is_handed_to_the_binary_once() {
    let mut h = Harness::boot(SimFlash::new());
    assert_eq!(h.dev.take_action(), None);
    assert_eq!(h.request(&Request::RebootToBootloader), Response::Done);
    assert_eq!(
        h.dev.take_action(),
        Some(crate::SystemAction::RebootToBootloader)
    );
    assert_eq!(h.dev.take_action(), None);
}

#[test]
fn old_or_new_hosts_get_a_version_error_under_the_boards_version() {
    let mut h = Harness::boot(SimFlash::new());
    // The previous protocol (an lrmcal not yet updated) and a future one.
    for theirs in [frame::PROTOCOL_VERSION - 1, 9] {
        let mut buf = [0u8; MAX_FRAME];
        let n = frame::encode_with_version(theirs, 44, &Request::Status, &mut buf).unwrap();
        let mut out = [0u8; MAX_FRAME];
        let m = h.dev.handle_frame(&buf[..n], &mut out);
        assert_eq!(
            frame::decode::<Response>(&out[..m]),
            Ok((44, Response::Error(WireError::VersionMismatch))),
            "protocol {theirs}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// No byte stream panics the handler, and a corrupt frame never gets a reply.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..700)) {
        let mut h = Harness::boot(SimFlash::new());
        let mut reader = protocol::FrameReader::<MAX_FRAME>::new();
        let mut out = [0u8; MAX_FRAME];
        for b in bytes {
            if let protocol::frame::Feed::Frame(f) = reader.feed(b) {
                let f = f.to_vec();
                h.dev.handle_frame(&f, &mut out);
            }
        }
        h.frames(2);
        prop_assert!(h.dev.bus().now.iter().all(|p| p.is_none()));
    }

    /// Whatever well-formed requests arrive (NaN, huge, out of range), every
    /// pulse stays in the safe range, no calibration is half applied, and on
    /// an arm of five joints or one the channels past its last joint never
    /// get a pulse.
    #[test]
    fn arbitrary_requests_keep_pulses_and_joints_in_limits(
        ops in proptest::collection::vec((0u8..8, any::<[f32; 6]>(), any::<u16>(), any::<u32>()), 1..40),
        calibrated in any::<bool>(),
        joints in prop_oneof![Just(6usize), Just(5), Just(1)],
    ) {
        let mut h = Harness::boot(SimFlash::new());
        let cal = test_calibration_of(2, joints);
        let joints = if calibrated { joints } else { 6 };
        if calibrated {
            h.push(&cal);
            h.request(&Request::SetCompensation { mode: CompensationMode::Full });
        }
        let mut used_raw = false;
        for (op, q, p, ms) in ops {
            used_raw |= op == 2;
            // One target per joint, now and then one too many.
            let n = if ms % 16 == 0 { (joints + 1).min(6) } else { joints };
            let targets = PerChannel::from_slice(&q[..n]).unwrap();
            let req = match op {
                0 => Request::Move { targets_rad: targets, timing: Timing::DurationMs(ms % 3000) },
                1 => Request::Move { targets_rad: targets.map(|x| x.clamp(-1.7, 1.7)), timing: Timing::SpeedRadPerS(q[0]) },
                2 => Request::RawPulse { channel: (p % 8) as u8, pulse_us: p },
                3 => Request::SetPayload { mass_kg: q[1] },
                4 => Request::Attach { channel: Some((p % 7) as u8) },
                5 => Request::Detach { channel: Some((p % 7) as u8) },
                6 => Request::CalibrationChunk { offset: ms % 2000, data: heapless::Vec::from_slice(&p.to_le_bytes()).unwrap() },
                _ => Request::CalibrationCommit,
            };
            h.request(&req);
            h.frames((ms % 40) as usize);
        }
        let id = h.status().calibration.map(|c| c.id);
        prop_assert_eq!(id, calibrated.then_some(2));
        let limits = if calibrated { cal.calibrated.joints.map(|j| j.limits) } else { [[-1.7453293, 1.7453293]; 6].into() };
        let curves = if calibrated { cal.calibrated.joints.map(|j| j.servo) } else { [Some(model::ServoCurve::nominal()); 6].into() };
        for &(ch, pulse) in &h.dev.bus().log {
            if let Some(us) = pulse {
                prop_assert!(ch < joints, "pulse {us} on channel {ch} of an arm of {joints} joints");
                prop_assert!((500..=2500).contains(&us), "pulse {us}");
                // Driven (not raw) pulses also respect the joint limits through the curve.
                let lo = curves[ch].unwrap().pulse_us(limits[ch][0]).min(curves[ch].unwrap().pulse_us(limits[ch][1]));
                let hi = curves[ch].unwrap().pulse_us(limits[ch][0]).max(curves[ch].unwrap().pulse_us(limits[ch][1]));
                prop_assert!(used_raw || (f32::from(us) >= lo - 1.0 && f32::from(us) <= hi + 1.0), "pulse {us} on {ch}");
            }
        }
    }
}
