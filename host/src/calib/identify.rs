//! Identification: the error parameters that make the model's measured points
//! match the measurements, by Levenberg–Marquardt (the `levenberg-marquardt`
//! crate, MINPACK's algorithm on nalgebra).
//!
//! **Non-negative compliances, by an active set.** The fit runs unconstrained
//! over the free parameters (a negative compliance is only a number to the
//! model, so the solver never sees a kink). If it ends with some total
//! compliance below zero, those compliances are fixed at exactly zero and the
//! fit is repeated from there; a fixed compliance is released again when the
//! gradient says that raising it would lower the cost (the KKT multiplier has
//! the wrong sign). This ends with every compliance either free and positive
//! or fixed at zero with a non-negative multiplier: the constrained optimum.
//!
//! **Standard deviations** come from the Jacobian J of the free parameters at
//! the solution and the residual: `cov = s² (JᵀJ)⁻¹` with `s² = RSS / (3n − m)`.
//! Parameters fixed at a bound are reported with no deviation.
//!
//! **Robust option (Huber, by iteratively reweighted least squares).** Each
//! measurement's weight depends on the norm `e` of its 3D residual relative to
//! a robust scale `s = median(e) / 1.5382` (the median of the norm of a 3D
//! Gaussian with per-axis deviation σ is 1.5382 σ): weight 1 up to
//! [`HUBER_K`]`·s`, `HUBER_K·s / e` beyond. Whether robust or not, measurements
//! whose residual exceeds [`OUTLIER_K`]`·s` are named as outliers (a clean 3D
//! Gaussian residual exceeds 4.5 σ with probability 5e-4).

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use model::{Arm, ParamId};
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, Dyn, Vector3};

use super::jacobian::{JacobianOptions, jacobian, tool_points};
use super::{CalibError, ModelOption, Sample};
use crate::dataset::Measurement;

/// Huber threshold on the residual norm, in units of the robust per-axis scale.
pub const HUBER_K: f64 = 3.0;
/// Residual norm (in units of the robust per-axis scale) above which a measurement is named an outlier.
pub const OUTLIER_K: f64 = 4.5;
/// Median of the norm of a 3D standard Gaussian vector.
const CHI3_MEDIAN: f64 = 1.5382;

/// How to fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifyOptions {
    /// Down-weight outliers with Huber's function.
    pub robust: bool,
    /// Most active-set rounds (each one a full LM fit).
    pub max_active_set_rounds: usize,
    /// Most reweighting rounds of the robust fit.
    pub max_irls_rounds: usize,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        Self {
            robust: false,
            max_active_set_rounds: 10,
            max_irls_rounds: 12,
        }
    }
}

/// One identified parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// The parameter.
    pub id: ParamId,
    /// Identified error (correction added to the nominal value), SI units.
    pub error: f64,
    /// Nominal + error, SI units.
    pub value: f64,
    /// One standard deviation of the error, SI units; `None` when fixed at a bound.
    pub std: Option<f64>,
}

/// A measurement whose residual is far beyond the others'.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Outlier {
    /// Pose id.
    pub pose: u32,
    /// Payload, kg.
    pub load_kg: f64,
    /// Norm of its residual after the fit, m.
    pub residual_m: f64,
    /// Its final weight in the fit (1 when not robust).
    pub weight: f64,
}

/// How the fit went.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostics {
    /// The last LM run's termination reason.
    pub termination: String,
    /// Whether the last LM run reported success.
    pub converged: bool,
    /// Residual evaluations over all LM runs.
    pub evaluations: usize,
    /// Active-set rounds used.
    pub active_set_rounds: usize,
    /// Reweighting rounds used (1 when not robust).
    pub irls_rounds: usize,
    /// Compliances fixed at zero by the constraint.
    pub at_bound: Vec<ParamId>,
    /// RMS of the 3D residual norm before the fit (nominal model), m.
    pub rms_before_m: f64,
    /// RMS of the 3D residual norm after the fit, m.
    pub rms_after_m: f64,
    /// Residual standard deviation per coordinate, `sqrt(RSS / (3n − m))`, m.
    pub sigma_m: f64,
    /// Condition number of the column-scaled Jacobian at the solution.
    pub condition: f64,
}

/// The outcome of an identification.
#[derive(Clone, Debug, PartialEq)]
pub struct Identified {
    /// The option fitted.
    pub option: ModelOption,
    /// The nominal arm with the identified errors applied.
    pub arm: Arm<f64>,
    /// Every fitted parameter.
    pub estimates: Vec<Estimate>,
    /// Convergence diagnostics.
    pub diagnostics: Diagnostics,
    /// Measurements named as outliers, largest residual first.
    pub outliers: Vec<Outlier>,
}

/// The LM problem over the free parameters; the fixed ones sit at their bound.
struct Problem<'a> {
    nominal: &'a Arm<f64>,
    free: Vec<ParamId>,
    fixed: Vec<ParamId>,
    samples: &'a [Sample],
    measured: &'a [Vector3<f64>],
    sqrt_w: &'a [f64],
    x: DVector<f64>,
}

impl Problem<'_> {
    /// The arm at the current free errors; fixed compliances at exactly zero.
    fn arm_at(&self, x: &DVector<f64>) -> Arm<f64> {
        let mut arm = *self.nominal;
        for (&id, e) in self.free.iter().zip(x.iter()) {
            *id.value_mut(&mut arm) += *e;
        }
        for &id in &self.fixed {
            *id.value_mut(&mut arm) = 0.0;
        }
        arm
    }

    fn weighted_residuals(&self, arm: &Arm<f64>) -> Option<DVector<f64>> {
        let points = tool_points(arm, self.samples).ok()?;
        let mut r = DVector::zeros(3 * points.len());
        for (k, (p, m)) in points.iter().zip(self.measured).enumerate() {
            r.fixed_rows_mut::<3>(3 * k)
                .copy_from(&((p - m) * self.sqrt_w[k]));
        }
        Some(r)
    }

    fn weighted_jacobian(&self, arm: &Arm<f64>, ids: &[ParamId]) -> Option<DMatrix<f64>> {
        let mut j = jacobian(arm, ids, self.samples, &JacobianOptions::default()).ok()?;
        for (k, w) in self.sqrt_w.iter().enumerate() {
            j.rows_mut(3 * k, 3).scale_mut(*w);
        }
        Some(j)
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.x.copy_from(x);
    }

    fn params(&self) -> DVector<f64> {
        self.x.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        self.weighted_residuals(&self.arm_at(&self.x))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        self.weighted_jacobian(&self.arm_at(&self.x), &self.free)
    }
}

/// Norms of the 3D residuals of `arm` against the measurements, m.
fn residual_norms(
    arm: &Arm<f64>,
    samples: &[Sample],
    measured: &[Vector3<f64>],
) -> Result<Vec<f64>, CalibError> {
    Ok(tool_points(arm, samples)?
        .iter()
        .zip(measured)
        .map(|(p, m)| (p - m).norm())
        .collect())
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// The robust per-axis scale of a set of residual norms.
fn robust_scale(norms: &[f64]) -> f64 {
    let mut v = norms.to_vec();
    v.sort_by(f64::total_cmp);
    let median = if v.is_empty() { 0.0 } else { v[v.len() / 2] };
    median / CHI3_MEDIAN
}

/// Checks that `ids` are identifiable from these samples at `arm`; names the
/// weakest direction when they are not.
pub fn check_rank(
    arm: &Arm<f64>,
    option: ModelOption,
    ids: &[ParamId],
    samples: &[Sample],
) -> Result<f64, CalibError> {
    let j = jacobian(arm, ids, samples, &JacobianOptions::default())?;
    let scaled = super::observability::ColumnScale::from_jacobian(&j, samples.len()).apply(&j);
    let svd = scaled.svd(false, true);
    let sv = &svd.singular_values;
    let (imin, smin) = sv.argmin();
    let smax = sv.max();
    let rank = sv
        .iter()
        .filter(|&&s| s > smax * super::identifiability::RANK_TOLERANCE)
        .count();
    if rank < ids.len() {
        let weakest = svd
            .v_t
            .as_ref()
            .map(|vt| {
                let row = vt.row(imin);
                let mut comps: Vec<(usize, f64)> =
                    row.iter().map(|v| v.abs()).enumerate().collect();
                comps.sort_by(|a, b| b.1.total_cmp(&a.1));
                comps
                    .iter()
                    .take(3)
                    .map(|(c, _)| ids[*c].name())
                    .collect::<Vec<_>>()
                    .join(", ")
            })
            .unwrap_or_default();
        return Err(CalibError::RankDeficient {
            option: option.name().into(),
            rank,
            params: ids.len(),
            weakest,
        });
    }
    Ok(smax / smin)
}

/// Fits the errors `ids` of `nominal` to `measurements`.
pub fn identify(
    nominal: &Arm<f64>,
    option: ModelOption,
    ids: &[ParamId],
    measurements: &[Measurement],
    options: &IdentifyOptions,
) -> Result<Identified, CalibError> {
    let samples: Vec<Sample> = measurements.iter().map(Sample::from).collect();
    let measured: Vec<Vector3<f64>> = measurements.iter().map(|m| m.position).collect();
    if 3 * samples.len() < ids.len() || samples.is_empty() {
        return Err(CalibError::TooFewPoses {
            poses: samples.len(),
            rows: 3 * samples.len(),
            params: ids.len(),
        });
    }
    check_rank(nominal, option, ids, &samples)?;
    let rms_before_m = rms(&residual_norms(nominal, &samples, &measured)?);

    let mut weights: Vec<f64> = vec![1.0; samples.len()];
    let mut errors: Vec<f64> = vec![0.0; ids.len()];
    let mut fixed: Vec<ParamId> = Vec::new();
    let mut evaluations = 0;
    let mut active_set_rounds = 0;
    let mut irls_rounds = 0;
    let mut termination = String::new();
    let mut converged = false;
    let rounds = if options.robust {
        options.max_irls_rounds.max(1)
    } else {
        1
    };
    for _ in 0..rounds {
        irls_rounds += 1;
        let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
        // Active set: fit the free parameters, fix negative compliances at zero,
        // release those whose multiplier has the wrong sign.
        loop {
            active_set_rounds += 1;
            let free: Vec<ParamId> = ids.iter().copied().filter(|p| !fixed.contains(p)).collect();
            let x0 = DVector::from_iterator(
                free.len(),
                free.iter()
                    .map(|p| errors[ids.iter().position(|q| q == p).unwrap_or(0)]),
            );
            let problem = Problem {
                nominal,
                free: free.clone(),
                fixed: fixed.clone(),
                samples: &samples,
                measured: &measured,
                sqrt_w: &sqrt_w,
                x: x0,
            };
            let (problem, report) = LevenbergMarquardt::new()
                .with_patience(50)
                .minimize(problem);
            evaluations += report.number_of_evaluations;
            converged = report.termination.was_successful();
            termination = format!("{:?}", report.termination);
            if !problem.x.iter().all(|v| v.is_finite()) {
                return Err(CalibError::Solver {
                    option: option.name().into(),
                    reason: termination,
                });
            }
            for (p, v) in free.iter().zip(problem.x.iter()) {
                if let Some(i) = ids.iter().position(|q| q == p) {
                    errors[i] = *v;
                }
            }
            for (i, p) in ids.iter().enumerate() {
                if fixed.contains(p) {
                    errors[i] = -p.value(nominal);
                }
            }
            let arm = problem.arm_at(&problem.x);
            let negative: Vec<ParamId> = free
                .iter()
                .copied()
                .filter(|p| !p.is_geometric() && p.value(&arm) < 0.0)
                .collect();
            if active_set_rounds >= options.max_active_set_rounds {
                break;
            }
            if !negative.is_empty() {
                fixed.extend(negative);
                continue;
            }
            // d(cost)/d(k) for each fixed compliance at the solution.
            if fixed.is_empty() {
                break;
            }
            let (Some(r), Some(jf)) = (
                problem.weighted_residuals(&arm),
                problem.weighted_jacobian(&arm, &fixed),
            ) else {
                break;
            };
            let g = jf.transpose() * r;
            let scale = jf
                .column_iter()
                .map(|c| c.norm())
                .fold(0.0, f64::max)
                .max(1e-300);
            match g
                .iter()
                .enumerate()
                .filter(|(_, v)| **v < -1e-9 * scale)
                .min_by(|a, b| a.1.total_cmp(b.1))
            {
                Some((i, _)) => {
                    fixed.remove(i);
                }
                None => break,
            }
        }
        if !options.robust {
            break;
        }
        let arm = nominal_plus(nominal, ids, &errors, &fixed);
        let norms = residual_norms(&arm, &samples, &measured)?;
        let c = HUBER_K * robust_scale(&norms);
        let new: Vec<f64> = norms
            .iter()
            .map(|&e| if e <= c || e == 0.0 { 1.0 } else { c / e })
            .collect();
        let change = new
            .iter()
            .zip(&weights)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        weights = new;
        if change < 1e-3 {
            break;
        }
    }

    let arm = nominal_plus(nominal, ids, &errors, &fixed);
    let norms = residual_norms(&arm, &samples, &measured).map_err(|e| CalibError::Solver {
        option: option.name().into(),
        reason: format!(
            "the fit ended where the model cannot be evaluated ({e}); {} poses do not determine these {} parameters: measure more poses (e.g. select 50 with `lrmcal select`)",
            samples.len(),
            ids.len()
        ),
    })?;
    let free: Vec<ParamId> = ids.iter().copied().filter(|p| !fixed.contains(p)).collect();
    let mut j = jacobian(&arm, &free, &samples, &JacobianOptions::default())?;
    for (k, w) in weights.iter().enumerate() {
        j.rows_mut(3 * k, 3).scale_mut(w.sqrt());
    }
    let rss: f64 = norms.iter().zip(&weights).map(|(e, w)| w * e * e).sum();
    let dof = (3 * samples.len()).saturating_sub(free.len()).max(1);
    let sigma_m = (rss / dof as f64).sqrt();
    let scale = super::observability::ColumnScale::from_jacobian(&j, samples.len());
    let js = scale.apply(&j);
    let svd = js.svd(true, true);
    let condition = svd.singular_values.max() / svd.singular_values.min();
    // cov of scaled params = s² (JsᵀJs)⁻¹ = s² V Σ⁻² Vᵀ; unscale by the factors.
    let vt = svd.v_t.as_ref();
    let std_free: Vec<f64> = (0..free.len())
        .map(|c| {
            let var: f64 = vt
                .map(|vt| {
                    svd.singular_values
                        .iter()
                        .enumerate()
                        .map(|(i, s)| (vt[(i, c)] / s).powi(2))
                        .sum()
                })
                .unwrap_or(f64::NAN);
            sigma_m * var.sqrt() * scale.factors[c]
        })
        .collect();
    let estimates = ids
        .iter()
        .zip(&errors)
        .map(|(&id, &error)| Estimate {
            id,
            error,
            value: id.value(&arm),
            std: free.iter().position(|p| *p == id).map(|i| std_free[i]),
        })
        .collect();
    let s = robust_scale(&norms);
    let mut outliers: Vec<Outlier> = norms
        .iter()
        .enumerate()
        .filter(|(_, e)| **e > OUTLIER_K * s && s > 0.0)
        .map(|(k, e)| Outlier {
            pose: samples[k].id,
            load_kg: samples[k].load_kg,
            residual_m: *e,
            weight: weights[k],
        })
        .collect();
    outliers.sort_by(|a, b| b.residual_m.total_cmp(&a.residual_m));
    Ok(Identified {
        option,
        arm,
        estimates,
        diagnostics: Diagnostics {
            termination,
            converged,
            evaluations,
            active_set_rounds,
            irls_rounds,
            at_bound: fixed,
            rms_before_m,
            rms_after_m: rms(&norms),
            sigma_m,
            condition,
        },
        outliers,
    })
}

/// The nominal arm with `errors` applied; compliances in `fixed` at exactly zero.
fn nominal_plus(
    nominal: &Arm<f64>,
    ids: &[ParamId],
    errors: &[f64],
    fixed: &[ParamId],
) -> Arm<f64> {
    let mut arm = nominal.with_errors(ids, errors);
    for &id in fixed {
        *id.value_mut(&mut arm) = 0.0;
    }
    arm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{rigid_nominal, small_samples, true_errors};
    use crate::dataset::Pose;

    fn measure(arm: &Arm<f64>, samples: &[Sample]) -> Vec<Measurement> {
        tool_points(arm, samples)
            .unwrap()
            .into_iter()
            .zip(samples)
            .map(|(p, s)| Measurement {
                pose: Pose { id: s.id, q: s.q },
                load_kg: s.load_kg,
                position: p,
            })
            .collect()
    }

    fn elastic_ids() -> Vec<ParamId> {
        ["k2", "k3", "k4", "k5", "k0"]
            .iter()
            .map(|n| ParamId::from_name(n).unwrap())
            .collect()
    }

    /// Noise-free data of a true arm that differs only in compliances: the fit
    /// recovers them exactly and the residual vanishes.
    #[test]
    fn recovers_compliances_exactly() {
        let nominal = rigid_nominal();
        let ids = elastic_ids();
        let truth = [0.1, 0.05, 0.08, 0.03, 0.02];
        let true_arm = nominal.with_errors(&ids, &truth);
        let meas = measure(&true_arm, &small_samples(16));
        let fit = identify(
            &nominal,
            ModelOption::Elastic,
            &ids,
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        for (e, t) in fit.estimates.iter().zip(truth) {
            assert!((e.error - t).abs() < 1e-8, "{}: {} vs {t}", e.id, e.error);
        }
        assert!(fit.diagnostics.rms_after_m < 1e-9);
        assert!(fit.diagnostics.converged, "{}", fit.diagnostics.termination);
    }

    /// A true compliance of zero with data pulling it below zero stays at the
    /// bound, and the bound is reported.
    #[test]
    fn compliances_never_go_negative() {
        let nominal = rigid_nominal();
        let ids = elastic_ids();
        // Measurements of an arm that sags *upwards* at joint 3: only a negative k3 would fit.
        let mut true_arm = nominal.with_errors(&ids, &[0.1, 0.0, 0.08, 0.03, 0.02]);
        true_arm.joints[2].compliance = -0.05;
        let meas = measure(&true_arm, &small_samples(16));
        let fit = identify(
            &nominal,
            ModelOption::Elastic,
            &ids,
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        assert!(
            fit.arm.joints.iter().all(|j| j.compliance >= 0.0) && fit.arm.base_compliance >= 0.0
        );
        let k3 = ParamId::from_name("k3").unwrap();
        assert!(
            fit.diagnostics.at_bound.contains(&k3),
            "{:?}",
            fit.estimates
        );
        // KKT: raising any compliance held at zero makes the fit worse.
        let samples: Vec<Sample> = meas.iter().map(Sample::from).collect();
        let points: Vec<Vector3<f64>> = meas.iter().map(|m| m.position).collect();
        let cost = |arm: &Arm<f64>| rms(&residual_norms(arm, &samples, &points).unwrap());
        for &p in &fit.diagnostics.at_bound {
            let raised = fit.arm.with_errors(&[p], &[1e-4]);
            assert!(cost(&raised) > cost(&fit.arm), "{p} should stay at zero");
        }
        assert!(fit.estimates[1].std.is_none());
    }

    /// One corrupted measurement is named, and the robust fit is not pulled by it.
    #[test]
    fn robust_fit_names_and_ignores_an_outlier() {
        let nominal = rigid_nominal();
        let ids = elastic_ids();
        let truth = [0.1, 0.05, 0.08, 0.03, 0.02];
        let samples = small_samples(24);
        let mut meas = measure(&nominal.with_errors(&ids, &truth), &samples);
        // Small noise so the robust scale is not zero, then one gross error.
        for (k, m) in meas.iter_mut().enumerate() {
            m.position.x += 1e-4 * ((k * 7 % 5) as f64 - 2.0);
        }
        meas[5].position.z += 0.02;
        let robust = IdentifyOptions {
            robust: true,
            ..Default::default()
        };
        let fit = identify(&nominal, ModelOption::Elastic, &ids, &meas, &robust).unwrap();
        assert_eq!(fit.outliers.first().map(|o| o.pose), Some(meas[5].pose.id));
        assert!(fit.outliers[0].weight < 0.1);
        let plain = identify(
            &nominal,
            ModelOption::Elastic,
            &ids,
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        let err = |f: &Identified| {
            f.estimates
                .iter()
                .zip(truth)
                .map(|(e, t)| (e.error - t).abs())
                .fold(0.0, f64::max)
        };
        assert!(
            err(&fit) < 0.5 * err(&plain),
            "robust {} plain {}",
            err(&fit),
            err(&plain)
        );
    }

    #[test]
    fn too_few_and_rank_deficient_sets_are_refused() {
        let nominal = rigid_nominal();
        let all: Vec<ParamId> = ParamId::all().collect();
        let meas = measure(
            &nominal.with_errors(&all, &true_errors(1)),
            &small_samples(20),
        );
        let opts = IdentifyOptions::default();
        assert!(matches!(
            identify(
                &nominal,
                ModelOption::ElastoKinematic,
                &all,
                &meas[..5],
                &opts
            ),
            Err(CalibError::TooFewPoses { params: 43, .. })
        ));
        // All 43 include the tool rotation, which no position can reveal.
        let err = identify(&nominal, ModelOption::ElastoKinematic, &all, &meas, &opts).unwrap_err();
        assert!(matches!(err, CalibError::RankDeficient { .. }), "{err}");
    }
}
