//! Behaviour of the whole [`Device`] through its two entry points, against
//! the recording servo bus and the simulated flash.

use proptest::prelude::*;
use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::{self, MAX_FRAME};
use protocol::{
    CHUNK_LEN, Calibration, CompensationMode, Faults, Request, Response, Status, Timing, WireError,
};
use rand::{Rng, SeedableRng, rngs::StdRng};

use crate::sim::{MockBus, SimFlash, test_calibration};
use crate::{Config, Device};

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

    fn move_to(&mut self, q: [f32; 6]) -> Response {
        self.request(&Request::Move {
            targets_rad: q,
            timing: Timing::DurationMs(0),
        })
    }
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
        targets_rad: [0.1; 6],
        timing: Timing::SpeedRadPerS(-1.0),
    };
    assert_eq!(h.request(&slow), Response::Error(WireError::OutOfRange));
    let forever = Request::Move {
        targets_rad: [0.1; 6],
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
    bad.calibrated.joints[2].servo.pulses_us_mut()[1] = f32::NAN;
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
        let expected = joint.servo.pulse_us(home).round() as u16;
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
    let mut tracker = ApproachTracker::new(cal.home_rad);
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
            let expected = joint.servo.pulse_us(command).round() as u16;
            assert_eq!(h.dev.bus().now[i], Some(expected), "joint {i} to {q:?}");
            // Half the play is a few µs: the offset shows in the pulse.
            let plain = joint.servo.pulse_us(q[i]).round() as u16;
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
    let top = cal.calibrated.joints[0].servo.pulse_us(hi).round() as u16;
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
        .map(|j| steepest(&j.servo))
        .fold(0.0, f32::max);
    slope * Config::default().max_correction_rate_rad_s * 0.02 + 1.0
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
                let expected = joint.servo.pulse_us(q[i]).round() as u16;
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
    let pulses = turned.calibrated.joints[3].servo.pulses_us_mut();
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
        j.servo.pulses_us_mut()[1] += 30.0;
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
            let curves = running.map_or([model::ServoCurve::nominal(); 6], |c| {
                c.calibrated.joints.map(|j| j.servo)
            });
            let home = running.map_or([0.0; 6], |c| c.home_rad);
            h.request(&Request::Home {
                timing: Timing::DurationMs(0),
            });
            h.frames(1);
            let pulses: [Option<u16>; 6] =
                core::array::from_fn(|i| Some(curves[i].pulse_us(home[i]).round() as u16));
            assert_eq!(h.dev.bus().now, pulses, "cut {cut}");
        }
    }
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
        for p in j.servo.pulses_us_mut() {
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
        let expected = joint.servo.pulse_us(home).round() as u16;
        assert_eq!(h.dev.bus().now[i], Some(expected), "joint {i}");
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
    let cal = test_calibration(5);
    let nominal64 = cal.nominal.map(f64::from).chain();
    let calibrated64 = cal.calibrated.map(f64::from).chain();
    let opts64 = model::CompensationOptions {
        tolerance_m: 1e-7,
        damping_m: 1e-6,
        max_iterations: 60,
    };
    let mut rng = StdRng::seed_from_u64(11);
    for payload in [0.0f32, 0.0663] {
        let mut comp =
            crate::compensator::Compensator::new(&cal, Config::default().compensation, 0.35);
        let (mut worst, mut done, mut unreachable, mut frames) = (0.0f64, 0, 0, 0);
        while done < 1000 {
            let q: [f32; 6] = core::array::from_fn(|_| rng.random_range(-1.6f32..1.6));
            let q64 = q.map(f64::from);
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
            let mut cmd = [0.0f32; 6];
            for _ in 0..FRAMES_FROM_REST {
                frames += 1;
                cmd = comp.step(&q, CompensationMode::Full, payload);
                if comp.report().converged {
                    break;
                }
            }
            assert!(comp.report().converged, "q {q:?}: {:?}", comp.report());
            let reached = calibrated64
                .tool_point(&cmd.map(f64::from), payload as f64, &Default::default())
                .unwrap();
            worst = worst.max((reached - target).norm());
        }
        assert!(
            worst < 5e-5,
            "payload {payload}: worst {:.4} mm",
            worst * 1e3
        );
        println!(
            "payload {payload} kg: worst {:.4} mm over 1000 targets ({unreachable} unreachable skipped, {frames} frames)",
            worst * 1e3
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
    /// pulse stays in the safe range and no calibration is half applied.
    #[test]
    fn arbitrary_requests_keep_pulses_and_joints_in_limits(
        ops in proptest::collection::vec((0u8..8, any::<[f32; 6]>(), any::<u16>(), any::<u32>()), 1..40),
        calibrated in any::<bool>(),
    ) {
        let mut h = Harness::boot(SimFlash::new());
        let cal = test_calibration(2);
        if calibrated {
            h.push(&cal);
            h.request(&Request::SetCompensation { mode: CompensationMode::Full });
        }
        let mut used_raw = false;
        for (op, q, p, ms) in ops {
            used_raw |= op == 2;
            let req = match op {
                0 => Request::Move { targets_rad: q, timing: Timing::DurationMs(ms % 3000) },
                1 => Request::Move { targets_rad: q.map(|x| x.clamp(-1.7, 1.7)), timing: Timing::SpeedRadPerS(q[0]) },
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
        let limits = if calibrated { cal.calibrated.joints.map(|j| j.limits) } else { [[-1.7453293, 1.7453293]; 6] };
        let curves = if calibrated { cal.calibrated.joints.map(|j| j.servo) } else { [model::ServoCurve::nominal(); 6] };
        for &(ch, pulse) in &h.dev.bus().log {
            if let Some(us) = pulse {
                prop_assert!((500..=2500).contains(&us), "pulse {us}");
                // Driven (not raw) pulses also respect the joint limits through the curve.
                let lo = curves[ch].pulse_us(limits[ch][0]).min(curves[ch].pulse_us(limits[ch][1]));
                let hi = curves[ch].pulse_us(limits[ch][0]).max(curves[ch].pulse_us(limits[ch][1]));
                prop_assert!(used_raw || (f32::from(us) >= lo - 1.0 && f32::from(us) <= hi + 1.0), "pulse {us} on {ch}");
            }
        }
    }
}
