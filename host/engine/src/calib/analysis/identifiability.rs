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

use std::sync::{Mutex, PoisonError};

use model::Arm;
use model::params::{ParamKind, ParamPart};
use nalgebra::{DMatrix, DVector};

use crate::calib::analysis::jacobian::jacobian;
use crate::calib::analysis::observability::ColumnScale;
use crate::calib::analysis::triangular::triangular_factor;
use crate::calib::parameters::option::candidates;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::{self, KnotSpacing};
use crate::calib::{CalibError, ModelOption, Rig, Sample};

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

/// Typical sizes of the parameters' errors on one arm: 1 mm, 1 mrad, for
/// compliances 0.01 rad/Nm and for softenings 0.1 1/Nm on the bundled arm,
/// carried to another arm by the ratio of gravity torques ([`crate::scale`]):
/// the same sag angle, so a UR10's shoulder, a hundred times the torque,
/// gets 1e-4 rad/Nm; and the same change of compliance over the arm's
/// torques (`s |tau|`), so 1e-3 1/Nm there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TypicalErrors {
    /// A joint compliance's, rad/Nm.
    joint_compliance: f64,
    /// The base compliance's, rad/Nm.
    base_compliance: f64,
    /// A joint spring's softening, 1/Nm.
    joint_softening: f64,
    /// The base spring's softening, 1/Nm.
    base_softening: f64,
}

impl TypicalErrors {
    /// The typical errors of `arm`'s parameters.
    pub fn of_arm(arm: &Arm<f64>) -> Self {
        let [joints, base] = crate::scale::torque_ratio_to_bundled(arm);
        Self {
            joint_compliance: 1e-2 * joints,
            base_compliance: 1e-2 * base,
            joint_softening: 0.1 * joints,
            base_softening: 0.1 * base,
        }
    }

    /// A typical size of an error of `key`.
    pub fn of(&self, key: ParamKey) -> f64 {
        match key {
            ParamKey::Softening { spring: 0 } => self.base_softening,
            ParamKey::Softening { .. } => self.joint_softening,
            _ => match key.kind() {
                ParamKind::Length | ParamKind::Angle => 1e-3,
                ParamKind::Compliance => match key {
                    ParamKey::Arm(id) if id.part() == ParamPart::BaseCompliance => {
                        self.base_compliance
                    }
                    _ => self.joint_compliance,
                },
            },
        }
    }
}

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

/// Per column of `j` (columns `ids`): what a typical error of the
/// parameter moves the points by (RMS, m), and the column normalised — or
/// zero when that effect is below [`RESOLUTION_M`] (a parameter that moves
/// no point by a resolution has no effect a tracker could see: what is
/// left is rounding and load coupling).
fn effects_and_units(
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
fn geometric_span(ids: &[ParamKey], unit: &[DVector<f64>], tolerance: f64) -> Vec<DVector<f64>> {
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
fn admit(
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
fn orthonormal_span<'a>(
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

/// What the arm's structure lets positions identify, worked out once per
/// option and knot spacing and kept for every later check of the same arm
/// and load: the parameters the -100/0/+100° grid of every joint identifies
/// (each level within the joint's limits; servo knots on the spacing
/// checked) is what positions can reveal at all.
pub struct Structures {
    nominal: Arm<f64>,
    load_kg: f64,
    known: Mutex<Vec<Structure>>,
}

/// The parameters the grid identifies for an option and knot spacing.
type Structure = ((ModelOption, KnotSpacing), Vec<ParamKey>);

impl Structures {
    /// The structures of `nominal` under `load_kg`, none worked out yet.
    pub fn new(nominal: &Arm<f64>, load_kg: f64) -> Self {
        Self {
            nominal: *nominal,
            load_kg,
            known: Mutex::new(Vec::new()),
        }
    }

    /// The load the structures are worked out under, kg.
    pub fn load_kg(&self) -> f64 {
        self.load_kg
    }

    /// Refuses a measured pose set that identifies fewer of
    /// `measured.option`'s parameters than the arm's structure allows.
    pub fn check(&self, measured: &Identifiability) -> Result<(), CalibError> {
        match self.missing(measured)? {
            (_, Some(e)) => Err(e),
            _ => Ok(()),
        }
    }

    /// The parameters the arm's structure identifies for
    /// `measured.option` that the measured poses leave undetermined, and
    /// the refusal [`Structures::check`] makes of them (`None` when none is
    /// missing).
    pub fn missing(
        &self,
        measured: &Identifiability,
    ) -> Result<(Vec<ParamKey>, Option<CalibError>), CalibError> {
        let spacing = measured.knots.unwrap_or(KnotSpacing::FINEST);
        let structural = self.kept(measured.option, spacing)?;
        // Compared over the rig's own parameters: further targets' tool points
        // are the measurements' own, the grid has none.
        let own_kept = measured
            .kept
            .iter()
            .filter(|p| !matches!(p, ParamKey::TargetTool { .. }))
            .count();
        if own_kept >= structural.len() {
            return Ok((Vec::new(), None));
        }
        let missing: Vec<ParamKey> = structural
            .iter()
            .filter(|p| !measured.kept.contains(p))
            .copied()
            .collect();
        let names: Vec<String> = missing.iter().map(|p| p.to_string()).collect();
        let refusal = CalibError::Unidentifiable {
            option: measured.option.name().into(),
            identified: own_kept,
            structural: structural.len(),
            missing: names.join(", "),
        };
        Ok((missing, Some(refusal)))
    }

    /// The parameters the grid identifies for `option` on `spacing`: worked
    /// out the first time they are asked for.
    fn kept(&self, option: ModelOption, spacing: KnotSpacing) -> Result<Vec<ParamKey>, CalibError> {
        if let Some((_, kept)) = self
            .known
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .iter()
            .find(|(k, _)| *k == (option, spacing))
        {
            return Ok(kept.clone());
        }
        // Each level within the joint's limits: the grid the arm can reach
        // (a slide's levels are its ends and its zero).
        let within = |mut q: model::PerJoint<f64>| {
            for (v, joint) in q.iter_mut().zip(self.nominal.joints.iter()) {
                *v = v.clamp(joint.limits[0], joint.limits[1]);
            }
            q
        };
        let grid: Vec<Sample> = crate::plan::Levels::paper()
            .grid(self.nominal.joints.len())
            .map(|p| Sample {
                id: p.id,
                q: within(p.q),
                load_kg: self.load_kg,
                target: 0,
                approach: lrmcal_core::dataset::from_home(p.q.len()),
            })
            .collect();
        let kept = analyse(&self.nominal, option, spacing, &grid)?.kept;
        self.known
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(((option, spacing), kept.clone()));
        Ok(kept)
    }
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

    /// One pose cannot identify what the grid identifies: the check names
    /// the parameters it leaves undetermined; the grid itself passes.
    #[test]
    fn a_pose_set_must_identify_what_the_grid_does() {
        let nominal = test_arm();
        let one = analyse(
            &nominal,
            ModelOption::Elastic,
            KnotSpacing::FINEST,
            &small_samples(1),
        )
        .unwrap();
        let structures = Structures::new(&nominal, 0.0663);
        let e = structures.check(&one).unwrap_err();
        assert!(
            matches!(e, CalibError::Unidentifiable { structural: 6, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("undetermined"), "{e}");
        let grid: Vec<Sample> = crate::plan::Levels::paper()
            .grid(6)
            .map(|p| Sample {
                id: p.id,
                q: p.q,
                load_kg: 0.0663,
                target: 0,
                approach: lrmcal_core::dataset::from_home(6),
            })
            .collect();
        let all = analyse(&nominal, ModelOption::Elastic, KnotSpacing::FINEST, &grid).unwrap();
        assert!(structures.check(&all).is_ok());
    }
}
