//! Which error parameters 3D positions can identify: the largest subset whose
//! Jacobian columns are independent over the candidate poses.
//!
//! Method: the Jacobian over all candidate samples, each column scaled to unit
//! norm for the angles between columns. Parameters are taken in the
//! option's preference order (compliances first, then the base and tool
//! frames, then DH joint by joint; `crate::calib::parameters::option` says why) and one is kept when its unit column has a component of at least
//! [`RANK_TOLERANCE`] orthogonal to the span of the columns already kept
//! (Gram–Schmidt with re-orthogonalisation); otherwise it is removed, and the
//! least-squares combination of kept columns that reproduces it names what it
//! is confounded with. The tolerance is the sine of the angle between a column
//! and that span: 1e-6 sits far above the Jacobian's rounding noise (~1e-15) and
//! far below any genuinely identifiable direction on a realistic arm (≳1e-3).
//! A sine says nothing of size, though: a column can stand at an angle to the
//! others only through a coupling no tracker resolves (on an industrial arm
//! the gravity load makes `j6.d` differ from `tool.z` by nanometres). So a
//! kept parameter must also move the points, RMS over the samples, by
//! [`RESOLUTION_M`] along its own direction when it errs by a typical amount
//! ([`TypicalErrors`]); that is what makes the analysis scale-aware. An SVD
//! of all candidate columns with the same two tests must give the same rank
//! ([`Identifiability::svd_rank`] reports it as a check).
//!
//! **On the bundled arm** (`lrmcal select --candidates …` prints this) 32 of
//! the 43 parameters remain (26 of 36 kinematic, 6 of 7 elastic), where the
//! paper found 28 / 21 / 7 on the real LRM. Removed, each for a reason of the
//! arm's structure: the three tool rotations (the measured point is the tool
//! frame's origin, so turning the frame about it moves nothing); j1.d and
//! j1.theta (the same motions as the base's z and yaw while the base is
//! level); j3.d (joints 2 and 3 are parallel, so d2 and d3 shift the chain
//! along the same axis); j6.theta, j6.d, j6.a and j6.alpha (they move the
//! tool point within frame 6, which the tool offset already spans); and k1
//! (joint 1's axis is vertical on the level nominal base, so gravity exerts no
//! torque about it and its compliance never shows). Several of these are
//! redundant only at the nominal arm; `crate::calib::fit::refresh` runs the analysis again
//! at the estimate. The paper does not list what it removed, and
//! the bundled arm is LRM-like rather than the measured LRM, so the counts
//! need not agree; these redundancies hold for any arm of this structure.
//!
//! This file holds the analysis and its outcome; the typical errors
//! ([`TypicalErrors`]), the judging of one column against the kept ones
//! (`admission`), the full-rank check of a fit's parameters
//! ([`check_full_rank`]) and the structural identifiability a pose set is
//! held to ([`Structures`]) have files of their own.

use model::Arm;
use nalgebra::{DMatrix, DVector};

use crate::calib::analysis::jacobian::jacobian;
use crate::calib::analysis::triangular::triangular_factor;
use crate::calib::parameters::option::candidates;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::{self, KnotSpacing};
use crate::calib::{CalibError, ModelOption, Rig, Sample};

mod admission;
mod full_rank;
mod structures;
mod typical;

use admission::{admit, effects_and_units, geometric_span, orthonormal_span};
pub use full_rank::check_full_rank;
pub use structures::Structures;
pub use typical::TypicalErrors;

/// Sine of the smallest angle between a kept column and the span of the others.
pub const RANK_TOLERANCE: f64 = 1e-6;

/// The smallest displacement, RMS over the samples in metres, that a typical
/// error of a parameter must cause in a direction the kept parameters cannot
/// reproduce for the parameter to count as identifiable: 0.1 µm, a hundred
/// times below the noise of the best laser trackers, so nothing a tracker
/// could see is dropped. What it drops are couplings through the gravity
/// load alone: on an industrial arm a millimetre of `j6.d` against `tool.z`
/// moves link 6's mass and with it the sag of the stiff arm by nanometres
/// (6.5e-9 m on the UR10-like test arm), which 60 poses cannot tell from
/// rounding; a millimetre of `tool.roll` swings the payload's centre of mass
/// and moves the point by 5e-9 m. On the bundled arm every kept parameter
/// clears it by more than ten times (the least, `k6`, moves the point 1.5 µm
/// past the others), every confounded one misses it by millions.
pub const RESOLUTION_M: f64 = 1e-7;

/// The numerical rank of a matrix from its singular values: how many exceed
/// [`RANK_TOLERANCE`] times the largest.
fn numerical_rank(singular_values: &DVector<f64>) -> usize {
    let smax = singular_values.max();
    singular_values
        .iter()
        .filter(|&&s| s > smax * RANK_TOLERANCE)
        .count()
}

/// A parameter removed by the analysis.
#[derive(Clone, Debug, PartialEq)]
pub struct Removed {
    /// The parameter.
    pub id: ParamKey,
    /// Sine of the angle between its column and the span of the kept columns.
    pub residual: f64,
    /// Kept parameters whose (unit) columns reproduce its column, with their
    /// coefficients, largest first; empty when the column is zero (no effect).
    pub confounded_with: Vec<(ParamKey, f64)>,
}

/// The outcome of the rank analysis for one model option.
#[derive(Clone, Debug, PartialEq)]
pub struct Identifiability {
    /// The option analysed.
    pub option: ModelOption,
    /// Identifiable parameters, in preference order.
    pub kept: Vec<ParamKey>,
    /// Removed parameters, in preference order.
    pub removed: Vec<Removed>,
    /// Rank of all candidate columns by SVD with the same tolerance and resolution.
    pub svd_rank: usize,
    /// Condition number of the kept, unit-scaled columns.
    pub kept_condition: f64,
    /// The grid of the servo curves' knots among the candidates, if any
    /// (`calib::servo_knots`).
    pub knots: Option<KnotSpacing>,
}

impl Identifiability {
    /// The removed parameters' ids, in preference order.
    pub fn removed_ids(&self) -> Vec<ParamKey> {
        self.removed.iter().map(|r| r.id).collect()
    }
}

/// Runs the analysis for `option` at `arm` over `samples`, the servo knots
/// on the grid of `spacing`, with [`RANK_TOLERANCE`].
pub fn analyse(
    arm: &Arm<f64>,
    option: ModelOption,
    spacing: KnotSpacing,
    samples: &[Sample],
) -> Result<Identifiability, CalibError> {
    let ids = candidates(option, arm, spacing);
    let j = jacobian(&Rig::from(*arm), &ids, samples)?;
    Ok(analyse_jacobian(
        option,
        &ids,
        &j,
        &TypicalErrors::of_arm(arm),
        RANK_TOLERANCE,
    ))
}

/// The analysis on an already computed Jacobian whose columns are `ids`,
/// with the typical errors of the arm it was taken at: a column is kept
/// when its part outside the span of the kept ones exceeds `tolerance`
/// (of its unit length; [`RANK_TOLERANCE`] but where a caller has reason
/// for another) and a typical error moves the points by more than
/// [`RESOLUTION_M`] along that part.
pub fn analyse_jacobian(
    option: ModelOption,
    ids: &[ParamKey],
    j: &DMatrix<f64>,
    typical: &TypicalErrors,
    tolerance: f64,
) -> Identifiability {
    let samples = (j.nrows() / 3).max(1) as f64;
    let (effect, unit) = effects_and_units(ids, j, typical);
    // Everything below depends on the unit columns only through their inner
    // products: read it on their triangular factor, a column per parameter.
    let unit: Vec<DVector<f64>> = triangular_factor(&DMatrix::from_columns(&unit))
        .column_iter()
        .map(|c| c.into_owned())
        .collect();

    let geometric_span = geometric_span(ids, &unit, tolerance);
    let mut basis: Vec<DVector<f64>> = Vec::new();
    let mut kept = Vec::new();
    let mut kept_cols = Vec::new();
    let mut pending = Vec::new();
    for (c, &id) in ids.iter().enumerate() {
        match admit(
            &mut basis,
            &geometric_span,
            id,
            &unit[c],
            effect[c],
            tolerance,
        ) {
            Ok(()) => {
                kept.push(id);
                kept_cols.push(c);
            }
            Err(residual) => pending.push((c, id, residual)),
        }
    }

    let kept_matrix = DMatrix::from_columns(
        &kept_cols
            .iter()
            .map(|&c| unit[c].clone())
            .collect::<Vec<_>>(),
    );
    let kept_svd = kept_matrix.clone().svd(true, true);
    let removed = pending
        .into_iter()
        .map(|(c, id, residual)| {
            let confounded_with = if unit[c].norm() == 0.0 || kept.is_empty() {
                Vec::new()
            } else {
                let x = kept_svd
                    .solve(&unit[c], 1e-12)
                    .unwrap_or_else(|_| DVector::zeros(kept.len()));
                let mut with: Vec<(ParamKey, f64)> = kept
                    .iter()
                    .zip(x.iter())
                    .filter(|(_, v)| v.abs() >= 0.05)
                    .map(|(p, v)| (*p, *v))
                    .collect();
                with.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
                with
            };
            Removed {
                id,
                residual,
                confounded_with,
            }
        })
        .collect();

    // The same two tests on all columns at once: the relative one on the unit
    // columns, the resolution on the columns of displacements per typical error.
    let all = DMatrix::from_columns(&unit);
    let relative_rank = numerical_rank(&all.svd(false, false).singular_values);
    let displacements = DMatrix::from_columns(
        &unit
            .iter()
            .zip(&effect)
            .map(|(u, e)| u * (e * samples.sqrt()))
            .collect::<Vec<_>>(),
    );
    let resolved_rank = displacements
        .svd(false, false)
        .singular_values
        .iter()
        .filter(|&&s| s > RESOLUTION_M * samples.sqrt())
        .count();
    let svd_rank = relative_rank.min(resolved_rank);
    let kept_sv = &kept_svd.singular_values;
    let kept_condition = if !kept_sv.is_empty() {
        kept_sv.max() / kept_sv.min()
    } else {
        1.0
    };
    Identifiability {
        option,
        kept,
        removed,
        svd_rank,
        kept_condition,
        knots: servo_knots::spacing_of(ids),
    }
}

/// The parameters of `new` that join `kept` at a later stage of the fit
/// (play widths at the fit's start, the refresh at its estimate), `j`'s
/// columns being `kept` then `new` over the fitted poses: each new column is
/// judged in order exactly as [`analyse_jacobian`] judges a column after
/// the kept ones, against the span of the kept columns and of the new ones
/// admitted before it. The kept ones are the fit's already and are not
/// judged again: the stage updates the analysis with what it adds instead
/// of starting over.
pub fn joining(
    kept: &[ParamKey],
    new: &[ParamKey],
    j: &DMatrix<f64>,
    typical: &TypicalErrors,
    tolerance: f64,
) -> Vec<ParamKey> {
    let ids: Vec<ParamKey> = kept.iter().chain(new).copied().collect();
    let (effect, unit) = effects_and_units(&ids, j, typical);
    let geometric_span = geometric_span(&ids, &unit, tolerance);
    let mut basis = orthonormal_span(unit[..kept.len()].iter(), tolerance);
    (kept.len()..ids.len())
        .filter(|&c| {
            admit(
                &mut basis,
                &geometric_span,
                ids[c],
                &unit[c],
                effect[c],
                tolerance,
            )
            .is_ok()
        })
        .map(|c| ids[c])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{key as name, rigid_nominal, small_samples, test_arm};

    /// A later stage's update (the kept columns, then what it adds) admits
    /// exactly what a full recomputation over all the columns keeps of the
    /// added ones, given the same kept ones, for several places the stage
    /// could split the columns: on the model with servo curves (geometry,
    /// springs, knots) and on few poses, where many columns are dependent.
    #[test]
    fn a_stage_update_matches_the_full_recomputation() {
        let arm = test_arm();
        for (option, poses) in [
            (ModelOption::ElastoKinematicServo, 40),
            (ModelOption::ElastoKinematic, 6),
        ] {
            let ids = candidates(option, &arm, KnotSpacing::Deg50);
            let j = jacobian(&Rig::from(arm), &ids, &small_samples(poses)).unwrap();
            let typical = TypicalErrors::of_arm(&arm);
            let full = analyse_jacobian(option, &ids, &j, &typical, RANK_TOLERANCE);
            let mut admitted = 0;
            for split in [ids.len() / 4, ids.len() / 2, 3 * ids.len() / 4] {
                let (first, added) = ids.split_at(split);
                let kept: Vec<ParamKey> = full
                    .kept
                    .iter()
                    .filter(|k| first.contains(k))
                    .copied()
                    .collect();
                // The stage's columns: the kept ones, then the added ones.
                let columns: Vec<usize> = kept
                    .iter()
                    .chain(added)
                    .map(|k| ids.iter().position(|i| i == k).unwrap())
                    .collect();
                let updated = joining(
                    &kept,
                    added,
                    &j.select_columns(&columns),
                    &typical,
                    RANK_TOLERANCE,
                );
                let recomputed: Vec<ParamKey> = full
                    .kept
                    .iter()
                    .filter(|k| added.contains(k))
                    .copied()
                    .collect();
                admitted += recomputed.len();
                assert_eq!(
                    updated, recomputed,
                    "{option}, {poses} poses: split at {split}"
                );
            }
            // Not vacuous: the added columns carry something somewhere.
            assert!(admitted > 0, "{option}: nothing added at any split");
        }
    }

    #[test]
    fn removes_tool_rotation_and_known_redundancies() {
        let samples = small_samples(40);
        let a = analyse(
            &rigid_nominal(),
            ModelOption::ElastoKinematic,
            KnotSpacing::FINEST,
            &samples,
        )
        .unwrap();
        // The tool point is the tool frame's origin: its rotation cannot be seen.
        for p in ["tool.roll", "tool.pitch", "tool.yaw"] {
            assert!(
                a.removed_ids().contains(&name(p)),
                "{p} should be removed: {:?}",
                a.removed
            );
        }
        // On a level base, joint 1's theta and d duplicate the base's yaw and z,
        // which are kept: they hold every base pose.
        let theta = a
            .removed
            .iter()
            .find(|r| r.id == name("j1.theta"))
            .expect("j1.theta removed");
        assert_eq!(theta.confounded_with[0].0, name("base.yaw"));
        for p in ["base.z", "base.yaw", "tool.x", "tool.y", "tool.z"] {
            assert!(a.kept.contains(&name(p)), "{p} kept: {:?}", a.removed);
        }
        // Gravity makes no torque about joint 1's vertical axis.
        assert!(a.removed_ids().contains(&name("k1")));
        assert_eq!(a.kept.len(), a.svd_rank, "greedy and SVD ranks agree");
        assert!(a.kept_condition < 1e4);
    }

    /// With the tool point on joint 6's axis, twisting joint 6 moves it only
    /// through the second-order sag (nanometres): k6 is below the
    /// resolution. Two centimetres off the axis it is a lever like any other.
    #[test]
    fn every_compliance_with_a_lever_on_a_tilted_compliant_arm_is_identifiable() {
        let on_axis = analyse(
            &test_arm(),
            ModelOption::Elastic,
            KnotSpacing::FINEST,
            &small_samples(20),
        )
        .unwrap();
        assert_eq!(on_axis.removed_ids(), [name("k6")], "{:?}", on_axis.removed);
        assert!(on_axis.removed[0].confounded_with.is_empty());
        let mut off_axis = test_arm();
        off_axis.tool.xyz[0] = 0.02;
        let a = analyse(
            &off_axis,
            ModelOption::Elastic,
            KnotSpacing::FINEST,
            &small_samples(20),
        )
        .unwrap();
        assert_eq!(a.kept.len(), 7, "{:?}", a.removed);
    }
}
