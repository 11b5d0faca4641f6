//! Accuracy at the tool, through the board: random tool-point targets, the
//! host's nominal inverse kinematics, the firmware's own servo frames, and
//! the simulated true arm executing the pulses.
//!
//! ```text
//! nominal Arm + seed + boards --targets--> tool points + each board's nominal joint targets (ik, as `move --xyz`)
//! targets + calibration (or none) --firmware Device, 20 ms frames--> pulses
//! pulses --TrueServos (true curve, servo error, play)--> true joint angles
//!        --TrueArm::tool_point (true geometry, stiffness, payload)--> where the tool went
//! ```
//!
//! Each board gets the nominal joint targets `move --xyz` would send it: of
//! the nominal solutions for the tool point, the nearest one its
//! calibration's compensation can command within the joint ranges and its
//! largest corrections ([`crate::device::commanded`]). A random tool point
//! that some board cannot reach so is left out (and counted): every board
//! is judged on the same targets.
//!
//! The board is the firmware library itself in memory
//! ([`crate::device::memory::MemoryBoard`]), talked to through the client
//! `lrmcal` talks to a real board with: the calibration goes in as
//! `lrmcal push` sends it, the targets through `motion/move`, and every
//! servo frame's pulses come out, so motion, compensation and the play's
//! offset run exactly as on the RP2040 (in f32).
//!
//! The true arm turns pulses into angles as [`TrueArm::simulate`] turns
//! commanded angles into them: the true servo curve (the arm file's) gives
//! the angle the pulse commands, the servo's own error moves it, and the
//! play leaves the joint on the side it came from. Here the play follows the
//! pulses frame by frame (the joint is dragged at the edge of its play), which
//! is `simulate`'s rule whenever a joint's command runs one way by more than
//! the play, as it does between two measured poses.

mod targets;

pub use targets::{Target, Targets, targets};

use std::time::Duration;

use firmware::CHANNELS;
use model::{Arm, PerJoint};
use protocol::{Calibration, CompensationMode, Faults, PerChannel, Timing};

use super::TrueArm;
use crate::calib::{ModelOption, parameters::option};
use crate::device::memory::MemoryBoard;
use crate::device::{Client, ClientError};
use crate::ik::IkError;
use lrmcal_core::io::calibration_file::{CalibrationFile, ErrorStats};

/// How many targets the demo visits.
pub const DEFAULT_TARGETS: usize = 100;

/// Servo frames a move may take before the board counts as stuck: 60 s.
const MAX_FRAMES: u32 = 3_000;

/// Why the positioning error could not be measured.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PositioningError {
    /// The board drives at most [`CHANNELS`] joints.
    #[error("an arm of {joints} joints: the board drives arms of up to {CHANNELS} joints")]
    TooManyJoints {
        /// The arm's joints.
        joints: usize,
    },
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
        /// What the solver said (boxed: it carries a pose of up to ten
        /// joints, and the error is returned by value).
        #[source]
        source: Box<IkError>,
    },
    /// A calibration the board could not run.
    #[error("the {label} calibration: {fault}")]
    Calibration {
        /// Which calibration.
        label: String,
        /// What is wrong with it.
        fault: protocol::CalibrationFault,
    },
    /// The board refused a request, or the exchange failed.
    #[error("the board in memory: {0}")]
    Board(#[source] Box<ClientError>),
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

impl From<ClientError> for PositioningError {
    fn from(e: ClientError) -> Self {
        Self::Board(Box::new(e))
    }
}

/// A board in memory ([`MemoryBoard`]), talked to as `lrmcal` talks to one:
/// holding `calibration` (sent as `lrmcal push` sends it), compensating fully
/// for `payload_kg`. Without one, the uncalibrated board: it holds the
/// nominal arm of the true arm (`nominal`: its joints, servo curves and
/// limits, nothing corrected) with compensation off, so it drives exactly
/// the arm's joints, each through its data-sheet curve. For an arm of six
/// joints with the data-sheet curve of a board that never had a
/// calibration (the bundled arm) that board sends the very same pulses.
fn board(
    calibration: Option<&Calibration>,
    nominal: &Arm<f64>,
    payload_kg: f64,
) -> Result<Client<MemoryBoard>, PositioningError> {
    let mut client = Client::new(MemoryBoard::default(), Duration::from_millis(1), 0);
    match calibration {
        Some(calibration) => {
            client.push_calibration(calibration, |_, _| {})?;
            client.set_compensation(CompensationMode::Full)?;
        }
        None => {
            let uncalibrated =
                crate::device::calibration::uncorrected(nominal).map_err(|fault| {
                    PositioningError::Calibration {
                        label: "uncalibrated (nominal)".into(),
                        fault,
                    }
                })?;
            client.push_calibration(&uncalibrated, |_, _| {})?;
            client.set_compensation(CompensationMode::Off)?;
        }
    }
    client.set_payload(payload_kg as f32)?;
    Ok(client)
}

/// The true arm's servos and joints following the pulses they are sent.
struct TrueServos<'a> {
    truth: &'a TrueArm,
    /// Each joint's angle, rad; `None` until its servo got a pulse.
    joints: PerJoint<Option<f64>>,
}

impl<'a> TrueServos<'a> {
    fn new(truth: &'a TrueArm) -> Self {
        Self {
            truth,
            joints: PerJoint::splat(truth.arm.joints.len(), None),
        }
    }

    /// One frame of pulses: each servo drives to the angle its true curve
    /// gives the pulse, off by its own error; the joint follows it within
    /// the play (at rest at start-up as if it had arrived rising, as
    /// [`super::approach_directions`] takes it).
    fn drive(&mut self, pulses: &[Option<u16>; CHANNELS]) {
        // The channels past the arm's last joint move nothing.
        for (i, pulse) in pulses.iter().enumerate().take(self.joints.len()) {
            // Only an arm whose every joint has a curve is driven (`drivable`).
            let (Some(pulse), Some(curve)) = (pulse, self.truth.arm.joints[i].servo) else {
                continue;
            };
            let commanded = curve.angle(f64::from(*pulse));
            let motor = commanded + self.truth.servo_errors[i].at(commanded);
            let half = self.truth.backlash_half_rad[i];
            self.joints[i] = Some(match self.joints[i] {
                None => motor - half,
                Some(joint) => joint.clamp(motor - half, motor + half),
            });
        }
    }
}

/// One board's run over the targets.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// The distance between each target and where the true arm's tool went, m.
    pub errors_m: Vec<f64>,
    /// Targets on the way to which the board clamped a command to a joint
    /// or pulse limit.
    pub clamped: usize,
    /// Targets whose move ended with the compensation fallen back to the
    /// last good correction or not converged (a calibrated board only).
    pub fell_back: usize,
    /// Servo frames over the whole run whose compensation step was not taken
    /// (worse than the last accepted state, or beyond the largest
    /// correction) and fell back for that frame: the solve's own damping
    /// on the way, which the board retries the next frame.
    pub fallback_frames: u32,
}

/// How a board holding `calibration` (or none) drove the true arm to the
/// targets with `payload_kg` at the tool, each target's joint targets the
/// board's own (`board`, its index in the targets' lists), visited in order from home.
pub fn errors(
    truth: &TrueArm,
    targets: &[Target],
    board_index: usize,
    calibration: Option<&Calibration>,
    payload_kg: f64,
) -> Result<Run, PositioningError> {
    let mut board = board(calibration, &truth.nominal, payload_kg)?;
    let mut servos = TrueServos::new(truth);
    let mut errors = Vec::with_capacity(targets.len());
    let mut clamped = 0;
    let mut fell_back = 0;
    let mut fallback_frames = 0;
    for (index, target) in targets.iter().enumerate() {
        let joints = truth.arm.joints.len();
        let q = target
            .q
            .get(board_index)
            .copied()
            .unwrap_or_else(|| PerJoint::splat(joints, 0.0));
        // The board drives at most CHANNELS joints; `targets` refuses longer arms.
        let sent = PerChannel::from_fn(q.len().min(CHANNELS), |j| q[j] as f32);
        board.move_to(sent, Timing::DurationMs(0))?;
        let mut frames = 0;
        let mut clamped_here = false;
        let status = loop {
            servos.drive(&board.link_mut().frame());
            frames += 1;
            let status = board.status()?;
            clamped_here |= status.faults.contains(Faults::LIMIT_CLAMPED);
            if !status.moving {
                break status;
            }
            if frames >= MAX_FRAMES {
                return Err(PositioningError::NotSettled { index });
            }
        };
        clamped += usize::from(clamped_here);
        if calibration.is_some() {
            fallback_frames = status.compensation.fallbacks;
            let ended_back = status.faults.contains(Faults::COMPENSATION_FALLBACK)
                || !status.compensation.converged;
            fell_back += usize::from(ended_back);
        }
        // A move drives every joint: each has its angle now.
        let driven = servos.joints.map(|q| q.unwrap_or_default());
        let point = truth
            .tool_point(&driven, payload_kg)
            .map_err(|reason| PositioningError::Model { index, reason })?;
        errors.push((point - target.point_m).norm());
    }
    Ok(Run {
        errors_m: errors,
        clamped,
        fell_back,
        fallback_frames,
    })
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
    /// Targets on the way to which a command was clamped to a limit.
    pub clamped: usize,
    /// Targets whose move ended with the compensation fallen back or not converged.
    pub fell_back: usize,
    /// Servo frames whose compensation step fell back on the way ([`Run`]).
    pub fallback_frames: u32,
}

/// [`errors`] for each labelled board (`None`: no calibration) over the same
/// targets (solved for these boards, in this order, by [`targets`]).
pub fn compare(
    truth: &TrueArm,
    targets: &[Target],
    boards: &[(String, Option<Calibration>)],
    payload_kg: f64,
) -> Result<Vec<Positioning>, PositioningError> {
    boards
        .iter()
        .enumerate()
        .map(|(b, (label, calibration))| {
            let run = errors(truth, targets, b, calibration.as_ref(), payload_kg)?;
            Ok(Positioning {
                label: label.clone(),
                stats: ErrorStats::of(&run.errors_m),
                errors_m: run.errors_m,
                clamped: run.clamped,
                fell_back: run.fell_back,
                fallback_frames: run.fallback_frames,
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
    let paper = ModelOption::PaperElastoKinematic;
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
        let calibration = crate::device::calibration::payload(
            file,
            PerChannel::splat(file.arm.joints.len(), 0.0),
        )
        .map_err(|fault| PositioningError::Calibration {
            label: label.clone(),
            fault,
        })?;
        boards.push((label, Some(calibration)));
    }
    Ok(boards)
}

/// The comparison as a table, mm, with each board's targets reached with a
/// clamped command or a fallen-back compensation.
pub fn table(rows: &[Positioning]) -> String {
    let width = rows.iter().map(|r| r.label.len()).max().unwrap_or(0).max(5);
    let mut text = format!(
        "{:width$}  {:>8}  {:>8}  {:>8}  {:>8}  {:>7}  {:>9}\n",
        "board", "mean", "median", "95th", "max", "clamped", "fell back"
    );
    for r in rows {
        let s = &r.stats;
        text += &format!(
            "{:width$}  {:>8.2}  {:>8.2}  {:>8.2}  {:>8.2}  {:>7}  {:>9}\n",
            r.label,
            s.mean_m * 1e3,
            s.median_m * 1e3,
            s.p95_m * 1e3,
            s.max_m * 1e3,
            r.clamped,
            r.fell_back
        );
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::commanded::Commanded;
    use crate::plan::PlanConfig;
    use crate::sim::SimConfig;
    use crate::sim::test_support::bundled_arm;

    /// The uncalibrated board, alone.
    fn uncalibrated() -> Vec<(String, Option<Calibration>)> {
        vec![("uncalibrated".to_owned(), None)]
    }

    #[test]
    fn targets_are_reached_by_their_joint_targets_clear_and_in_the_boards_range() {
        let nominal = bundled_arm();
        let collisions = PlanConfig::default();
        let t = targets(&nominal, 6, 3, &collisions, &uncalibrated(), 0.0).unwrap();
        assert_eq!((t.targets.len(), t.left_out), (6, 0));
        let chain = nominal.chain();
        for target in &t.targets {
            let q = target.q[0];
            assert!((chain.rigid_tool_point(&q) - target.point_m).norm() < 1e-8);
            assert!(collisions.contact(&chain.frames(&q, 0.0)).is_none());
            assert!(q.iter().all(|q| q.abs() <= 100f64.to_radians()));
        }
        assert_eq!(
            t,
            targets(&nominal, 6, 3, &collisions, &uncalibrated(), 0.0).unwrap()
        );
    }

    /// The board's calibration of `calibrated` from `nominal`, the paper's model.
    fn board_calibration(nominal: &Arm<f64>, calibrated: &Arm<f64>) -> Calibration {
        crate::device::calibration::identified(Calibration {
            id: 0,
            option: ModelOption::ElastoKinematic,
            nominal: nominal.map(|x| x as f32),
            calibrated: calibrated.map(|x| x as f32),
            home_rad: [0.0; 6].into(),
            max_correction_rad: crate::device::calibration::max_corrections(nominal, calibrated),
        })
        .unwrap()
    }

    /// A calibrated board gets joint targets its compensation commands
    /// within the ranges; the uncalibrated one, the nearest as before.
    #[test]
    fn each_board_gets_targets_its_compensation_can_command() {
        let nominal = bundled_arm();
        let mut calibrated = nominal;
        calibrated.joints[1].compliance = 0.15;
        calibrated.joints[2].theta += 0.05;
        let calibration = board_calibration(&nominal, &calibrated);
        let mut boards = uncalibrated();
        boards.push(("sagging".to_owned(), Some(calibration)));
        let t = targets(&nominal, 8, 4, &PlanConfig::default(), &boards, 0.0663).unwrap();
        let board = Commanded::new(&calibration, CompensationMode::Full, 0.0663);
        // The board's nominal arm is the one it was sent, in f32.
        let (chain, sent) = (nominal.chain(), calibration.nominal.map(f64::from).chain());
        for target in &t.targets {
            assert_eq!(target.q.len(), 2);
            assert!((chain.rigid_tool_point(&target.q[0]) - target.point_m).norm() < 1e-8);
            assert!((sent.rigid_tool_point(&target.q[1]) - target.point_m).norm() < 1e-8);
            assert!(board.command(&target.q[1]).is_ok());
        }
    }

    /// A calibrated board whose arm stands elsewhere (its nominal arm on
    /// the calibrated base, 4 cm lower and turned) gets joint targets of
    /// that nominal arm; the points it cannot reach are left out for all
    /// boards, not an error.
    #[test]
    fn a_board_standing_elsewhere_solves_on_its_own_nominal_arm() {
        let nominal = bundled_arm();
        let mut standing = nominal;
        standing.base.xyz = [0.01, 0.0, -0.04];
        standing.base.rpy = [0.0, 0.0, 0.3];
        let calibration = board_calibration(&standing, &standing);
        let mut boards = uncalibrated();
        boards.push(("lower".to_owned(), Some(calibration)));
        let t = targets(&nominal, 20, 6, &PlanConfig::default(), &boards, 0.0).unwrap();
        assert!(t.left_out > 0, "no point beyond the lower arm's reach");
        let (chain, lower) = (nominal.chain(), calibration.nominal.map(f64::from).chain());
        for target in &t.targets {
            assert!((chain.rigid_tool_point(&target.q[0]) - target.point_m).norm() < 1e-8);
            assert!((lower.rigid_tool_point(&target.q[1]) - target.point_m).norm() < 1e-8);
        }
    }

    #[test]
    fn a_perfect_arm_goes_where_the_board_sends_it_and_play_moves_it() {
        let nominal = bundled_arm();
        let t = targets(&nominal, 4, 5, &PlanConfig::default(), &uncalibrated(), 0.0)
            .unwrap()
            .targets;
        // The nominal arm itself, rigid, without play: only the 1 µs pulse step is left.
        let mut exact = TrueArm::draw(&nominal, 2, &SimConfig::model_only()).unwrap();
        exact.arm = nominal;
        for j in &mut exact.arm.joints {
            j.compliance = 0.0;
        }
        exact.arm.base_compliance = 0.0;
        let e = errors(&exact, &t, 0, None, 0.0).unwrap();
        assert!(e.errors_m.iter().all(|&e| e < 2e-3), "{e:?}");
        assert_eq!((e.clamped, e.fell_back, e.fallback_frames), (0, 0, 0));
        // Play of a few degrees, uncompensated, throws the tool by millimetres.
        exact.backlash_half_rad = vec![1.5f64.to_radians(); 6];
        let played = errors(&exact, &t, 0, None, 0.0).unwrap();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!(
            mean(&played.errors_m) > mean(&e.errors_m) + 2e-3,
            "{played:?} vs {e:?}"
        );
    }

    fn so101() -> Arm<f64> {
        lrmcal_core::io::arm_source::bundled("so101")
            .expect("the bundled SO-101 parses")
            .arm
    }

    /// Runs `board` to rest on each target's first joint targets and
    /// returns the pulses of every servo frame on the way.
    fn pulses_to(
        board: &mut Client<MemoryBoard>,
        targets: &[Target],
    ) -> Vec<[Option<u16>; CHANNELS]> {
        let mut frames = Vec::new();
        for target in targets {
            let q = &target.q[0];
            let sent = PerChannel::from_fn(q.len(), |j| q[j] as f32);
            board.move_to(sent, Timing::DurationMs(0)).unwrap();
            loop {
                frames.push(board.link_mut().frame());
                if !board.status().unwrap().moving {
                    break;
                }
            }
        }
        frames
    }

    /// The uncalibrated board of a five-joint arm holds the arm's nominal
    /// arm: channels 1 to 5 are driven, each through the arm's own servo
    /// curve, and channel 6 stays limp in every frame; an exact arm goes
    /// where it is sent.
    #[test]
    fn the_uncalibrated_board_of_a_five_joint_arm_drives_five_channels_through_its_curves() {
        let nominal = so101();
        let t = targets(&nominal, 5, 3, &PlanConfig::default(), &uncalibrated(), 0.0)
            .unwrap()
            .targets;
        let mut b = board(None, &nominal, 0.0663).unwrap();
        let frames = pulses_to(&mut b, &t);
        assert!(frames.len() > t.len());
        for pulses in &frames {
            assert!(pulses[..5].iter().all(Option::is_some), "{pulses:?}");
            assert_eq!(pulses[5], None);
        }
        // At rest on the last target, each pulse is the arm's curve's (to the 1 µs step).
        let last = frames.last().unwrap();
        for (j, pulse) in last.iter().take(5).enumerate() {
            let expected = nominal.joints[j]
                .servo
                .unwrap()
                .pulse_us(t[t.len() - 1].q[0][j]);
            let sent = f64::from(pulse.unwrap());
            assert!(
                (sent - expected).abs() <= 1.0,
                "joint {}: {sent} µs for {expected}",
                j + 1
            );
        }
        let mut exact = TrueArm::draw(&nominal, 2, &SimConfig::model_only()).unwrap();
        exact.arm = nominal;
        let e = errors(&exact, &t, 0, None, 0.0).unwrap();
        assert!(e.errors_m.iter().all(|&e| e < 2e-3), "{e:?}");
        assert_eq!((e.clamped, e.fell_back), (0, 0));
    }

    /// On the bundled arm (six joints, the data-sheet curve) the
    /// uncalibrated board, holding the nominal arm with compensation off,
    /// sends the very pulses of a board that never had a calibration: the
    /// demo's uncalibrated row is what it was.
    #[test]
    fn on_the_bundled_arm_the_uncalibrated_board_is_a_board_without_calibration() {
        let nominal = bundled_arm();
        let t = targets(
            &nominal,
            6,
            3,
            &PlanConfig::default(),
            &uncalibrated(),
            0.0663,
        )
        .unwrap()
        .targets;
        let mut held = board(None, &nominal, 0.0663).unwrap();
        let mut bare = Client::new(MemoryBoard::default(), Duration::from_millis(1), 0);
        bare.set_payload(0.0663).unwrap();
        assert_eq!(pulses_to(&mut held, &t), pulses_to(&mut bare, &t));
    }

    #[test]
    fn the_table_has_one_row_per_board_in_mm() {
        let row = Positioning {
            label: "ours".into(),
            errors_m: vec![1e-3, 3e-3],
            stats: ErrorStats::of(&[1e-3, 3e-3]),
            clamped: 1,
            fell_back: 0,
            fallback_frames: 3,
        };
        let text = table(&[row]);
        assert!(text.contains("mean") && text.contains("95th"), "{text}");
        assert!(text.lines().nth(1).unwrap().starts_with("ours"), "{text}");
        assert!(text.contains("2.00") && text.contains("3.00"), "{text}");
    }
}
