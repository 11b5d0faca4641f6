//! The tool point in registration: for a given rotation of the motion the
//! measured point is linear in the tool point and the translation, solved by
//! least squares when the last link turns enough.

use model::Arm;
use nalgebra::{Matrix3, Vector3};

use crate::calib::{CalibError, Rig, Sample};

use super::MIN_TOOL_TURN;

/// Frame 6 of one sample, origin and rotation: the tool point `t` is at `o + A t`.
pub(super) type Flange = (Vector3<f64>, Matrix3<f64>);

/// The nominal arm's predicted points, deflected under `gravity_arm` (arm frame).
pub(super) fn predicted(
    nominal: &Arm<f64>,
    gravity_arm: Vector3<f64>,
    samples: &[Sample],
) -> Result<Vec<Vector3<f64>>, CalibError> {
    let mut arm = *nominal;
    arm.gravity = gravity_arm.into();
    Rig::from(arm).tool_points(samples)
}

/// Frame 6's origin `o` and rotation `A` of each sample in `arm`'s world
/// frame under `gravity_arm`: the tool point `t` is at `o + A t`. The
/// deflection does not depend on `t`, so the map is affine and three
/// evaluations at unit tool points give it exactly.
pub(super) fn flange_poses(
    arm: &Arm<f64>,
    gravity_arm: Vector3<f64>,
    samples: &[Sample],
) -> Result<Vec<Flange>, CalibError> {
    let at = |t: Vector3<f64>| {
        let mut a = *arm;
        a.tool.xyz = t.into();
        predicted(&a, gravity_arm, samples)
    };
    let origin = at(Vector3::zeros())?;
    let axes = [at(Vector3::x())?, at(Vector3::y())?, at(Vector3::z())?];
    Ok(origin
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let a = Matrix3::from_columns(&[axes[0][i] - o, axes[1][i] - o, axes[2][i] - o]);
            (*o, a)
        })
        .collect())
}

/// What one linear solve for the tool point found.
pub(super) struct ToolSolve {
    /// The tool point `t` (frame 6) and the motion's translation `b`; `None`
    /// when the turn is below [`MIN_TOOL_TURN`].
    pub(super) found: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The turn of the last link over the kept points.
    pub(super) turn: f64,
}

/// The tool point and translation that put the flange poses nearest the
/// kept measurements for the motion's rotation `r` (module docs).
pub(super) fn solve_tool(
    flanges: &[Flange],
    measured: &[Vector3<f64>],
    keep: &[bool],
    r: &Matrix3<f64>,
) -> ToolSolve {
    let kept: Vec<usize> = (0..flanges.len()).filter(|&i| keep[i]).collect();
    let mut m = nalgebra::DMatrix::zeros(3 * kept.len(), 6);
    let mut rhs = nalgebra::DVector::zeros(3 * kept.len());
    for (row, &i) in kept.iter().enumerate() {
        let (o, a) = &flanges[i];
        m.fixed_view_mut::<3, 3>(3 * row, 0).copy_from(a);
        m.fixed_view_mut::<3, 3>(3 * row, 3)
            .copy_from(&Matrix3::identity());
        rhs.fixed_rows_mut::<3>(3 * row)
            .copy_from(&(r.transpose() * measured[i] - o));
    }
    let svd = m.svd(true, true);
    let turn = svd.singular_values.min() / (kept.len().max(1) as f64).sqrt();
    let found = if turn.is_nan() || turn < MIN_TOOL_TURN {
        None
    } else {
        svd.solve(&rhs, 0.0).ok().map(|x| {
            let t = Vector3::new(x[0], x[1], x[2]);
            let c = Vector3::new(x[3], x[4], x[5]);
            (t, r * c)
        })
    };
    ToolSolve { found, turn }
}
