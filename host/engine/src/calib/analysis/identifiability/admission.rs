//! Whether a column joins the kept ones: its effect at a typical error, its
//! part outside the span of the kept columns (Gram–Schmidt with
//! re-orthogonalisation), and the compliances left to the geometric columns
//! that reproduce them.

use model::params::ParamKind;
use nalgebra::{DMatrix, DVector};

use super::{RESOLUTION_M, TypicalErrors};
use crate::calib::parameters::params::ParamKey;

/// Per column of `j` (columns `ids`): what a typical error of the
/// parameter moves the points by (RMS, m), and the column normalised — or
/// zero when that effect is below [`RESOLUTION_M`] (a parameter that moves
/// no point by a resolution has no effect a tracker could see: what is
/// left is rounding and load coupling).
pub(super) fn effects_and_units(
    ids: &[ParamKey],
    j: &DMatrix<f64>,
    typical: &TypicalErrors,
) -> (Vec<f64>, Vec<DVector<f64>>) {
    let samples = (j.nrows() / 3).max(1) as f64;
    let effect: Vec<f64> = j
        .column_iter()
        .zip(ids)
        .map(|(c, id)| c.norm() * typical.of(*id) / samples.sqrt())
        .collect();
    let unit = j
        .column_iter()
        .zip(&effect)
        .map(|(c, &effect)| {
            if effect > RESOLUTION_M {
                c.normalize()
            } else {
                DVector::zeros(c.len())
            }
        })
        .collect();
    (effect, unit)
}

/// A compliance cannot go below zero, a geometric parameter can go either
/// way.
fn one_sided(id: ParamKey) -> bool {
    id.kind() == ParamKind::Compliance
}

/// The span of the two-sided (geometric) columns among `unit` (columns `ids`).
pub(super) fn geometric_span(
    ids: &[ParamKey],
    unit: &[DVector<f64>],
    tolerance: f64,
) -> Vec<DVector<f64>> {
    orthonormal_span(
        ids.iter()
            .zip(unit)
            .filter(|(id, _)| !one_sided(**id))
            .map(|(_, u)| u),
        tolerance,
    )
}

/// Judges the column `unit` of `id` (its typical error moving the points by
/// `effect`) against the kept columns' orthonormal `basis`, and adds it
/// when it is kept; the length of its part outside the basis when it is not.
/// A compliance whose column the geometric columns reproduce (a slide's
/// spring under a constant force is a constant offset) is left to them, or
/// the half of that direction the spring cannot take is lost. A column is
/// kept when its part outside the basis exceeds `tolerance` and a typical
/// error moves the points by more than [`RESOLUTION_M`] along that part.
pub(super) fn admit(
    basis: &mut Vec<DVector<f64>>,
    geometric_span: &[DVector<f64>],
    id: ParamKey,
    unit: &DVector<f64>,
    effect: f64,
    tolerance: f64,
) -> Result<(), f64> {
    if one_sided(id) && outside(geometric_span, unit) * effect <= RESOLUTION_M {
        return Err(outside(basis, unit));
    }
    let r = remainder(basis, unit);
    let residual = r.norm();
    if residual > tolerance && residual * effect > RESOLUTION_M {
        basis.push(r / residual);
        Ok(())
    } else {
        Err(residual)
    }
}

/// What of `v` lies outside the span of the orthonormal `basis` (Gram–Schmidt
/// with re-orthogonalisation).
fn remainder(basis: &[DVector<f64>], v: &DVector<f64>) -> DVector<f64> {
    let mut r = v.clone();
    for _ in 0..2 {
        for b in basis {
            r -= b * b.dot(&r);
        }
    }
    r
}

/// The length of [`remainder`].
fn outside(basis: &[DVector<f64>], v: &DVector<f64>) -> f64 {
    remainder(basis, v).norm()
}

/// An orthonormal basis of the span of `columns`: each column's remainder
/// joins it when longer than `tolerance`.
pub(super) fn orthonormal_span<'a>(
    columns: impl Iterator<Item = &'a DVector<f64>>,
    tolerance: f64,
) -> Vec<DVector<f64>> {
    let mut basis = Vec::new();
    for c in columns {
        let r = remainder(&basis, c);
        let norm = r.norm();
        if norm > tolerance {
            basis.push(r / norm);
        }
    }
    basis
}
