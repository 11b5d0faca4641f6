//! The per-servo-frame compensation step: nominal joint targets in, joint
//! commands for the calibrated, deflected arm out.
//!
//! The solve of `model::Chain::compensate` is spread over the servo frames,
//! one Newton step per frame, so a frame costs one evaluation, one
//! linearisation and one step whatever happens:
//!
//! 1. *Evaluate* the state the previous frame's step led to, moved along with
//!    the nominal targets and the correction's own rate of change. This
//!    gives a command and its exact remaining error, and that command is
//!    what the frame sends: the reported error is measured, not predicted.
//! 2. *Step* from it towards this frame's target; the result is the next
//!    frame's state to evaluate. Newton converges quadratically and the
//!    targets move by at most 30 mrad per frame, so a move is followed to
//!    about 10 µm and a new target from rest is reached in about three frames
//!    (a dozen for corrections near the bound).
//!
//! A state worse than the last accepted one would have been (near singular
//! or unreachable targets), not finite, or correcting a joint by more than
//! the configured bound is not commanded: the frame falls back to the
//! nominal targets plus the last good correction, counts the fallback, and
//! the next frame retries from the accepted state with a more strongly
//! damped, purely corrective step (as `compensate` does within one solve);
//! six failures in a row while the targets move start the solve afresh.
//! Once the tool point is on target, the steps go on while they still pull
//! the arm's shape towards the nominal targets (null-space moves that leave
//! the tool point put) and the solve ends when a step would move no joint by
//! more than the options' `settle_rad`: a move into a pose and a solve started
//! afresh at it (after a commit) then end on the same command, not on two of
//! the many that reach the point. A frame whose inputs (targets, mode,
//! payload) equal the last settled frame's reuses its answer: the model is
//! deterministic, so a holding arm costs no solve at all. Holding still at a target the solve does not reach
//! (three steps in a row gain less than 10 %, or six fail), the solve starts
//! afresh from the nominal targets once: a solve that followed a move can
//! end where the pull towards the nominal shape and the position fight each
//! other (steps that trade a little position for shape, rejected again and
//! again), which one started at the nominal targets does not meet; the
//! correction on the servos changes at its bounded rate meanwhile. If that
//! one stalls too, the solve ends on its best command, reported as not
//! converged.

use model::{Chain, CompensationOptions, Evaluation, PerJoint, Slope};
use nalgebra::{IsometryMatrix3, Point3, Vector3};
use protocol::{Calibration, CompensationMode, CompensationReport};

/// How many failed steps in a row raise the damping (by 4× each).
const MAX_REJECTIONS: u32 = 6;
/// Holding still, a step that keeps more than this share of the error is slow;
/// [`STALLED_STEPS`] slow steps in a row end the solve (an unreachable or
/// singular target), and the arm stays put.
const SLOW_RATIO: f32 = 0.9;
/// See [`SLOW_RATIO`].
const STALLED_STEPS: u32 = 3;
/// On target, the solve goes on stepping until the shape settles (a step
/// moves no joint by more than the options' `settle_rad`), for at most this
/// many frames in a row.
const MAX_SHAPING_STEPS: u32 = 25;

/// What a frame's answer depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Inputs {
    q_nominal: PerJoint<f32>,
    mode: CompensationMode,
    payload_kg: f32,
}

/// The last accepted state: its evaluation, its slope and what it was solved for.
#[derive(Clone, Copy, Debug)]
struct Accepted {
    evaluation: Evaluation<f32>,
    slope: Slope<f32>,
    target: Vector3<f32>,
    /// The nominal targets it was solved for.
    q_nominal: PerJoint<f32>,
    /// Deflected angles minus nominal targets of the step taken from it, rad.
    correction: PerJoint<f32>,
}

/// The state the next frame evaluates, before it is moved along with the targets.
#[derive(Clone, Copy, Debug)]
struct Next {
    qa: PerJoint<f32>,
    beta: f32,
    /// The nominal targets it was stepped for.
    q_nominal: PerJoint<f32>,
    /// How much the correction changed over the last frame, rad.
    correction_rate: PerJoint<f32>,
}

/// The compensation state carried from one servo frame to the next, for an
/// arm of any number of joints: every joint vector in and out has one value
/// per joint of the calibration's arm.
#[derive(Clone, Copy, Debug)]
pub struct Compensator {
    nominal: Chain<f32>,
    calibrated: Chain<f32>,
    /// The nominal arm's base in the calibrated arm's base frame, if the
    /// nominal arm is rigid (its target then needs no deflection solve).
    rigid_nominal_base: Option<IsometryMatrix3<f32>>,
    options: CompensationOptions<f32>,
    /// How far a joint may be corrected: the calibration's, cut to the board's cap, rad.
    max_correction_rad: PerJoint<f32>,
    accepted: Option<Accepted>,
    next: Option<Next>,
    rejections: u32,
    /// Slow steps in a row while holding still.
    slow_steps: u32,
    /// Steps in a row taken on target, settling the shape.
    shaping_steps: u32,
    /// Whether the solve has started afresh since the targets last changed.
    fresh_while_holding: bool,
    /// Steps since the current move started or the solve last started afresh.
    steps: u32,
    /// Inputs of the last frame that solved.
    last_inputs: Option<Inputs>,
    /// Inputs of the last frame that ended the solve (converged or stalled) and the command it gave.
    settled: Option<(Inputs, PerJoint<f32>)>,
    /// Command minus nominal of the last accepted frame, rad.
    last_correction: PerJoint<f32>,
    fell_back: bool,
    report: CompensationReport,
}

impl Compensator {
    /// Prepares both arms of `calibration` for evaluation; no joint is
    /// corrected by more than the calibration's largest correction or `cap_rad`.
    pub fn new(calibration: &Calibration, options: CompensationOptions<f32>, cap_rad: f32) -> Self {
        let (nominal, calibrated) = (calibration.nominal.chain(), calibration.calibrated.chain());
        let joints = calibration.calibrated.joint_count();
        Self {
            nominal,
            calibrated,
            rigid_nominal_base: nominal
                .is_rigid()
                .then(|| calibrated.base.inverse() * nominal.base),
            options,
            max_correction_rad: PerJoint::from_fn(joints, |i| {
                calibration.max_correction_rad[i].min(cap_rad)
            }),
            accepted: None,
            next: None,
            rejections: 0,
            slow_steps: 0,
            shaping_steps: 0,
            fresh_while_holding: false,
            steps: 0,
            last_inputs: None,
            settled: None,
            last_correction: PerJoint::splat(joints, 0.0),
            fell_back: false,
            report: CompensationReport::default(),
        }
    }

    /// Starts this solve where `previous` (the last calibration's) stands, if
    /// its arm has as many joints: a calibration committed while the arm
    /// holds a pose then goes on from the shape the arm holds rather than from
    /// the nominal targets, so the same calibration committed again changes
    /// no pulse and a new one moves the servos only as far as it differs.
    pub fn continue_from(&mut self, previous: &Compensator) {
        if previous.joints() == self.joints() {
            self.next = previous.next.map(|next| Next {
                correction_rate: PerJoint::splat(self.joints(), 0.0),
                ..next
            });
        }
    }

    /// The calibrated arm's joints: the length of every joint vector in and out.
    pub fn joints(&self) -> usize {
        self.max_correction_rad.len()
    }

    /// How the last step went.
    pub fn report(&self) -> CompensationReport {
        self.report
    }

    /// Whether the last frame commanded the fallback instead of a solution.
    pub fn fell_back(&self) -> bool {
        self.fell_back
    }

    /// Whether the solve for the last frame's inputs has ended (converged,
    /// or stalled for good): until then its commands may still change.
    pub fn settled(&self) -> bool {
        self.settled.is_some()
    }

    /// A new move starts: `status` counts the solve's steps from here.
    pub fn start_move(&mut self) {
        self.steps = 0;
    }

    /// Forgets the solve and the last correction (after a mode change or a detach).
    pub fn reset(&mut self) {
        self.restart();
        self.fresh_while_holding = false;
        self.last_inputs = None;
        self.settled = None;
        self.last_correction = PerJoint::splat(self.joints(), 0.0);
        self.fell_back = false;
    }

    /// The tool point the user means by `q_nominal` in `mode`, in the calibrated
    /// arm's base frame, or `None` when off.
    fn target(
        &self,
        q_nominal: &[f32],
        mode: CompensationMode,
        payload_kg: f32,
    ) -> Option<Vector3<f32>> {
        match mode {
            CompensationMode::Off => None,
            CompensationMode::ElasticOnly => Some(self.calibrated.rigid_base_point(q_nominal)),
            // The nominal arm as the user plans with it: rigid if its compliances are zero.
            CompensationMode::Full => match &self.rigid_nominal_base {
                Some(base) => {
                    Some((base * Point3::from(self.nominal.rigid_base_point(q_nominal))).coords)
                }
                None => self
                    .nominal
                    .tool_point(q_nominal, payload_kg, &Default::default())
                    .ok()
                    .map(|world| self.calibrated.to_base(&world)),
            },
        }
    }

    /// The state to evaluate this frame: the last step's result moved along
    /// with the targets and the correction's rate, or the nominal targets.
    fn guess(&self, q_nominal: &[f32]) -> (PerJoint<f32>, f32) {
        let n = q_nominal.len();
        match (&self.next, &self.accepted) {
            (Some(next), Some(accepted)) => {
                // The correction goes on changing only while the targets move.
                let rate = if *q_nominal == *next.q_nominal {
                    PerJoint::splat(n, 0.0)
                } else {
                    next.correction_rate
                };
                let shift = PerJoint::from_fn(n, |i| q_nominal[i] - next.q_nominal[i] + rate[i]);
                let qa = PerJoint::from_fn(n, |i| next.qa[i] + shift[i]);
                (qa, next.beta + accepted.slope.tilt_change(&shift))
            }
            // Carried over from the last calibration, for the targets it held.
            (Some(next), None) if *next.q_nominal == *q_nominal => (next.qa, next.beta),
            _ => (joint_vector(q_nominal), 0.0),
        }
    }

    /// One servo frame: the joint commands for `q_nominal`, one target per
    /// joint of the calibration's arm (not yet clamped to limits). Targets
    /// of another length (which the board never passes) get no compensation.
    pub fn step(
        &mut self,
        q_nominal: &[f32],
        mode: CompensationMode,
        payload_kg: f32,
    ) -> PerJoint<f32> {
        if mode == CompensationMode::Off || q_nominal.len() != self.joints() {
            self.reset();
            return joint_vector(q_nominal);
        }
        let inputs = Inputs {
            q_nominal: joint_vector(q_nominal),
            mode,
            payload_kg,
        };
        if let Some((settled, q)) = self.settled
            && settled == inputs
        {
            return q;
        }
        self.settled = None;
        let holding = self.last_inputs == Some(inputs);
        if !holding {
            self.fresh_while_holding = false;
        }
        self.last_inputs = Some(inputs);
        let Some(target) = self.target(q_nominal, mode, payload_kg) else {
            return self.fall_back(q_nominal);
        };
        let (qa, beta) = self.guess(q_nominal);
        let tolerance = self.options.tolerance_m;
        // Looked at in place from here on: an evaluation is 300 bytes, each
        // move of it a copy on the board.
        let evaluated = self
            .calibrated
            .evaluate(&qa, beta, &target, payload_kg, tolerance);
        let within = |e: &Evaluation<f32>| {
            e.state
                .q
                .iter()
                .zip(q_nominal)
                .zip(&self.max_correction_rad)
                .all(|((q, n), max)| (q - n).abs() <= *max)
        };
        // The accepted state's own error at this frame's target: a step must not do worse.
        let anchor_error = self
            .accepted
            .as_ref()
            .map(|a| a.evaluation.error_m_at(&(target - a.target)));
        let better = |e: f32| anchor_error.is_none_or(|a| e <= a + tolerance);
        match &evaluated {
            Ok(evaluation) if within(evaluation) && better(evaluation.state.error_m) => {
                let state = &evaluation.state;
                let slope = self.calibrated.slope(evaluation);
                self.rejections = 0;
                self.steps = self.steps.saturating_add(1);
                self.report = CompensationReport {
                    converged: state.converged,
                    iterations: self.steps.min(u32::from(u8::MAX)) as u8,
                    error_um: state.error_m * 1e6,
                    fallbacks: self.report.fallbacks,
                };
                self.last_correction =
                    PerJoint::from_fn(q_nominal.len(), |i| state.q[i] - q_nominal[i]);
                self.fell_back = false;
                // On target, the steps only settle the shape: counted apart,
                // since the error then hovers at the tolerance.
                let slow = holding
                    && !state.converged
                    && anchor_error.is_some_and(|a| state.error_m > a * SLOW_RATIO);
                self.slow_steps = if slow { self.slow_steps + 1 } else { 0 };
                self.shaping_steps = if state.converged {
                    self.shaping_steps + 1
                } else {
                    0
                };
                let stalled = self.slow_steps >= STALLED_STEPS;
                if stalled && !self.fresh_while_holding {
                    self.start_afresh_while_holding();
                    return state.q;
                }
                // A rate only between two frames of a move: holding, the
                // correction changes by the solve's own steps.
                let previous = self
                    .accepted
                    .as_ref()
                    .filter(|a| *a.q_nominal != *q_nominal)
                    .map(|a| a.correction);
                let settles = self.take_step(evaluation, &slope, target, q_nominal, previous);
                let shaped = settles || self.shaping_steps >= MAX_SHAPING_STEPS;
                if (state.converged && shaped) || stalled {
                    self.settled = Some((inputs, state.q));
                }
                state.q
            }
            _ => {
                self.rejections = (self.rejections + 1).min(MAX_REJECTIONS);
                // Retry from the accepted state, seen from this frame's target.
                match &self.accepted {
                    Some(a) => {
                        let (anchor, slope) =
                            (a.evaluation.retarget(&(target - a.target)), a.slope);
                        self.take_step(&anchor, &slope, target, q_nominal, None);
                    }
                    None => self.next = None,
                }
                let command = self.fall_back(q_nominal);
                if self.rejections == MAX_REJECTIONS {
                    if holding && self.fresh_while_holding {
                        self.settled = Some((inputs, command));
                    } else if holding {
                        self.start_afresh_while_holding();
                    } else {
                        // Lost while the targets move: start afresh from them.
                        self.restart();
                    }
                }
                command
            }
        }
    }

    /// Holding still, the solve starts afresh from the nominal targets, once
    /// per target (module docs).
    fn start_afresh_while_holding(&mut self) {
        self.restart();
        self.fresh_while_holding = true;
    }

    /// Forgets the solve: the next frame starts from the nominal targets.
    fn restart(&mut self) {
        self.accepted = None;
        self.next = None;
        self.rejections = 0;
        self.slow_steps = 0;
        self.shaping_steps = 0;
        self.steps = 0;
    }

    /// Steps from `evaluation` (solved for `target`) with `slope` and keeps the
    /// result for the next frame; whether the step settles the shape (moves
    /// no joint by more than the options' `settle_rad`).
    fn take_step(
        &mut self,
        evaluation: &Evaluation<f32>,
        slope: &Slope<f32>,
        target: Vector3<f32>,
        q_nominal: &[f32],
        previous_correction: Option<PerJoint<f32>>,
    ) -> bool {
        let next = evaluation
            .with_slope(slope, q_nominal)
            .next_state(self.rejections, self.options.damping_m);
        let Some((qa, beta)) = next else {
            self.accepted = None;
            self.next = None;
            return false;
        };
        let settles = self.options.settles(&evaluation.state.qa, &qa);
        let n = q_nominal.len();
        let correction = PerJoint::from_fn(n, |i| qa[i] - q_nominal[i]);
        let correction_rate = match previous_correction {
            Some(p) => PerJoint::from_fn(n, |i| correction[i] - p[i]),
            None => PerJoint::splat(n, 0.0),
        };
        let q_nominal = joint_vector(q_nominal);
        // Overwritten field by field while there is one (every frame of a
        // solve): built and moved in whole, its 500 bytes would be copied
        // twice more on the board.
        match &mut self.accepted {
            Some(a) => {
                a.evaluation = *evaluation;
                a.slope = *slope;
                a.target = target;
                a.q_nominal = q_nominal;
                a.correction = correction;
            }
            None => {
                self.accepted = Some(Accepted {
                    evaluation: *evaluation,
                    slope: *slope,
                    target,
                    q_nominal,
                    correction,
                });
            }
        }
        self.next = Some(Next {
            qa,
            beta,
            q_nominal,
            correction_rate,
        });
        settles
    }

    /// Commands the nominal targets plus the last good correction and says so.
    fn fall_back(&mut self, q_nominal: &[f32]) -> PerJoint<f32> {
        self.fell_back = true;
        self.report.converged = false;
        self.report.fallbacks = self.report.fallbacks.saturating_add(1);
        PerJoint::from_fn(q_nominal.len(), |i| q_nominal[i] + self.last_correction[i])
    }
}

/// `q` as a joint vector (at most `model::MAX_JOINTS` values: the board's
/// arms have at most six).
fn joint_vector(q: &[f32]) -> PerJoint<f32> {
    PerJoint::from_fn(q.len(), |i| q[i])
}
