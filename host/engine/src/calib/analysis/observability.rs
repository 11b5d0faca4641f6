//! Column scaling of the identification Jacobian and the observability indices
//! O1..O5 compared by Joubair & Bonev (2013).
//!
//! Parameters come in metres, radians and rad/Nm, so raw singular values mix
//! units. Every index here is taken on a column-scaled Jacobian. The scale is
//! fixed once per candidate set (each column divided by its RMS over the
//! candidates' 3-row blocks) and then applied unchanged to any subset, so the
//! indices of two pose sets, or of a set before and after an exchange, are
//! comparable.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// Per-column factors that make the columns comparable.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ColumnScale {
    /// Column `c` of a Jacobian is multiplied by `factors[c]`.
    pub factors: Vec<f64>,
}

impl ColumnScale {
    /// Scale from a stacked Jacobian of `blocks` poses: each column to unit RMS
    /// per block. A column with no effect at all is left unscaled.
    pub fn from_jacobian(j: &DMatrix<f64>, blocks: usize) -> Self {
        let factors = j
            .column_iter()
            .map(|c| {
                let rms = c.norm() / (blocks.max(1) as f64).sqrt();
                if rms > 0.0 { 1.0 / rms } else { 1.0 }
            })
            .collect();
        Self { factors }
    }

    /// `j` with its columns scaled.
    pub fn apply(&self, j: &DMatrix<f64>) -> DMatrix<f64> {
        let mut s = j.clone();
        for (c, f) in self.factors.iter().enumerate() {
            s.column_mut(c).scale_mut(*f);
        }
        s
    }
}

/// The five observability indices of one pose set.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Observability {
    /// O1 = (σ1 ⋯ σm)^(1/m) / √n: D-optimality; DETMAX maximises it.
    #[serde(deserialize_with = "lrmcal_core::io::json::nan_if_null")]
    pub o1: f64,
    /// O2 = σmin / σmax, the inverse condition number.
    #[serde(deserialize_with = "lrmcal_core::io::json::nan_if_null")]
    pub o2: f64,
    /// O3 = σmin, the minimum singular value.
    #[serde(deserialize_with = "lrmcal_core::io::json::nan_if_null")]
    pub o3: f64,
    /// O4 = σmin² / σmax, the noise amplification index.
    #[serde(deserialize_with = "lrmcal_core::io::json::nan_if_null")]
    pub o4: f64,
    /// O5 = 1 / Σ 1/σi.
    #[serde(deserialize_with = "lrmcal_core::io::json::nan_if_null")]
    pub o5: f64,
}

impl Observability {
    /// Indices of a column-scaled Jacobian of `poses` poses.
    ///
    /// A rank-deficient set has σmin = 0 and so O1 = O3 = O4 = O5 = 0.
    pub fn of_scaled(j_scaled: &DMatrix<f64>, poses: usize) -> Self {
        let sv = j_scaled.clone().svd(false, false).singular_values;
        let m = sv.len().max(1) as f64;
        let (min, max) = (sv.min(), sv.max());
        let o1 = if min > 0.0 {
            (sv.iter().map(|s| s.ln()).sum::<f64>() / m).exp() / (poses.max(1) as f64).sqrt()
        } else {
            0.0
        };
        let inv_sum: f64 = sv.iter().map(|s| 1.0 / s).sum();
        Self {
            o1,
            o2: if max > 0.0 { min / max } else { 0.0 },
            o3: min,
            o4: if max > 0.0 { min * min / max } else { 0.0 },
            o5: if min > 0.0 { 1.0 / inv_sum } else { 0.0 },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn indices_of_a_known_matrix() {
        // Singular values 4 and 1 with 2 "poses" of one row each... the definitions
        // only need the singular values, so a diagonal matrix checks them.
        let j = DMatrix::from_row_slice(2, 2, &[4.0, 0.0, 0.0, 1.0]);
        let o = Observability::of_scaled(&j, 4);
        assert!((o.o1 - 2.0 / 2.0).abs() < 1e-12);
        assert!((o.o2 - 0.25).abs() < 1e-12);
        assert!((o.o3 - 1.0).abs() < 1e-12);
        assert!((o.o4 - 0.25).abs() < 1e-12);
        assert!((o.o5 - 0.8).abs() < 1e-12);
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        assert_eq!(Observability::of_scaled(&singular, 1).o1, 0.0);
    }

    #[test]
    fn scale_gives_unit_rms_columns() {
        let j = DMatrix::from_row_slice(3, 2, &[1.0, 100.0, 2.0, 0.0, 2.0, 0.0]);
        let s = ColumnScale::from_jacobian(&j, 1).apply(&j);
        assert!((s.column(0).norm() - 1.0).abs() < 1e-12);
        assert!((s.column(1).norm() - 1.0).abs() < 1e-12);
    }
}
