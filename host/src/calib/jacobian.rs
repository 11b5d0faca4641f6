//! The identification Jacobian: how each measured tool point moves per unit
//! change of each error parameter, through the elastic model (deflection
//! included), by central differences.
//!
//! Why numerical: the deflection is the fixed point of a pose-dependent map, so
//! an analytic derivative needs the implicit-function theorem through the
//! gravity torques of every link; central differences on the model the rest of
//! the project uses cannot disagree with it.
//!
//! Step per parameter: `h = eps^(1/3) * max(|value|, typical)` balances the
//! O(h²) truncation error against the O(eps/h) rounding error of a central
//! difference, with `typical` = 0.1 m for lengths, 1 rad for angles and
//! 0.1 rad/Nm for compliances. The deflection solver converges to ~1e-14 rad,
//! far below what these steps resolve. A compliance closer to zero than its
//! step is differenced one-sidedly upwards (second order), so no evaluated arm
//! ever has a negative compliance: the selection sees the physical model only.
//!
//! A sample's joints stand where its command drives them ([`Rig::standing_angles`]:
//! through the rig's servo curves, with its backlash). The columns of servo
//! knots and backlash widths move only those angles, so they are built from
//! one joint-angle column per joint (`calib::joint_columns`).

use model::SolverOptions;
use model::params::ParamKind;
use nalgebra::{DMatrix, Vector3};

use super::joint_columns;
use super::params::ParamKey;
use super::servo_knots::fit_start;
use super::{CalibError, Rig, Sample};

/// How the finite-difference steps are chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JacobianOptions {
    /// Multiplies every step; 1 is the balanced step described in the module docs.
    pub step_factor: f64,
}

impl Default for JacobianOptions {
    fn default() -> Self {
        Self { step_factor: 1.0 }
    }
}

/// The central-difference step for `id` at its current `value`.
pub fn step(id: ParamKey, value: f64, options: &JacobianOptions) -> f64 {
    let typical = match id.kind() {
        ParamKind::Length => 0.1,
        ParamKind::Angle => 1.0,
        ParamKind::Compliance => 0.1,
    };
    f64::EPSILON.cbrt() * value.abs().max(typical) * options.step_factor
}

/// Measured (deflected) points of `rig` for every sample, each of its
/// sample's target, with the joints where the sample's command drives them
/// ([`Rig::standing_angles`]), world frame, m.
pub fn tool_points(rig: &Rig, samples: &[Sample]) -> Result<Vec<Vector3<f64>>, CalibError> {
    let angles: Vec<[f64; model::JOINTS]> =
        samples.iter().map(|s| rig.standing_angles(s)).collect();
    points_at(rig, samples, &angles)
}

/// [`tool_points`] with the joints at `angles` (one per sample), rad.
pub fn points_at(
    rig: &Rig,
    samples: &[Sample],
    angles: &[[f64; model::JOINTS]],
) -> Result<Vec<Vector3<f64>>, CalibError> {
    // One chain per target: they differ in the tool point only, which the
    // deflection does not depend on.
    let chains: Vec<model::Chain<f64>> = (0..rig.targets.len())
        .map(|t| {
            let mut chain = rig.chain();
            chain.tool_point = rig.tool_point(t).unwrap_or(chain.tool_point);
            chain
        })
        .collect();
    let opts = SolverOptions::default();
    samples
        .iter()
        .zip(angles)
        .map(|(s, q)| {
            let chain = chains.get(s.target).ok_or_else(|| CalibError::Deflection {
                pose: s.id,
                load_kg: s.load_kg,
                message: format!(
                    "the calibration has {} targets, not a target {}",
                    chains.len(),
                    s.target
                ),
            })?;
            chain
                .tool_point(q, s.load_kg, &opts)
                .map_err(|e| CalibError::Deflection {
                    pose: s.id,
                    load_kg: s.load_kg,
                    message: e.to_string(),
                })
        })
        .collect()
}

/// Writes `points` (3 rows each) into column `col` of `j`, scaled by `factor`,
/// accumulating onto what is there.
fn accumulate(j: &mut DMatrix<f64>, col: usize, points: &[Vector3<f64>], factor: f64) {
    for (k, p) in points.iter().enumerate() {
        for r in 0..3 {
            j[(3 * k + r, col)] += factor * p[r];
        }
    }
}

/// The rig with `delta` added to parameter `id`, without clamping (a
/// difference step may pass through negative compliance only when the caller
/// allows it).
fn perturbed(rig: &Rig, id: ParamKey, delta: f64) -> Rig {
    let mut r = rig.clone();
    *id.slot(&mut r) += delta;
    r
}

/// The `3 n × m` Jacobian of the measured points of `samples` (rows `3k..3k+3`
/// for sample `k`, x y z) with respect to the error parameters `ids` (columns),
/// evaluated at `rig`, in m per unit of each parameter.
pub fn jacobian(
    rig: &Rig,
    ids: &[ParamKey],
    samples: &[Sample],
    options: &JacobianOptions,
) -> Result<DMatrix<f64>, CalibError> {
    let mut j = DMatrix::zeros(3 * samples.len(), ids.len());
    // Servo-knot keys move the curves on their grid (the same map).
    let rig = &fit_start(rig, ids);
    let done = joint_columns::fill(rig, ids, samples, &mut j)?;
    let mut base: Option<Vec<Vector3<f64>>> = None;
    for (col, &id) in ids.iter().enumerate() {
        if done[col] {
            continue;
        }
        let value = id.value(rig);
        let h = step(id, value, options);
        if id.kind() == ParamKind::Compliance && value < h {
            // One-sided, second order: (-3 f(x) + 4 f(x+h) - f(x+2h)) / 2h.
            if base.is_none() {
                base = Some(tool_points(rig, samples)?);
            }
            let f0 = base.as_deref().unwrap_or_default();
            accumulate(&mut j, col, f0, -1.5 / h);
            accumulate(
                &mut j,
                col,
                &tool_points(&perturbed(rig, id, h), samples)?,
                2.0 / h,
            );
            accumulate(
                &mut j,
                col,
                &tool_points(&perturbed(rig, id, 2.0 * h), samples)?,
                -0.5 / h,
            );
        } else {
            accumulate(
                &mut j,
                col,
                &tool_points(&perturbed(rig, id, h), samples)?,
                0.5 / h,
            );
            accumulate(
                &mut j,
                col,
                &tool_points(&perturbed(rig, id, -h), samples)?,
                -0.5 / h,
            );
        }
    }
    Ok(j)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{small_samples, test_arm};

    /// Two step sizes a decade apart agree: the step is in the flat part of the
    /// truncation/rounding trade-off for every parameter kind.
    #[test]
    fn agrees_with_a_second_step_size() {
        let arm = test_arm();
        let ids: Vec<ParamKey> = model::ParamId::all().map(ParamKey::Arm).collect();
        let samples = small_samples(6);
        let j1 = jacobian(&Rig::from(arm), &ids, &samples, &JacobianOptions::default()).unwrap();
        let j2 = jacobian(
            &Rig::from(arm),
            &ids,
            &samples,
            &JacobianOptions { step_factor: 10.0 },
        )
        .unwrap();
        for (c, id) in ids.iter().enumerate() {
            let scale = j1.column(c).norm().max(1e-3);
            let diff = (j1.column(c) - j2.column(c)).norm();
            assert!(
                diff < 1e-6 * scale,
                "{id}: |dJ| = {diff:e}, |J| = {scale:e}"
            );
        }
    }

    /// Hand-checkable columns: a base translation moves every point by exactly
    /// its own amount; a tool rotation does not move the tool point at all.
    #[test]
    fn frame_columns_match_their_meaning() {
        let arm = test_arm();
        let ids: Vec<ParamKey> = ["base.x", "base.z", "tool.roll"]
            .iter()
            .map(|n| ParamKey::from_name(n).unwrap())
            .collect();
        let samples = small_samples(5);
        let j = jacobian(&Rig::from(arm), &ids, &samples, &JacobianOptions::default()).unwrap();
        for k in 0..samples.len() {
            let row = |r: usize, c: usize| j[(3 * k + r, c)];
            assert!(
                (row(0, 0) - 1.0).abs() < 1e-9 && row(1, 0).abs() < 1e-9 && row(2, 0).abs() < 1e-9
            );
            assert!((row(2, 1) - 1.0).abs() < 1e-9);
            assert!(j.fixed_view::<3, 1>(3 * k, 2).norm() < 1e-9);
        }
    }

    /// At zero compliance the one-sided difference gives (dx/dqa)·tau, the
    /// derivative of the physical side, and never evaluates a negative compliance.
    #[test]
    fn compliance_column_at_zero_is_joint_column_times_torque() {
        let mut arm = test_arm();
        arm.joints[1].compliance = 0.0;
        let k2 = ParamKey::from_name("k2").unwrap();
        let theta2 = ParamKey::from_name("j2.theta").unwrap();
        let samples = small_samples(4);
        let j = jacobian(
            &Rig::from(arm),
            &[k2, theta2],
            &samples,
            &JacobianOptions::default(),
        )
        .unwrap();
        let chain = arm.chain();
        for (k, s) in samples.iter().enumerate() {
            let d = chain
                .deflect(&s.q, s.load_kg, &SolverOptions::default())
                .unwrap();
            let tau = chain.gravity_torques(&d.qa, d.beta, s.load_kg).joints[1];
            // d x / d k2 = d x / d qa2 * tau2 * (1 + feedback); the feedback of the
            // other compliances is small but real, so compare loosely.
            let expected = j.fixed_view::<3, 1>(3 * k, 1) * tau;
            let got = j.fixed_view::<3, 1>(3 * k, 0);
            assert!(
                (got - expected).norm() < 0.05 * expected.norm() + 1e-9,
                "pose {k}"
            );
        }
    }
}
