//! Accuracy at the tool, through the board: random tool-point targets, the
//! host's nominal inverse kinematics, the firmware's own servo frames, and
//! the simulated true arm executing the pulses.
//!
//! ```text
//! nominal Arm + seed --targets--> tool points + nominal joint targets (ik, as `move --xyz`)
//! targets + calibration (or none) --firmware Device, 20 ms frames--> pulses
//! pulses --TrueServos (true curve, servo error, play)--> true joint angles
//!        --TrueArm::tool_point (true geometry, stiffness, payload)--> where the tool went
//! ```
//!
//! The board is the firmware library itself ([`firmware::Device`]) on an
//! in-memory servo bus and flash: the calibration goes in through the same
//! `calib/*` requests `lrmcal push` sends, the targets through `motion/move`,
//! and every servo frame's pulses come out, so motion, compensation and the
//! play's offset run exactly as on the RP2040 (in f32).
//!
//! The true arm turns pulses into angles as [`TrueArm::simulate`] turns
//! commanded angles into them: the true servo curve (the arm file's) gives
//! the angle the pulse commands, the servo's own error moves it, and the
//! play leaves the joint on the side it came from. Here the play follows the
//! pulses frame by frame (the joint is dragged at the edge of its play), which
//! is `simulate`'s rule whenever a joint's command runs one way by more than
//! the play, as it does between two measured poses.

use firmware::{CHANNELS, Config, Device, FlashStorage, ServoBus};
use model::{Arm, JOINTS};
use nalgebra::Vector3;
use protocol::frame::{self, MAX_FRAME};
use protocol::{Calibration, CompensationMode, Request, Response, Timing, WireError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::TrueArm;
use crate::calib::{CalibError, ModelOption, option, plots};
use crate::ik::{self, IkError, IkOptions};
use crate::io::calibration_file::{CalibrationFile, ErrorStats};
use crate::plan::PlanConfig;

/// How many targets the demo visits.
pub const DEFAULT_TARGETS: usize = 100;

/// Servo frames a move may take before the board counts as stuck: 60 s.
const MAX_FRAMES: u32 = 3_000;
/// The servo frame, µs (the firmware's 50 Hz).
const FRAME_US: u64 = 20_000;
/// Samples drawn per target wanted before giving up: most random poses are clear.
const SAMPLES_PER_TARGET: usize = 50;

/// Why the positioning error could not be measured.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PositioningError {
    /// Too few clear, reachable targets were found.
    #[error("found {found} of {wanted} clear, reachable targets in {tries} random poses")]
    Targets {
        /// Targets found.
        found: usize,
        /// Targets wanted.
        wanted: usize,
        /// Random poses tried.
        tries: usize,
    },
    /// The nominal inverse kinematics found no joint targets for a target.
    #[error("target {index} at ({:.1}, {:.1}, {:.1}) mm: {source}", .target_mm[0], .target_mm[1], .target_mm[2])]
    Ik {
        /// 0-based position in the visiting order.
        index: usize,
        /// The target, world frame, mm.
        target_mm: [f64; 3],
        /// What the solver said.
        #[source]
        source: IkError,
    },
    /// A calibration the board could not run.
    #[error("the {label} calibration: {fault}")]
    Calibration {
        /// Which calibration.
        label: String,
        /// What is wrong with it.
        fault: protocol::CalibrationFault,
    },
    /// The board refused a request.
    #[error("the board refused `{request}`: {error}")]
    Board {
        /// The request's path.
        request: &'static str,
        /// The board's answer.
        error: WireError,
    },
    /// The board answered something the request does not expect.
    #[error("the board answered `{request}` with {answer}")]
    Unexpected {
        /// The request's path.
        request: &'static str,
        /// The answer, debug-printed.
        answer: String,
    },
    /// The arm was still moving after [`MAX_FRAMES`] servo frames.
    #[error("target {index}: the board still moves after {MAX_FRAMES} servo frames")]
    NotSettled {
        /// 0-based position in the visiting order.
        index: usize,
    },
    /// The true arm's deflection could not be solved.
    #[error("target {index}: the true arm's deflection: {reason}")]
    Model {
        /// 0-based position in the visiting order.
        index: usize,
        /// The model's error.
        reason: model::DeflectionError,
    },
}

/// One target: a tool point and the nominal joint targets that reach it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// Where the tool is asked to go, world frame, m.
    pub point_m: Vector3<f64>,
    /// The nominal arm's joint targets for it, nearest the previous target's, rad.
    pub q: [f64; JOINTS],
}

/// `count` random tool points the nominal arm reaches clear of collisions
/// within the joint ranges the board accepts without a calibration, each
/// with its nominal joint targets solved as `lrmcal move --xyz` solves them:
/// nearest the pose of the target before (home, all zero, for the first).
pub fn targets(
    nominal: &Arm<f64>,
    count: usize,
    seed: u64,
    collisions: &PlanConfig,
) -> Result<Vec<Target>, PositioningError> {
    let config = Config::default();
    let board =
        firmware::servo::joint_limits(None, config.hard_limits_rad, config.default_limits_rad);
    let mut arm = *nominal;
    for (joint, [lo, hi]) in arm.joints.iter_mut().zip(board) {
        joint.limits = [
            joint.limits[0].max(f64::from(lo)),
            joint.limits[1].min(f64::from(hi)),
        ];
    }
    let chain = arm.chain();
    let options = IkOptions {
        collisions: Some(collisions.clone()),
        ..IkOptions::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut found = Vec::with_capacity(count);
    let mut from = [0.0; JOINTS];
    let tries = count * SAMPLES_PER_TARGET;
    for _ in 0..tries {
        if found.len() == count {
            break;
        }
        let q: [f64; JOINTS] = std::array::from_fn(|i| {
            let [lo, hi] = arm.joints[i].limits;
            rng.random_range(lo..=hi)
        });
        if collisions.contact(&chain.frames(&q, 0.0)).is_some() {
            continue;
        }
        let point_m = chain.rigid_tool_point(&q);
        let solution = ik::solve_position(&arm, &point_m, &from, &options).map_err(|source| {
            PositioningError::Ik {
                index: found.len(),
                target_mm: (point_m * 1e3).into(),
                source,
            }
        })?;
        from = solution.q;
        found.push(Target {
            point_m,
            q: solution.q,
        });
    }
    if found.len() < count {
        return Err(PositioningError::Targets {
            found: found.len(),
            wanted: count,
            tries,
        });
    }
    Ok(found)
}

/// The pulses on the board's outputs, as the last servo frame left them.
#[derive(Clone, Copy, Debug, Default)]
struct Outputs([Option<u16>; CHANNELS]);

impl ServoBus for Outputs {
    fn set_pulse(&mut self, channel: usize, pulse_us: Option<u16>) {
        if let Some(slot) = self.0.get_mut(channel) {
            *slot = pulse_us;
        }
    }
}

/// Two flash sectors in memory, enough for the board to store a calibration.
#[derive(Clone, Debug)]
struct MemoryFlash([Vec<u8>; 2]);

/// A read or write past the end of a sector.
#[derive(Clone, Copy, Debug)]
struct OutOfSector;

/// One RP2040 flash sector.
const SECTOR: usize = 4096;

impl FlashStorage for MemoryFlash {
    type Error = OutOfSector;

    fn slot_size(&self) -> usize {
        SECTOR
    }

    fn read(&mut self, slot: u8, offset: usize, buf: &mut [u8]) -> Result<(), OutOfSector> {
        let bytes = self.0.get(usize::from(slot)).ok_or(OutOfSector)?;
        let src = bytes.get(offset..offset + buf.len()).ok_or(OutOfSector)?;
        buf.copy_from_slice(src);
        Ok(())
    }

    fn erase(&mut self, slot: u8) -> Result<(), OutOfSector> {
        self.0
            .get_mut(usize::from(slot))
            .ok_or(OutOfSector)?
            .fill(0xFF);
        Ok(())
    }

    fn write(&mut self, slot: u8, offset: usize, data: &[u8]) -> Result<(), OutOfSector> {
        let bytes = self.0.get_mut(usize::from(slot)).ok_or(OutOfSector)?;
        let dst = bytes
            .get_mut(offset..offset + data.len())
            .ok_or(OutOfSector)?;
        // NOR flash: programming only clears bits.
        for (d, s) in dst.iter_mut().zip(data) {
            *d &= s;
        }
        Ok(())
    }
}

/// The firmware library on in-memory outputs and flash, with its clock.
struct Board {
    device: Device<Outputs, MemoryFlash>,
    now_us: u64,
    seq: u16,
}

impl Board {
    /// A fresh board holding `calibration` (sent as `lrmcal push` sends it),
    /// compensating fully for `payload_kg`; without one, a board that never
    /// had a calibration, compensation off.
    fn new(calibration: Option<&Calibration>, payload_kg: f64) -> Result<Self, PositioningError> {
        let flash = MemoryFlash([vec![0xFF; SECTOR], vec![0xFF; SECTOR]]);
        let mut board = Self {
            device: Device::new(Outputs::default(), flash, Config::default(), 0),
            now_us: 0,
            seq: 0,
        };
        if let Some(calibration) = calibration {
            board.push(calibration)?;
            board.request(&Request::SetCompensation {
                mode: CompensationMode::Full,
            })?;
        }
        board.request(&Request::SetPayload {
            mass_kg: payload_kg as f32,
        })?;
        Ok(board)
    }

    /// One request through the board's dispatcher, as its USB link delivers it.
    fn request(&mut self, request: &Request) -> Result<Response, PositioningError> {
        let path = request.path();
        let unexpected = |answer: String| PositioningError::Unexpected {
            request: path,
            answer,
        };
        self.seq = self.seq.wrapping_add(1);
        let mut frame = [0u8; MAX_FRAME];
        let n = frame::encode(self.seq, request, &mut frame)
            .map_err(|e| unexpected(format!("no frame: {e:?}")))?;
        let mut reply = [0u8; MAX_FRAME];
        let m = self.device.handle_frame(&frame[..n], &mut reply);
        match frame::decode::<Response>(&reply[..m]) {
            Ok((_, Response::Error(error))) => Err(PositioningError::Board {
                request: path,
                error,
            }),
            Ok((_, response)) => Ok(response),
            Err(e) => Err(unexpected(format!("an unreadable frame ({e:?})"))),
        }
    }

    /// Uploads and commits `calibration`: the board checks it whole before storing it.
    fn push(&mut self, calibration: &Calibration) -> Result<(), PositioningError> {
        let mut buf = [0u8; protocol::calibration::MAX_CALIBRATION_LEN];
        let bytes = calibration
            .encode(&mut buf)
            .map_err(|e| PositioningError::Unexpected {
                request: "calib/begin",
                answer: format!("a calibration that does not encode: {e:?}"),
            })?;
        self.request(&Request::CalibrationBegin {
            len_bytes: bytes.len() as u32,
            crc: frame::crc32(bytes),
        })?;
        for (k, chunk) in bytes.chunks(protocol::CHUNK_LEN).enumerate() {
            // `chunks` never yields more than CHUNK_LEN bytes: the copy always fits.
            let data = heapless::Vec::from_slice(chunk).unwrap_or_default();
            self.request(&Request::CalibrationChunk {
                offset: (k * protocol::CHUNK_LEN) as u32,
                data,
            })?;
        }
        self.request(&Request::CalibrationCommit).map(drop)
    }

    /// Whether the servos still move (a motion, or a correction fading in).
    fn moving(&mut self) -> Result<bool, PositioningError> {
        match self.request(&Request::Status)? {
            Response::Status(status) => Ok(status.moving),
            other => Err(PositioningError::Unexpected {
                request: "status/get",
                answer: format!("{other:?}"),
            }),
        }
    }

    /// Runs one servo frame and returns the pulses it put out.
    fn frame(&mut self) -> [Option<u16>; CHANNELS] {
        self.now_us += FRAME_US;
        self.device.servo_frame(self.now_us);
        self.device.bus().0
    }
}

/// The true arm's servos and joints following the pulses they are sent.
struct TrueServos<'a> {
    truth: &'a TrueArm,
    /// Each joint's angle, rad; `None` until its servo got a pulse.
    joints: [Option<f64>; JOINTS],
}

impl<'a> TrueServos<'a> {
    fn new(truth: &'a TrueArm) -> Self {
        Self {
            truth,
            joints: [None; JOINTS],
        }
    }

    /// One frame of pulses: each servo drives to the angle its true curve
    /// gives the pulse, off by its own error; the joint follows it within
    /// the play (at rest at start-up as if it had arrived rising, as
    /// [`super::approach_directions`] takes it).
    fn drive(&mut self, pulses: &[Option<u16>; CHANNELS]) {
        for (i, pulse) in pulses.iter().enumerate() {
            let Some(pulse) = pulse else { continue };
            let commanded = self.truth.arm.joints[i].servo.angle(f64::from(*pulse));
            let motor = commanded + self.truth.servo_errors[i].at(commanded);
            let half = self.truth.backlash_half_rad[i];
            self.joints[i] = Some(match self.joints[i] {
                None => motor - half,
                Some(joint) => joint.clamp(motor - half, motor + half),
            });
        }
    }
}

/// The distance, m, between each target and where the true arm's tool went
/// when a board holding `calibration` (or none) drove it there with
/// `payload_kg` at the tool, the targets visited in order from home.
pub fn errors(
    truth: &TrueArm,
    targets: &[Target],
    calibration: Option<&Calibration>,
    payload_kg: f64,
) -> Result<Vec<f64>, PositioningError> {
    let mut board = Board::new(calibration, payload_kg)?;
    let mut servos = TrueServos::new(truth);
    let mut errors = Vec::with_capacity(targets.len());
    for (index, target) in targets.iter().enumerate() {
        board.request(&Request::Move {
            targets_rad: target.q.map(|q| q as f32),
            timing: Timing::DurationMs(0),
        })?;
        let mut frames = 0;
        loop {
            servos.drive(&board.frame());
            frames += 1;
            if !board.moving()? {
                break;
            }
            if frames >= MAX_FRAMES {
                return Err(PositioningError::NotSettled { index });
            }
        }
        // A move drives every joint: each has its angle now.
        let driven = servos.joints.map(|q| q.unwrap_or_default());
        let point = truth
            .tool_point(&driven, payload_kg)
            .map_err(|reason| PositioningError::Model { index, reason })?;
        errors.push((point - target.point_m).norm());
    }
    Ok(errors)
}

/// One board's positioning errors.
#[derive(Clone, Debug, PartialEq)]
pub struct Positioning {
    /// What the board held ("uncalibrated", a model's name).
    pub label: String,
    /// Error at each target, in visiting order, m.
    pub errors_m: Vec<f64>,
    /// Their statistics.
    pub stats: ErrorStats,
}

/// [`errors`] for each labelled board (`None`: no calibration) over the same targets.
pub fn compare(
    truth: &TrueArm,
    targets: &[Target],
    boards: &[(String, Option<Calibration>)],
    payload_kg: f64,
) -> Result<Vec<Positioning>, PositioningError> {
    boards
        .iter()
        .map(|(label, calibration)| {
            let errors_m = errors(truth, targets, calibration.as_ref(), payload_kg)?;
            Ok(Positioning {
                label: label.clone(),
                stats: ErrorStats::of(&errors_m),
                errors_m,
            })
        })
        .collect()
}

/// The boards the demo compares: none (uncalibrated), the paper's model
/// (elasto-kinematic) and ours ([`option::DEFAULT`], the option `identify`
/// fits by default), from the calibration files of `calibrations` (one per
/// option, as the demo writes them; one row when ours is the paper's).
pub fn demo_boards(
    calibrations: &[(ModelOption, &CalibrationFile)],
) -> Result<Vec<(String, Option<Calibration>)>, PositioningError> {
    let mut boards = vec![("uncalibrated".to_owned(), None)];
    let paper = ModelOption::ElastoKinematic;
    let mut wanted = vec![(paper, format!("paper's model ({paper})"))];
    if option::DEFAULT == paper {
        wanted[0].1 = format!("paper's model = ours ({paper})");
    } else {
        wanted.push((option::DEFAULT, format!("ours ({})", option::DEFAULT)));
    }
    for (option, label) in wanted {
        let Some((_, file)) = calibrations.iter().find(|(o, _)| *o == option) else {
            continue;
        };
        let calibration =
            crate::device::calibration::payload(file, [0.0; JOINTS]).map_err(|fault| {
                PositioningError::Calibration {
                    label: label.clone(),
                    fault,
                }
            })?;
        boards.push((label, Some(calibration)));
    }
    Ok(boards)
}

/// The comparison's box plot, `<dir>/positioning.svg` and `.png`; returns the files.
pub fn plot(
    dir: &std::path::Path,
    rows: &[Positioning],
    payload_kg: f64,
) -> Result<Vec<std::path::PathBuf>, CalibError> {
    let boxes: Vec<plots::Distribution> = rows
        .iter()
        .map(|r| plots::Distribution {
            label: r.label.clone(),
            values_mm: r.errors_m.iter().map(|e| e * 1e3).collect(),
        })
        .collect();
    let count = rows.first().map_or(0, |r| r.errors_m.len());
    plots::error_distribution(
        &dir.join("positioning"),
        &format!("Error at the tool through the board, {count} random targets, {payload_kg} kg"),
        &boxes,
    )
}

/// The comparison as a table, mm.
pub fn table(rows: &[Positioning]) -> String {
    let width = rows.iter().map(|r| r.label.len()).max().unwrap_or(0).max(5);
    let mut text = format!(
        "{:width$}  {:>8}  {:>8}  {:>8}  {:>8}\n",
        "board", "mean", "median", "95th", "max"
    );
    for r in rows {
        let s = &r.stats;
        text += &format!(
            "{:width$}  {:>8.2}  {:>8.2}  {:>8.2}  {:>8.2}\n",
            r.label,
            s.mean_m * 1e3,
            s.median_m * 1e3,
            s.p95_m * 1e3,
            s.max_m * 1e3
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::SimConfig;
    use crate::sim::test_support::bundled_arm;

    #[test]
    fn targets_are_reached_by_their_joint_targets_clear_and_in_the_boards_range() {
        let nominal = bundled_arm();
        let collisions = PlanConfig::default();
        let t = targets(&nominal, 6, 3, &collisions).unwrap();
        assert_eq!(t.len(), 6);
        let chain = nominal.chain();
        for target in &t {
            assert!((chain.rigid_tool_point(&target.q) - target.point_m).norm() < 1e-8);
            assert!(collisions.contact(&chain.frames(&target.q, 0.0)).is_none());
            assert!(target.q.iter().all(|q| q.abs() <= 100f64.to_radians()));
        }
        assert_eq!(t, targets(&nominal, 6, 3, &collisions).unwrap());
    }

    #[test]
    fn a_perfect_arm_goes_where_the_board_sends_it_and_play_moves_it() {
        let nominal = bundled_arm();
        let t = targets(&nominal, 4, 5, &PlanConfig::default()).unwrap();
        // The nominal arm itself, rigid, without play: only the 1 µs pulse step is left.
        let mut exact = TrueArm::draw(&nominal, 2, &SimConfig::model_only()).unwrap();
        exact.arm = nominal;
        for j in &mut exact.arm.joints {
            j.compliance = 0.0;
        }
        exact.arm.base_compliance = 0.0;
        let e = errors(&exact, &t, None, 0.0).unwrap();
        assert!(e.iter().all(|&e| e < 2e-3), "{e:?}");
        // Play of a few degrees, uncompensated, throws the tool by millimetres.
        exact.backlash_half_rad = [1.5f64.to_radians(); JOINTS];
        let played = errors(&exact, &t, None, 0.0).unwrap();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!(mean(&played) > mean(&e) + 2e-3, "{played:?} vs {e:?}");
    }

    #[test]
    fn the_table_has_one_row_per_board_in_mm() {
        let row = Positioning {
            label: "ours".into(),
            errors_m: vec![1e-3, 3e-3],
            stats: ErrorStats::of(&[1e-3, 3e-3]),
        };
        let text = table(&[row]);
        assert!(text.contains("mean") && text.contains("95th"), "{text}");
        assert!(text.lines().nth(1).unwrap().starts_with("ours"), "{text}");
        assert!(text.contains("2.00") && text.contains("3.00"), "{text}");
    }
}
