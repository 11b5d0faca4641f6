//! The per-servo-frame compensation step: nominal joint targets in, joint
//! commands for the calibrated, deflected arm out.
//!
//! Each frame solves `model::Chain::compensate` (f32) from the previous
//! frame's solution, shifted by how far the nominal targets moved since, which
//! is a few iterations away at most because the targets move by a few
//! milliradians per frame. A frame whose inputs (targets, mode, payload) equal
//! the last converged frame's reuses its answer: the model is deterministic,
//! so a holding arm costs no solve at all. If a solve fails (no convergence,
//! a non-finite value, or a correction larger than the configured bound) the
//! frame commands the nominal targets plus the last good correction, so the
//! arm moves on smoothly instead of jumping, and the failure is counted.

use model::{Chain, Compensation, CompensationOptions};
use nalgebra::Vector3;
use protocol::{Calibration, CompensationMode, CompensationReport};

use crate::CHANNELS;

/// How many times a frame's iteration allowance a cold start gets.
const COLD_START_ITERATIONS: u32 = 3;

/// What a frame's answer depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Inputs {
    q_nominal: [f32; CHANNELS],
    mode: CompensationMode,
    payload_kg: f32,
}

/// The compensation state carried from one servo frame to the next.
#[derive(Clone, Copy, Debug)]
pub struct Compensator {
    nominal: Chain<f32>,
    calibrated: Chain<f32>,
    options: CompensationOptions<f32>,
    max_correction_rad: f32,
    /// The last usable solution and the nominal targets it was solved for.
    warm: Option<(Compensation<f32>, [f32; CHANNELS])>,
    /// Inputs of the last converged frame and the command it gave.
    settled: Option<(Inputs, [f32; CHANNELS])>,
    /// Command minus nominal of the last good solve, rad.
    last_correction: [f32; CHANNELS],
    report: CompensationReport,
}

impl Compensator {
    /// Prepares both arms of `calibration` for evaluation.
    pub fn new(
        calibration: &Calibration,
        options: CompensationOptions<f32>,
        max_correction_rad: f32,
    ) -> Self {
        Self {
            nominal: calibration.nominal.chain(),
            calibrated: calibration.calibrated.chain(),
            options,
            max_correction_rad,
            warm: None,
            settled: None,
            last_correction: [0.0; CHANNELS],
            report: CompensationReport::default(),
        }
    }

    /// How the last step went.
    pub fn report(&self) -> CompensationReport {
        self.report
    }

    /// Forgets the warm start and the last correction (after a mode change or a detach).
    pub fn reset(&mut self) {
        self.warm = None;
        self.settled = None;
        self.last_correction = [0.0; CHANNELS];
    }

    /// The tool point the user means by `q_nominal` in `mode`, or `None` when off.
    fn target(
        &self,
        q_nominal: &[f32; CHANNELS],
        mode: CompensationMode,
        payload_kg: f32,
    ) -> Option<Vector3<f32>> {
        match mode {
            CompensationMode::Off => None,
            CompensationMode::ElasticOnly => Some(self.calibrated.rigid_tool_point(q_nominal)),
            // The nominal arm as the user plans with it (rigid if its compliances are zero).
            CompensationMode::Full => self
                .nominal
                .tool_point(q_nominal, payload_kg, &Default::default())
                .ok(),
        }
    }

    /// One servo frame: the joint commands for `q_nominal` (not yet clamped to limits).
    pub fn step(
        &mut self,
        q_nominal: &[f32; CHANNELS],
        mode: CompensationMode,
        payload_kg: f32,
    ) -> [f32; CHANNELS] {
        if mode == CompensationMode::Off {
            self.reset();
            return *q_nominal;
        }
        let inputs = Inputs {
            q_nominal: *q_nominal,
            mode,
            payload_kg,
        };
        if let Some((settled, q)) = self.settled
            && settled == inputs
        {
            return q;
        }
        // Start from the last solution moved along with the nominal targets.
        let warm = self.warm.map(|(mut w, solved_for)| {
            for i in 0..CHANNELS {
                w.deflection.qa[i] += q_nominal[i] - solved_for[i];
            }
            w
        });
        // A cold start is rare (after a mode change, a new calibration or a
        // failed frame) and further from the answer: it may iterate longer, so
        // that the same cut-short solve is not repeated frame after frame.
        let options = match warm {
            Some(_) => self.options,
            None => CompensationOptions {
                max_iterations: self.options.max_iterations * COLD_START_ITERATIONS,
                ..self.options
            },
        };
        let solved = self.target(q_nominal, mode, payload_kg).and_then(|target| {
            self.calibrated
                .compensate(q_nominal, &target, payload_kg, warm.as_ref(), &options)
                .ok()
        });
        let sane = solved.filter(|c| {
            c.q.iter()
                .zip(q_nominal)
                .all(|(q, n)| q.is_finite() && (q - n).abs() <= self.max_correction_rad)
        });
        // Only a solve near the nominal command is a good start for the next
        // frame: one that strayed past the bound (from a singular pose, say)
        // would lead the next frames astray, so they start afresh instead.
        self.warm = sane.map(|c| (c, *q_nominal));
        self.settled = sane.filter(|c| c.converged).map(|c| (inputs, c.q));
        match sane {
            Some(c) if c.converged => {
                self.last_correction = core::array::from_fn(|i| c.q[i] - q_nominal[i]);
                self.report.converged = true;
                self.report.iterations = c.iterations.min(u8::MAX as u32) as u8;
                self.report.error_um = c.error_m * 1e6;
                c.q
            }
            _ => {
                self.report.converged = false;
                self.report.iterations = sane.map_or(0, |c| c.iterations.min(u8::MAX as u32) as u8);
                self.report.error_um = sane.map_or(f32::INFINITY, |c| c.error_m * 1e6);
                self.report.fallbacks = self.report.fallbacks.saturating_add(1);
                core::array::from_fn(|i| q_nominal[i] + self.last_correction[i])
            }
        }
    }
}
