//! The identification Jacobian: how each measured tool point moves per unit
//! change of each free parameter, and per unit of each commanded joint angle,
//! exact through the elastic deflection.
//!
//! **Every geometric parameter is a small rigid motion.** A DH offset
//! `theta_k` turns everything beyond joint `k` about axis `z(k-1)`, `d_k`
//! slides it along that axis, `a_k` along `x(k)`, `alpha_k` turns it about
//! `x(k)`; the base's six move the whole arm, the tool's move the payload
//! (and, for `tool.x/y/z`, the measured point). A moved point `x` goes
//! `ω × x + v` (a [`Twist`]), so its derivative is one cross product.
//!
//! **The deflection by the implicit function theorem.** The deflected state
//! `s = (qa, beta)` solves `s = (q, 0) + D T(s, p)` (`D` the compliances,
//! `T` the gravity torques of the six joints and the base tilt, `p` the
//! parameters). Differentiating, `(I − D ∂T/∂s) ds = D ∂T/∂p dp + dD T`: one
//! 7×7 solve per pose. `∂T/∂s` and `∂T/∂p` are the torques' derivatives
//! under the same rigid motions (each joint angle and the base tilt is one
//! too): a torque about an axis that moves with the motion only changes
//! because gravity does not turn with it (`−a · (r × (ω × g))`), one about an
//! axis that stays changes by the moments of the masses that move
//! (`a · ((ω × C + M v) × g)`). With suffix sums of the masses and their
//! moments each entry costs a few cross products: a pose's 43 columns cost
//! about as much as two evaluations of the model, where central differences
//! took 86.
//!
//! A spring may soften with its torque, `k (1 + s |τ|) τ`: then `D` holds
//! each spring's rate `k (1 + 2 s |τ|)`, a compliance's column is
//! `(1 + s |τ|) τ` per unit and a softening's `k |τ| τ`.
//!
//! **Joint-angle columns.** A sample's joints stand where its command drives
//! them ([`Rig::standing_angles`]: through the rig's servo curves, with its
//! backlash). The same solve gives `d point / d q` for those angles
//! ([`Slopes::joints`]): a parameter that acts through a joint's angle alone
//! (a servo curve's knot, backlash) has that column times its own weight at
//! the pose (`calib::joint_columns`).
//!
//! The test module checks every column against central differences of the
//! model itself.

mod state;

use model::SolverOptions;
use model::params::{ParamKind, ParamPart};
use nalgebra::{DMatrix, Matrix3xX, Vector3};
use rayon::prelude::*;

use crate::calib::parameters::joint_columns;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::fit_start;
use crate::calib::parameters::targets::{chain_of, deflection_error, same_pose, target_chains};
use crate::calib::{CalibError, Rig, Sample};
use state::{State, Twist};

/// Samples per share of the work on another core (a few ms of it), in
/// whole poses.
const PARALLEL_CHUNK: usize = 1024;

/// One sample's rows: its measured point's derivatives with respect to the
/// parameters and to the commanded joint angles.
type SampleSlopes = (Matrix3xX<f64>, Matrix3xX<f64>);

/// The exact slopes of the measured points of a set of samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Slopes {
    /// `3 n × m`: rows `3k..3k+3` for sample `k` (x y z), a column per key
    /// asked for, m per unit of the key.
    pub params: DMatrix<f64>,
    /// Per sample, the measured point's derivative with respect to the
    /// commanded joint angles (`3 × n`), the deflection included, m/rad.
    pub joints: Vec<Matrix3xX<f64>>,
}

/// The `3 n × m` Jacobian of the measured points of `samples` (rows `3k..3k+3`
/// for sample `k`, x y z) with respect to `ids` (columns), evaluated at
/// `rig`, in m per unit of each parameter.
pub fn jacobian(
    rig: &Rig,
    ids: &[ParamKey],
    samples: &[Sample],
) -> Result<DMatrix<f64>, CalibError> {
    Ok(slopes(rig, ids, samples)?.params)
}

/// [`jacobian`] and the joint-angle slopes of every sample, in one pass.
/// Sets of thousands of samples (a candidate pool) are worked on all cores,
/// each sample's rows alone, so the result does not depend on how they are
/// shared out; a fit's few hundred cost less than waking another thread.
pub fn slopes(rig: &Rig, ids: &[ParamKey], samples: &[Sample]) -> Result<Slopes, CalibError> {
    // Servo-knot keys move the curves on their grid (the same map).
    let rig = &fit_start(rig, ids);
    let chains = target_chains(rig);
    // Samples of one pose (a camera's corners) share its deflection and
    // its solve: one group each.
    let mut groups: Vec<&[Sample]> = Vec::new();
    let mut rest = samples;
    while let Some(first) = rest.first() {
        let len = rest.iter().take_while(|s| same_pose(first, s)).count();
        let (group, after) = rest.split_at(len);
        groups.push(group);
        rest = after;
    }
    let chunk = (PARALLEL_CHUNK * groups.len() / samples.len().max(1)).max(1);
    let per_group: Vec<Vec<SampleSlopes>> = groups
        .par_iter()
        .with_min_len(chunk)
        .map(|group| pose_slopes(rig, &chains, ids, group))
        .collect::<Result<_, _>>()?;
    let mut params = DMatrix::zeros(3 * samples.len(), ids.len());
    let mut joints = Vec::with_capacity(samples.len());
    for (k, (p, j)) in per_group.into_iter().flatten().enumerate() {
        params.rows_mut(3 * k, 3).copy_from(&p);
        joints.push(j);
    }
    Ok(Slopes { params, joints })
}

/// The axes of a `Trans · Rz(yaw) Ry(pitch) Rx(roll)` frame's roll, pitch and
/// yaw, in its parent's frame: the derivative of each angle turns the frame
/// about one of them.
fn rpy_axes([_, pitch, yaw]: [f64; 3]) -> [Vector3<f64>; 3] {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    [
        Vector3::new(cy * cp, sy * cp, -sp),
        Vector3::new(-sy, cy, 0.0),
        Vector3::z(),
    ]
}

/// Rows of each sample of `group` (samples of one pose, [`same_pose`]):
/// its measured point's derivatives with respect to `ids` and to the
/// commanded joint angles. The deflection, its solve and each parameter's
/// change of the state are the pose's, worked once; the measured point is
/// each sample's own.
fn pose_slopes(
    rig: &Rig,
    chains: &[model::Chain<f64>],
    ids: &[ParamKey],
    group: &[Sample],
) -> Result<Vec<SampleSlopes>, CalibError> {
    let Some(first) = group.first() else {
        return Ok(Vec::new());
    };
    // The deflection does not depend on which target is measured.
    let d = chain_of(chains, first)?
        .deflect(
            &rig.standing_angles(first),
            first.load_kg,
            &SolverOptions::default(),
        )
        .map_err(|e| deflection_error(first, e.to_string()))?;
    let state = State::new(
        chain_of(chains, first)?,
        rig,
        d.frames.frames,
        first.load_kg,
    );
    let n = state.joints;
    let twists: Vec<Twist> = (0..=n).map(|e| state.state_twist(e)).collect();
    // Each state coordinate's motion of the bodies beyond it, its response
    // included: `ds = (I − D ∂T/∂s)⁻¹ D ∂T/∂p dp` moves a point by `P ds`
    // (`P` the state's twists' velocities at it), so a unit change of the
    // right-hand side's coordinate `e` moves it as the twist
    // `Σ_k (I − D ∂T/∂s)⁻¹_ke twist_k` does, whichever point it is.
    let responses: Vec<Motion> = if state.rigid() {
        twists.iter().map(Motion::of).collect()
    } else {
        let mut h = DMatrix::<f64>::identity(n + 1, n + 1);
        for (e, t) in twists.iter().enumerate() {
            for (row, slope) in state.torque_slopes(t).iter().enumerate() {
                h[(row, e)] -= state.rate[row] * slope;
            }
        }
        let inverse = h.try_inverse().ok_or_else(|| {
            deflection_error(
                first,
                "the deflection is singular here: its fixed point does not move smoothly with the parameters".into(),
            )
        })?;
        (0..=n)
            .map(|e| {
                twists.iter().enumerate().fold(Motion::NONE, |sum, (k, t)| {
                    sum.plus(&Motion::of(t), inverse[(k, e)])
                })
            })
            .collect()
    };
    let torques = state.torques();
    let last = state.frames[n];
    let per_target = |part: ParamPart| {
        rig.board.is_none() && matches!(part, ParamPart::Tool { axis } if axis < 3)
    };
    // Each column's motion at the pose, the same for every target but
    // where a target's own offset decides.
    let columns: Vec<Column> = ids
        .iter()
        .map(|id| match *id {
            ParamKey::Arm(pid) => {
                let part = pid.part();
                match pid.kind() {
                    ParamKind::Compliance => {
                        // k1..kn then k0, as the state.
                        let e = match part {
                            ParamPart::Compliance { joint } => joint,
                            _ => n,
                        };
                        let per_unit = (1.0 + state.softening[e] * torques[e].abs()) * torques[e];
                        Column::Moves(Motion::NONE.plus(&responses[e], per_unit))
                    }
                    ParamKind::Length | ParamKind::Angle => {
                        let (twist, direct) = arm_twist(rig, &state, part, first.target);
                        // A level base turns gravity with it: the arm
                        // moves rigidly, its torques unchanged.
                        let with_gravity = rig.level_base.is_some()
                            && matches!(part, ParamPart::Base { axis } if axis >= 3);
                        let response = if state.rigid() || with_gravity {
                            Motion::NONE
                        } else {
                            let dt = state.torque_slopes(&twist);
                            responses
                                .iter()
                                .enumerate()
                                .fold(Motion::NONE, |sum, (e, r)| {
                                    sum.plus(r, state.rate[e] * dt[e])
                                })
                        };
                        if per_target(part) {
                            Column::ToolOffset(response, part)
                        } else {
                            let own = match direct {
                                Some(v) => Motion {
                                    w: Vector3::zeros(),
                                    v,
                                },
                                None => Motion::of(&twist),
                            };
                            Column::Moves(own.plus(&response, 1.0))
                        }
                    }
                }
            }
            ParamKey::TargetTool { target, axis } => Column::Target {
                target: usize::from(target),
                along: last
                    .rotation
                    .matrix()
                    .column(usize::from(axis))
                    .into_owned(),
            },
            ParamKey::Softening { spring } => {
                // s0 is the base's (state n), s1..sn the joints'.
                let e = match usize::from(spring) {
                    0 => n,
                    j => j - 1,
                };
                let per_unit = state.compliance[e] * torques[e].abs() * torques[e];
                Column::Moves(Motion::NONE.plus(&responses[e], per_unit))
            }
            // A servo knot's or a play's share of its joint's angle: the
            // pose's command and approach.
            ParamKey::ServoKnot { .. } | ParamKey::Backlash { .. } => {
                match joint_columns::joint_of(*id) {
                    Some(j) => Column::Moves(
                        Motion::NONE.plus(&responses[j], joint_columns::weight(rig, *id, first)),
                    ),
                    None => Column::Still,
                }
            }
            // The lens moves the pixel, not the point (below).
            ParamKey::Lens { .. } => Column::Still,
        })
        .collect();
    group
        .iter()
        .map(|sample| {
            let tool_point = chain_of(chains, sample)?.tool_point;
            let point = rig.measured_point(sample, &last, &tool_point);
            let mut out = Matrix3xX::zeros(ids.len());
            for (col, column) in columns.iter().enumerate() {
                let slope = match column {
                    Column::Moves(motion) => motion.velocity(&point),
                    Column::ToolOffset(response, part) => {
                        let (_, direct) = arm_twist(rig, &state, *part, sample.target);
                        direct.unwrap_or_else(Vector3::zeros) + response.velocity(&point)
                    }
                    Column::Target { target, along } if *target == sample.target => *along,
                    Column::Target { .. } | Column::Still => continue,
                };
                out.set_column(col, &slope);
            }
            // What the instrument measures of the point (a camera: its pixel).
            let seen = rig.observe(sample, &last, &point)?;
            let mut rows = seen.slope * out;
            if let Some(lens) = &seen.lens_slope {
                for (col, id) in ids.iter().enumerate() {
                    if let ParamKey::Lens { field } = *id {
                        rows.fixed_view_mut::<2, 1>(0, col)
                            .copy_from(&lens.column(usize::from(field)));
                    }
                }
            }
            let joints = Matrix3xX::from_fn(n, |r, e| responses[e].velocity(&point)[r]);
            Ok((rows, seen.slope * joints))
        })
        .collect()
}

/// How a change moves every point of the bodies beyond it at a pose,
/// `ω × x + v`: a rigid motion, the deflection's response included.
#[derive(Clone, Copy, Debug)]
struct Motion {
    w: Vector3<f64>,
    v: Vector3<f64>,
}

impl Motion {
    /// No motion.
    const NONE: Self = Self {
        w: Vector3::new(0.0, 0.0, 0.0),
        v: Vector3::new(0.0, 0.0, 0.0),
    };

    fn of(t: &Twist) -> Self {
        Self { w: t.w, v: t.v }
    }

    /// This motion and `scale` times `other`.
    fn plus(self, other: &Self, scale: f64) -> Self {
        Self {
            w: self.w + other.w * scale,
            v: self.v + other.v * scale,
        }
    }

    fn velocity(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.w.cross(x) + self.v
    }
}

/// A parameter's column at a pose, read at each of its samples' points.
enum Column {
    /// Moves the measured point as the motion does, whichever target it is.
    Moves(Motion),
    /// A tool offset with a tracker: its deflection's response, and the
    /// offset's own motion of the sample's target (target 0's point alone).
    ToolOffset(Motion, ParamPart),
    /// A target's own tool offset: along `along` for that target's samples.
    Target { target: usize, along: Vector3<f64> },
    /// Moves no point.
    Still,
}

/// The rigid motion of the arm's geometric parameter `part` at `state`,
/// and the measured point's own motion when it is not the twist's (the tool
/// frame's parameters move the payload, and the point of target 0 only by
/// its translation).
fn arm_twist(
    rig: &Rig,
    state: &State,
    part: ParamPart,
    target: usize,
) -> (Twist, Option<Vector3<f64>>) {
    let f = &state.frames;
    let n = state.joints;
    let column = |frame: usize, axis: usize| f[frame].rotation.matrix().column(axis).into_owned();
    match part {
        ParamPart::Dh { joint, field } => {
            let k = joint + 1;
            let (z, before) = (column(k - 1, 2), f[k - 1].translation.vector);
            // `a` and `alpha` act along and about x before Hayati's twist
            // `Ry(beta)`: `c x_k + s z_k` in frame k's axes.
            let (sb, cb) = rig.arm.joints[joint].beta.sin_cos();
            let x = column(k, 0) * cb + column(k, 2) * sb;
            let origin = f[k].translation.vector;
            let twist = match field {
                0 => Twist::about(z, &before, k),
                1 => Twist::along(z, k),
                2 => Twist::along(x, k),
                3 => Twist::about(x, &origin, k),
                _ => Twist::about(column(k, 1), &origin, k),
            };
            (twist, None)
        }
        ParamPart::Base { axis } if axis < 3 => (Twist::along(Vector3::ith(axis, 1.0), 0), None),
        ParamPart::Base { axis } => {
            let axis = rpy_axes(rig.arm.base.rpy)[axis - 3];
            let origin = Vector3::from(rig.arm.base.xyz);
            (Twist::about(axis, &origin, 0), None)
        }
        ParamPart::Tool { axis } if axis < 3 => {
            let axis = column(n, axis);
            // Target 0's point is the tool frame's origin; a board's corners
            // move with its frame.
            let moves = target == 0 || rig.board.is_some();
            let direct = if moves { axis } else { Vector3::zeros() };
            (Twist::along(axis, state.payload()), Some(direct))
        }
        ParamPart::Tool { axis } => {
            let last = &f[n];
            let local = rpy_axes(rig.arm.tool.rpy)[axis - 3];
            let origin = last.rotation * Vector3::from(rig.arm.tool.xyz) + last.translation.vector;
            // A turn of the tool frame moves the payload; it moves the
            // measured point too when that is a board's corner (not the
            // frame's origin).
            let direct = rig.board.is_none().then(Vector3::zeros);
            (
                Twist::about(last.rotation * local, &origin, state.payload()),
                direct,
            )
        }
        // A spring moves nothing rigidly: its column comes from the state.
        ParamPart::Compliance { .. } | ParamPart::BaseCompliance => {
            (Twist::along(Vector3::zeros(), 0), Some(Vector3::zeros()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::ModelOption;
    use crate::calib::parameters::params::Key as _;
    use crate::calib::parameters::targets::Targets;
    use crate::calib::testing::{small_samples, test_arm};
    use lrmcal_core::dataset::TargetName;
    use model::testing::TEST_ARM_JOINTS as JOINTS;

    /// Central differences of the model itself, the reference the exact
    /// slopes are held to: step `h = eps^(1/3) · max(|value|, typical)`
    /// (0.1 m, 1 rad, 0.1 rad/Nm) balances the O(h²) truncation against the
    /// O(eps/h) rounding; a compliance nearer zero than its step is
    /// differenced one-sidedly upwards (second order), never below zero.
    fn central_differences(rig: &Rig, ids: &[ParamKey], samples: &[Sample]) -> DMatrix<f64> {
        // A camera's pixels at the scale of the point differenced about.
        let scales: Vec<f64> = rig
            .observations(samples)
            .unwrap()
            .iter()
            .map(|o| o.scale)
            .collect();
        let at = |id: ParamKey, delta: f64| {
            let mut r = rig.clone();
            *id.slot(&mut r) += delta;
            DMatrix::from_iterator(
                3 * samples.len(),
                1,
                r.observations(samples)
                    .unwrap()
                    .iter()
                    .zip(&scales)
                    .flat_map(|(o, scale)| (o.value * *scale).iter().copied().collect::<Vec<_>>()),
            )
        };
        let mut j = DMatrix::zeros(3 * samples.len(), ids.len());
        for (c, &id) in ids.iter().enumerate() {
            let value = id.value(rig);
            let typical = match id.kind() {
                ParamKind::Length | ParamKind::Compliance => 0.1,
                ParamKind::Angle => 1.0,
            };
            let h = f64::EPSILON.cbrt() * value.abs().max(typical);
            let column = if id.kind() == ParamKind::Compliance && value < h {
                (at(id, 0.0) * -1.5 + at(id, h) * 2.0 - at(id, 2.0 * h) * 0.5) / h
            } else {
                (at(id, h) - at(id, -h)) / (2.0 * h)
            };
            j.set_column(c, &column.column(0));
        }
        j
    }

    /// A rig on which every column is alive: the compliant, tilted test arm
    /// with its payload's centre off the tool point and a turned tool frame
    /// (so the tool's rotations move the payload), and a second target.
    fn lively_rig() -> Rig {
        let mut arm = test_arm();
        arm.payload_com = [0.01, -0.02, 0.015];
        arm.tool.rpy = [0.1, -0.2, 0.3];
        arm.base_compliance = 0.05;
        arm.base.xyz = [0.1, -0.05, 0.02];
        let names: Vec<TargetName> = ["a", "b"]
            .iter()
            .map(|n| TargetName::from(n).unwrap())
            .collect();
        let mut rig = Rig::new(arm, Targets::named_as(&names));
        rig.tools[0] += Vector3::new(0.01, 0.02, -0.01);
        rig
    }

    fn lively_samples() -> Vec<Sample> {
        let mut samples = small_samples(6);
        for (k, s) in samples.iter_mut().enumerate() {
            s.target = k % 2;
            // No load, the paper's 66.3 g, and a heavy 0.4 kg.
            s.load_kg = [0.0, 0.0663, 0.4][k % 3];
        }
        samples
    }

    fn all_keys(rig: &Rig) -> Vec<ParamKey> {
        let mut ids: Vec<ParamKey> = model::ParamId::all(JOINTS).map(ParamKey::Arm).collect();
        ids.extend(rig.tool_keys());
        ids.extend(rig.camera.iter().flat_map(|c| c.lens_keys()));
        ids
    }

    /// Every column, on several poses and loads, agrees with central
    /// differences to 1e-6 of the column's size. The differences' own error
    /// is their truncation (`h²`) plus the deflection solver's stopping noise
    /// (about 1e-14 rad) over the step: most columns agree to 1e-9, the
    /// worst (k6, whose joint carries a few mNm) to 3e-7, and to 2e-8 with
    /// a ten times larger step, so that is the differences' noise. A wrong
    /// term (a torque feedback missed, a sign) is off by percents.
    #[test]
    fn exact_columns_match_central_differences() {
        let rig = lively_rig();
        let samples = lively_samples();
        let ids = all_keys(&rig);
        let exact = jacobian(&rig, &ids, &samples).unwrap();
        let reference = central_differences(&rig, &ids, &samples);
        let mut worst = 0.0f64;
        for (c, id) in ids.iter().enumerate() {
            let size = reference.column(c).amax();
            let diff = (exact.column(c) - reference.column(c)).amax();
            assert!(size > 1e-6, "{id}: a column of the lively rig is dead");
            assert!(
                diff <= 1e-6 * size,
                "{id}: exact vs differences {diff:e}, size {size:e}"
            );
            worst = worst.max(diff / size);
        }
        eprintln!("worst relative difference {worst:e}");
    }

    /// A camera measuring a board's corners: every column, the tool
    /// frame's turns moving the corners too, agrees with central
    /// differences of the pixels as closely, with the base standing level
    /// (gravity turning with it) too.
    #[test]
    fn camera_columns_match_central_differences_of_the_pixels() {
        use crate::calib::parameters::camera::RigCamera;
        use nalgebra::{IsometryMatrix3, Rotation3, Translation3};
        let lively = lively_rig();
        let names: Vec<TargetName> = ["c0", "c1", "c2"]
            .iter()
            .map(|n| TargetName::from(n).unwrap())
            .collect();
        // The camera 2 m out along x, looking back at the arm.
        let camera_in_world = IsometryMatrix3::from_parts(
            Translation3::new(2.0, 0.1, 0.3),
            Rotation3::from_euler_angles(
                -std::f64::consts::FRAC_PI_2,
                0.0,
                std::f64::consts::FRAC_PI_2,
            ),
        );
        let rig = Rig::on_board(
            lively.arm,
            Targets::named_as(&names),
            vec![
                Vector3::new(0.0, 0.0, 0.0),
                Vector3::new(0.1, 0.0, 0.0),
                Vector3::new(0.02, 0.08, 0.0),
            ],
            RigCamera {
                // The lens refined too: its columns are checked with the arm's.
                lens: Some([0.0; 9]),
                ..RigCamera::fixed(crate::camera::testing::webcam(), camera_in_world.inverse())
            },
        );
        let mut samples = lively_samples();
        for (k, s) in samples.iter_mut().enumerate() {
            s.target = k % 3;
        }
        let ids = all_keys(&rig);
        assert!(rig.tool_keys().is_empty());
        assert_columns_match_differences(&rig, &ids, &samples);
        // Every corner seen at each pose, as a camera sees them: the
        // corners of one pose share its deflection.
        let seen: Vec<Sample> = lively_samples()
            .iter()
            .flat_map(|s| (0..3).map(move |target| Sample { target, ..*s }))
            .collect();
        assert_columns_match_differences(&rig, &ids, &seen);
        // The base standing level: its turns turn gravity with it.
        let level = Rig {
            level_base: Some(9.81),
            ..rig
        };
        assert_columns_match_differences(&level, &ids, &samples);
    }

    /// On an arm with a compliant lift (a prismatic joint) before the six
    /// joints, Hayati's twists on two links (one of them fitted, so the
    /// `a` and `alpha` columns act across a tilted frame), every column,
    /// each twist's too, agrees with central differences as closely.
    /// A camera on the flange, the tool frame, seeing corners fixed in the
    /// world: every column (the camera's six, the lens's) agrees with
    /// central differences of the pixels.
    #[test]
    fn a_carried_cameras_columns_match_central_differences_of_the_pixels() {
        use crate::calib::parameters::camera::RigCamera;
        let lively = lively_rig();
        let samples = lively_samples();
        let names: Vec<TargetName> = (0..samples.len())
            .map(|k| TargetName::from(&format!("c{k}")).unwrap())
            .collect();
        let mut rig = Rig::on_board(
            lively.arm,
            Targets::named_as(&names),
            vec![Vector3::zeros(); names.len()],
            RigCamera {
                lens: Some([0.0; 9]),
                ..RigCamera::on_flange(crate::camera::testing::webcam())
            },
        );
        // Sample k sees corner k, half a metre before the camera where the
        // arm stands then, off its axis.
        let seen: Vec<Sample> = samples
            .iter()
            .enumerate()
            .map(|(k, s)| Sample { target: k, ..*s })
            .collect();
        let corners: Vec<Vector3<f64>> = seen
            .iter()
            .map(|s| {
                let last = rig
                    .evaluate(s)
                    .unwrap()
                    .deflection
                    .frames
                    .frames
                    .last_value();
                let camera = last * rig.arm.tool.isometry();
                let k = s.target as f64;
                (camera * nalgebra::Point3::new(0.04 * k - 0.1, 0.03 - 0.02 * k, 0.5)).coords
            })
            .collect();
        rig.board = Some(corners);
        let ids = all_keys(&rig);
        assert_columns_match_differences(&rig, &ids, &seen);
        let level = Rig {
            level_base: Some(9.81),
            ..rig
        };
        assert_columns_match_differences(&level, &ids, &seen);
    }

    #[test]
    fn lift_and_twist_columns_match_central_differences() {
        use model::testing::{LIFT_ARM_JOINTS, lift_arm, random_lift_q};
        let mut arm = lift_arm::<f64>();
        arm.base_compliance = 0.05;
        arm.payload_com = [0.01, -0.02, 0.015];
        arm.joints[0].compliance = 3e-4;
        let rig = Rig::from(arm);
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(3);
        let qs: Vec<model::PerJoint<f64>> = (0..6)
            .map(|_| random_lift_q::<f64>(&mut rng).into())
            .collect();
        let samples: Vec<Sample> = qs
            .iter()
            .zip(lrmcal_core::dataset::approaches(&qs))
            .enumerate()
            .map(|(k, (q, approach))| Sample {
                id: k as u32,
                q: *q,
                load_kg: [0.0, 0.0663, 0.4][k % 3],
                target: 0,
                approach,
            })
            .collect();
        let mut ids: Vec<ParamKey> = model::ParamId::all(LIFT_ARM_JOINTS)
            .chain((0..LIFT_ARM_JOINTS).filter_map(model::ParamId::beta))
            .map(ParamKey::Arm)
            .collect();
        ids.extend((0..=LIFT_ARM_JOINTS as u8).map(|spring| ParamKey::Softening { spring }));
        assert_columns_match_differences(&rig, &ids, &samples);
    }

    /// With our option's parameters on a rig whose springs soften, whose
    /// joints have play and whose servo curves sit on the knots' grid, the
    /// knot, backlash and softening columns (and all the others) agree with
    /// central differences as closely as the paper's.
    #[test]
    fn servo_backlash_and_softening_columns_match_central_differences() {
        let mut lively = lively_rig();
        let mut ids = crate::calib::parameters::option::candidates(
            ModelOption::ElastoKinematicServo,
            &lively.arm,
            crate::calib::parameters::servo_knots::KnotSpacing::FINEST,
        );
        ids.extend(crate::calib::parameters::option::refresh_candidates(
            ModelOption::ElastoKinematicServo,
            &lively.arm,
        ));
        ids.extend((0..JOINTS as u8).map(|joint| ParamKey::Backlash { joint }));
        ids.extend(lively.tool_keys());
        for spring in 0..=JOINTS as u8 {
            *ParamKey::Softening { spring }.slot(&mut lively) = 0.2 + 0.05 * f64::from(spring);
        }
        for joint in 0..JOINTS as u8 {
            *ParamKey::Backlash { joint }.slot(&mut lively) = 0.004 + 0.001 * f64::from(joint);
        }
        let rig = fit_start(&lively, &ids);
        let samples = lively_samples();
        let approaches: Vec<_> = samples.iter().map(|s| s.approach).collect();
        assert!(
            (0..JOINTS).all(|j| approaches.iter().any(|a| a[j] != approaches[0][j])),
            "every joint must arrive both ways in the samples"
        );
        assert_columns_match_differences(&rig, &ids, &samples);
    }

    /// Every column of `ids` agrees with central differences to 1e-6 of its
    /// size plus the differences' absolute noise: the solver's 1e-14 over a
    /// step of a few 1e-6 (a wrist spring's softening moves the point by only
    /// a micrometre per unit).
    fn assert_columns_match_differences(rig: &Rig, ids: &[ParamKey], samples: &[Sample]) {
        let exact = jacobian(rig, ids, samples).unwrap();
        let reference = central_differences(rig, ids, samples);
        for (c, id) in ids.iter().enumerate() {
            let size = reference.column(c).amax();
            let diff = (exact.column(c) - reference.column(c)).amax();
            assert!(
                diff <= 1e-6 * size + 1e-9,
                "{id}: exact vs differences {diff:e}, size {size:e}"
            );
        }
    }

    /// The joint-angle slopes agree with central differences of the
    /// commanded angles, through the deflection.
    #[test]
    fn joint_slopes_match_central_differences() {
        let rig = lively_rig();
        let samples = lively_samples();
        let s = slopes(&rig, &[], &samples).unwrap();
        let h = f64::EPSILON.cbrt();
        for (k, sample) in samples.iter().enumerate() {
            for joint in 0..JOINTS {
                let shifted = |by: f64| {
                    let mut moved = *sample;
                    moved.q[joint] += by;
                    rig.tool_points(&[moved]).unwrap()[0]
                };
                let reference = (shifted(h) - shifted(-h)) / (2.0 * h);
                let exact = s.joints[k].column(joint);
                assert!(
                    (exact - reference).amax() <= 1e-6 * reference.amax().max(1e-3),
                    "sample {k} joint {}: {exact} vs {reference}",
                    joint + 1
                );
            }
        }
    }

    /// Hand-checkable columns: a base translation moves every point by exactly
    /// its own amount; a tool rotation does not move the tool point of a
    /// payload centred on it.
    #[test]
    fn frame_columns_match_their_meaning() {
        let arm = test_arm();
        let ids: Vec<ParamKey> = ["base.x", "base.z", "tool.roll"]
            .iter()
            .map(|n| ParamKey::from_name(n).unwrap())
            .collect();
        let samples = small_samples(5);
        let j = jacobian(&Rig::from(arm), &ids, &samples).unwrap();
        for k in 0..samples.len() {
            let row = |r: usize, c: usize| j[(3 * k + r, c)];
            assert!(
                (row(0, 0) - 1.0).abs() < 1e-12
                    && row(1, 0).abs() < 1e-12
                    && row(2, 0).abs() < 1e-12
            );
            assert!((row(2, 1) - 1.0).abs() < 1e-12);
            assert!(j.fixed_view::<3, 1>(3 * k, 2).norm() < 1e-12);
        }
    }

    /// On a rigid arm a compliance's column is the joint's column times its
    /// gravity torque, exactly: the derivative of the physical side at zero.
    #[test]
    fn compliance_column_of_a_rigid_arm_is_joint_column_times_torque() {
        let arm = crate::calib::testing::rigid_nominal();
        let k2 = ParamKey::from_name("k2").unwrap();
        let theta2 = ParamKey::from_name("j2.theta").unwrap();
        let samples = small_samples(4);
        let j = jacobian(&Rig::from(arm), &[k2, theta2], &samples).unwrap();
        let chain = arm.chain();
        for (k, s) in samples.iter().enumerate() {
            let tau = chain.gravity_torques(&s.q, 0.0, s.load_kg).joints[1];
            let expected = j.fixed_view::<3, 1>(3 * k, 1) * tau;
            let got = j.fixed_view::<3, 1>(3 * k, 0);
            assert!(
                (got - expected).norm() <= 1e-12 * expected.norm().max(1e-9),
                "pose {k}"
            );
        }
    }

    /// The torques the slopes are built on are the model's own.
    #[test]
    fn world_frame_torques_are_the_model_torques() {
        let rig = lively_rig();
        let chain = rig.arm.chain();
        for s in lively_samples() {
            let d = chain
                .deflect(&s.q, s.load_kg, &SolverOptions::default())
                .unwrap();
            let state = State::new(&chain, &rig, d.frames.frames, s.load_kg);
            let model = chain.gravity_torques(&d.qa, d.beta, s.load_kg);
            let ours = state.torques();
            for (e, (a, b)) in ours.iter().zip(model.joints).enumerate() {
                assert!((a - b).abs() < 1e-12, "joint {}", e + 1);
            }
            assert!((ours[JOINTS] - model.base).abs() < 1e-12);
        }
    }
}
