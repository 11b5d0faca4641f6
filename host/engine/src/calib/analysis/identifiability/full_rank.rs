//! The check that a fit's parameters are identifiable from its poses: the
//! column-scaled Jacobian of full rank, or the parameters of its weakest
//! direction named.

use crate::calib::analysis::jacobian::jacobian;
use crate::calib::analysis::observability::ColumnScale;
use crate::calib::analysis::triangular::triangular_factor;
use crate::calib::parameters::params::ParamKey;
use crate::calib::{CalibError, ModelOption, Rig, Sample};

use super::numerical_rank;

/// Checks that `keys` are identifiable from `samples` at `rig`: the
/// column-scaled Jacobian has full rank. When it has not, the error names the
/// parameters that dominate the weakest direction.
pub fn check_full_rank(
    rig: &Rig,
    option: ModelOption,
    keys: &[ParamKey],
    samples: &[Sample],
) -> Result<(), CalibError> {
    let j = jacobian(rig, keys, samples)?;
    let scaled = ColumnScale::from_jacobian(&j, samples.len()).apply(&j);
    // The same singular values and right singular vectors, on a square matrix.
    let svd = triangular_factor(&scaled).svd(false, true);
    let rank = numerical_rank(&svd.singular_values);
    if rank == keys.len() {
        return Ok(());
    }
    let (weakest_direction, _) = svd.singular_values.argmin();
    let weakest = svd
        .v_t
        .as_ref()
        .map(|vt| {
            let mut comps: Vec<(usize, f64)> = vt
                .row(weakest_direction)
                .iter()
                .map(|v| v.abs())
                .enumerate()
                .collect();
            comps.sort_by(|a, b| b.1.total_cmp(&a.1));
            comps
                .iter()
                .take(3)
                .map(|(c, _)| keys[*c].name())
                .collect::<Vec<_>>()
                .join(", ")
        })
        .unwrap_or_default();
    Err(CalibError::RankDeficient {
        option: option.name().into(),
        rank,
        params: keys.len(),
        weakest,
    })
}
