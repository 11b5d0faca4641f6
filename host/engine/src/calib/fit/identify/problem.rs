//! The least-squares problem each Levenberg–Marquardt run solves: the
//! measurements as the solver sees them, their weighted residuals and
//! Jacobian with the prior's rows below them, and what the runs add up to.

use levenberg_marquardt::LeastSquaresProblem;
use lrmcal_core::dataset::Measurement;
use nalgebra::allocator::Reallocator;
use nalgebra::storage::Owned;
use nalgebra::{DMatrix, DVector, DefaultAllocator, Dim, Dyn, OMatrix, Vector3};

use super::compressed;
use super::robust::Weighting;
use crate::calib::analysis::jacobian::jacobian;
use crate::calib::parameters::params::{ParamKey, ParamVector};
use crate::calib::parameters::prior::Prior;
use crate::calib::{CalibError, ModelOption, Rig, Sample};

/// The measurements of one fit, as the solver sees them.
pub(super) struct FitData<'a> {
    pub(super) nominal: &'a Rig,
    pub(super) option: ModelOption,
    pub(super) samples: Vec<Sample>,
    pub(super) measured: Vec<Vector3<f64>>,
    /// The rows of the stacked blocks that hold a measurement, when some do
    /// not (a pixel's block is `(u, v, 0)`: its third row is zero whatever
    /// the parameters); `None` when every row does.
    pub(super) measured_rows: Option<Vec<usize>>,
    /// The prior on the corrections of the keys, if the fit has one.
    pub(super) prior: Option<Prior>,
}

impl<'a> FitData<'a> {
    pub(super) fn new(
        nominal: &'a Rig,
        option: ModelOption,
        measurements: &[Measurement],
    ) -> Result<Self, CalibError> {
        let samples = nominal.samples(measurements)?;
        let measured_rows = measurements.iter().any(|m| m.pixel.is_some()).then(|| {
            measurements
                .iter()
                .enumerate()
                .flat_map(|(k, m)| {
                    let rows = if m.pixel.is_some() { 2 } else { 3 };
                    (0..rows).map(move |row| 3 * k + row)
                })
                .collect()
        });
        Ok(Self {
            nominal,
            option,
            samples,
            measured: measurements.iter().map(measured_block).collect(),
            measured_rows,
            prior: None,
        })
    }

    /// The prior's rows at the corrections of `params` with the free ones
    /// taken from `free`, each times `sigma` (the measurements' noise, the
    /// scale of the weighted residuals); `None` without a prior.
    pub(super) fn prior_residuals(
        &self,
        params: &ParamVector,
        free: &[f64],
        sigma: f64,
    ) -> Option<DVector<f64>> {
        let prior = self.prior.as_ref()?;
        let mut trial = free.iter();
        let errors: Vec<f64> = params
            .iter()
            .map(|p| match p.fixed {
                true => p.error,
                false => trial.next().copied().unwrap_or(p.error),
            })
            .collect();
        Some(prior.residuals(&errors) * sigma)
    }

    /// The Jacobian of [`FitData::prior_residuals`] with respect to the
    /// `fixed` or the free parameters of `params`; `None` without a prior.
    pub(super) fn prior_jacobian(
        &self,
        params: &ParamVector,
        fixed: bool,
        sigma: f64,
    ) -> Option<DMatrix<f64>> {
        let prior = self.prior.as_ref()?;
        let columns: Vec<usize> = params
            .iter()
            .enumerate()
            .filter(|(_, p)| p.fixed == fixed)
            .map(|(c, _)| c)
            .collect();
        Some(prior.columns(&columns) * sigma)
    }

    /// The smallest and largest value the fit may give `key`'s quantity, if bounded.
    pub(super) fn bounds(&self, key: ParamKey) -> (Option<f64>, Option<f64>) {
        key.fit_range(&self.nominal.bounds)
    }

    /// Norms of the residuals of `arm` against the measurements, m.
    pub(super) fn residual_norms(&self, arm: &Rig) -> Result<Vec<f64>, CalibError> {
        Ok(self.residuals(arm)?.iter().map(|r| r.norm()).collect())
    }

    /// The residual blocks of `arm` against the measurements, m (a
    /// camera's carried to the target's distance: `calib::parameters::camera`).
    pub(super) fn residuals(&self, arm: &Rig) -> Result<Vec<Vector3<f64>>, CalibError> {
        arm.residuals(&self.samples, &self.measured)
    }

    /// The stacked residuals of `arm`, each block as `weighting` has the
    /// solver see it.
    pub(super) fn weighted_residuals(
        &self,
        arm: &Rig,
        weighting: Weighting,
    ) -> Option<DVector<f64>> {
        let residuals = arm.residuals(&self.samples, &self.measured).ok()?;
        let mut r = DVector::zeros(3 * residuals.len());
        for (k, block) in residuals.iter().enumerate() {
            r.fixed_rows_mut::<3>(3 * k)
                .copy_from(&weighting.block(k, block).0);
        }
        Some(r)
    }

    /// The Jacobian with respect to `keys` at `arm` of the residuals, each
    /// block times its `sqrt_w`.
    pub(super) fn weighted_jacobian(
        &self,
        arm: &Rig,
        keys: &[ParamKey],
        sqrt_w: &[f64],
    ) -> Result<DMatrix<f64>, CalibError> {
        let mut j = jacobian(arm, keys, &self.samples)?;
        for (k, w) in sqrt_w.iter().enumerate() {
            j.rows_mut(3 * k, 3).scale_mut(*w);
        }
        Ok(j)
    }

    /// [`FitData::weighted_residuals`] and their Jacobian with respect to
    /// `keys`, from one evaluation of the residuals (Huber's weighting
    /// needs them for the Jacobian too).
    pub(super) fn weighted_with_jacobian(
        &self,
        arm: &Rig,
        keys: &[ParamKey],
        weighting: Weighting,
    ) -> Result<(DVector<f64>, DMatrix<f64>), CalibError> {
        let residuals = self.residuals(arm)?;
        let mut j = jacobian(arm, keys, &self.samples)?;
        let mut r = DVector::zeros(3 * residuals.len());
        for (k, block) in residuals.iter().enumerate() {
            let (seen, map) = weighting.block(k, block);
            r.fixed_rows_mut::<3>(3 * k).copy_from(&seen);
            match weighting {
                Weighting::Scaled(sqrt_w) => j.rows_mut(3 * k, 3).scale_mut(sqrt_w[k]),
                Weighting::Huber(_) => {
                    let rows = map * j.rows(3 * k, 3);
                    j.rows_mut(3 * k, 3).copy_from(&rows);
                }
            }
        }
        Ok((r, j))
    }

    pub(super) fn solver_error(&self, reason: String) -> CalibError {
        CalibError::Solver {
            option: self.option.name().into(),
            reason,
        }
    }
}

/// A measurement's block as the fit compares it (`calib::parameters::camera`):
/// its point, m, or its pixel `(u, v, 0)`, px.
pub(crate) fn measured_block(m: &Measurement) -> Vector3<f64> {
    match m.pixel {
        Some(pixel) => Vector3::new(pixel.x, pixel.y, 0.0),
        None => m.position,
    }
}

/// The LM problem over the free parameters; the fixed ones stay where they are.
pub(super) struct Problem<'a> {
    pub(super) data: &'a FitData<'a>,
    pub(super) params: &'a ParamVector,
    pub(super) free: Vec<ParamKey>,
    pub(super) weighting: Weighting<'a>,
    /// The noise the prior's rows are scaled by, m.
    pub(super) sigma: f64,
    pub(super) x: DVector<f64>,
    /// The residual of a trial point whose deflection cannot be solved
    /// (each entry), from the norm the run started from.
    pub(super) failed_entry: f64,
    /// Trial points that could not be evaluated.
    pub(super) failed: std::cell::Cell<usize>,
}

impl Problem<'_> {
    pub(super) fn arm(&self) -> Rig {
        self.params
            .apply_with_free(self.data.nominal, self.x.as_slice())
    }

    /// The rows of `stacked` (the blocks' residuals or Jacobian) that hold
    /// a measurement: the solver's work grows with its rows, and a pixel's
    /// third row is always zero.
    fn measured<C: Dim>(&self, stacked: OMatrix<f64, Dyn, C>) -> OMatrix<f64, Dyn, C>
    where
        DefaultAllocator: nalgebra::allocator::Allocator<Dyn, C>,
    {
        match &self.data.measured_rows {
            Some(rows) => stacked.select_rows(rows),
            None => stacked,
        }
    }

    /// How many rows the measurements give the solver.
    fn measured_count(&self) -> usize {
        self.data
            .measured_rows
            .as_ref()
            .map_or(3 * self.data.samples.len(), Vec::len)
    }
}

impl Problem<'_> {
    /// The measurements' weighted residuals with the prior's rows below,
    /// at the trial point; `None` where the deflection cannot be solved.
    pub(super) fn stacked_residuals(&self) -> Option<DVector<f64>> {
        let prior = self
            .data
            .prior_residuals(self.params, self.x.as_slice(), self.sigma);
        let r = self.data.weighted_residuals(&self.arm(), self.weighting)?;
        Some(stack(self.measured(r), prior))
    }

    /// [`Problem::stacked_residuals`] and their Jacobian over the free
    /// parameters, from one evaluation of the model.
    pub(super) fn stacked_with_jacobian(&self) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let (r, j) = self
            .data
            .weighted_with_jacobian(&self.arm(), &self.free, self.weighting)
            .ok()?;
        let prior = self
            .data
            .prior_residuals(self.params, self.x.as_slice(), self.sigma);
        Some((
            stack(self.measured(r), prior),
            stack(
                self.measured(j),
                self.data.prior_jacobian(self.params, false, self.sigma),
            ),
        ))
    }
}

/// The solver sees the stacked problem compressed to one row more than
/// the free parameters (`compressed`): the same cost, gradient and
/// Gauss–Newton matrix, so the same steps, for a fraction of its QR.
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
        let norm = match self.stacked_residuals() {
            Some(r) => r.norm(),
            None => {
                // A failed step, not the end of the fit (module docs).
                self.failed.set(self.failed.get() + 1);
                let prior = self.data.prior.as_ref().map_or(0, |p| p.len());
                self.failed_entry * ((self.measured_count() + prior) as f64).sqrt()
            }
        };
        Some(compressed::residuals(norm, self.free.len()))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        // LM asks at points whose residuals it accepted: they evaluate.
        let (r, j) = self.stacked_with_jacobian()?;
        Some(compressed::jacobian(&r, j))
    }
}

/// What the LM runs of a fit add up to.
#[derive(Debug, Default)]
pub(super) struct Tally {
    pub(super) evaluations: usize,
    pub(super) exhausted: bool,
    pub(super) active_set_rounds: usize,
    pub(super) irls_rounds: usize,
    pub(super) failed_steps: usize,
    pub(super) termination: String,
    pub(super) converged: bool,
}

/// `top` (the measurements' residuals, or their Jacobian) with the prior's
/// rows below it, if any.
pub(super) fn stack<C: Dim>(
    top: OMatrix<f64, Dyn, C>,
    prior: Option<OMatrix<f64, Dyn, C>>,
) -> OMatrix<f64, Dyn, C>
where
    DefaultAllocator: Reallocator<f64, Dyn, C, Dyn, C>,
{
    match prior {
        Some(p) => {
            let rows = top.nrows();
            let mut out = top.resize_vertically(rows + p.nrows(), 0.0);
            out.rows_mut(rows, p.nrows()).copy_from(&p);
            out
        }
        None => top,
    }
}
