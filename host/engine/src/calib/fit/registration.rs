//! Registration: where the arm stands in the tracker's frame, found from the
//! measurements themselves before the fit.
//!
//! A tracker measures in its own frame (OptiTrack is Y-up; ART, Vicon and
//! laser trackers put it where their own calibration put it), and the arm
//! file's `[base]` is at best a guess of the arm's pose in it. Registration
//! finds the rigid motion `R` (arm file's world frame → measurement frame)
//! that puts the nominal arm's predicted tool points nearest the measured
//! ones, in closed form: the centroids and the SVD of the 3 × 3
//! cross-covariance of the two point sets (nalgebra's SVD), with the sign of
//! the smallest singular direction chosen so that `R` is a rotation, not a
//! reflection. The nominal arm misses its points by centimetres (that is what
//! the calibration removes), so the fit is least squares over all points;
//! a few gross errors (a swapped target, a mistyped line) would pull it, so
//! the points farther than [`TRIM_FACTOR`] times the median distance (and
//! than [`TRIM_FLOOR_M`]) are left out and the motion solved again, until
//! the set stays the same. Residual norms do not change under a rigid motion
//! of the measurements, so the whole procedure is equivariant: the same data
//! seen from any frame give the same registered arm.
//!
//! The fit then runs in the arm file's world frame, with the measurements
//! carried there by `R⁻¹` (so the base's roll, pitch and yaw stay small
//! corrections, far from the gimbal lock a tracker's Y-up frame would put
//! them near) and refines the base with the other parameters. Gravity is
//! given in the measurement frame ([`Gravity::Measured`]: the arm file's
//! vector or `--up`) and carried along, or taken along frame 0's `-z` when
//! the base stands level ([`Gravity::LevelBase`]). With compliances in the
//! nominal arm the predicted points depend on gravity in the arm's frame,
//! which depends on `R`: the solve is repeated with the deflected points.
//!
//! **The tool point too.** Where the target sits on the flange is often known
//! to a ruler's accuracy at best. For a given rotation `R` of the motion the
//! measured point is linear in the tool point `t` (frame 6) and the motion's
//! translation `b`: `m ≈ R (o(q) + A(q) t) + b`, with `o` and `A` frame 6's
//! origin and rotation in the arm's world frame (deflected, which does not
//! depend on `t`). So registration alternates: the rigid alignment above for
//! `R` and `b` with `t` held, then linear least squares for `t` and `Rᵀ b`
//! with `R` held, over the points the alignment kept, until neither moves.
//! This needs the last link to turn: if it kept one orientation, a shift of
//! `t` would be a shift of `b`. The stacked `[A(q) I]` tells: its smallest
//! singular value over the square root of the point count (the *turn* of
//! the last link, 0 when it never turns, near 1 for orientations all round)
//! must reach [`MIN_TOOL_TURN`]; below, the file's tool point is kept and
//! the report says so. The fit refines the tool point from there like any
//! parameter.
//!
//! When no rigid motion brings the nominal arm within [`IMPLAUSIBLE_M`] of
//! the measurements, [`diagnose`] tries the usual mistakes (millimetre
//! columns holding metres or micrometres, degree columns holding radians, two
//! joint columns swapped, a joint counted the other way, a mirrored frame)
//! and names the one that fits.

use model::{Arm, Frame};
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Translation3, Vector3};

use crate::calib::fit::checks::IMPLAUSIBLE_M;
use crate::calib::fit::identify::{Estimate, Identified};
use crate::calib::parameters::params::Key as _;
use crate::calib::parameters::params::ParamKey;
use crate::calib::{CalibError, ModelOption, Rig, Sample};
use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::RegistrationRecord;

/// A point farther than this many times the median distance after the
/// alignment is left out of the next solve.
pub const TRIM_FACTOR: f64 = 3.0;
/// Distances below this are never trimmed, m: an uncalibrated arm misses by
/// centimetres everywhere, and the median of a near-perfect fit is not a scale.
pub const TRIM_FLOOR_M: f64 = 0.02;
/// Solves, at most, while the trimmed set changes or the gravity settles.
const MAX_ROUNDS: usize = 8;
/// Rounds of the alternation between the motion and the tool point, at most.
const MAX_TOOL_ROUNDS: usize = 200;
/// The alternation has settled when the motion and the tool point move by
/// less than this in a round, m (rotations as their matrices' change).
const SETTLED_M: f64 = 1e-10;
/// The least turn of the last link (module docs) for registration to find
/// the tool point: 0.3, so that the tool point it finds is off by no more
/// than about three times what the nominal arm misses by anyway.
pub const MIN_TOOL_TURN: f64 = 0.3;
/// Above this angle between frame 0's `z` and "up" the base is reported as tilted, rad.
pub const TILT_WARNING_RAD: f64 = 20.0 * std::f64::consts::PI / 180.0;

/// A rigid motion `p ↦ r · p + t` as `(r, t)`.
type Motion = (Matrix3<f64>, Vector3<f64>);
/// Frame 6 of one sample, origin and rotation: the tool point `t` is at `o + A t`.
type Flange = (Vector3<f64>, Matrix3<f64>);

/// Where gravity comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gravity {
    /// Given in the measurement frame, m/s² (the arm file's `gravity`, or `--up`).
    Measured(Vector3<f64>),
    /// Along `-z` of the arm's frame 0, of this magnitude (m/s²): the base stands level.
    LevelBase(f64),
}

impl Gravity {
    /// Gravity of `nominal`'s size: along the minus `z` of `up` (the
    /// measurement frame's rotation that takes `z` to its up axis) when
    /// given, else along frame 0's `-z` when the base stands level, else
    /// the arm file's `gravity` read in the measurement frame.
    pub fn chosen(nominal: &Arm<f64>, up: Option<Rotation3<f64>>, level_base: bool) -> Self {
        let g = nominal.gravity_vector().norm();
        match (up, level_base) {
            (Some(up), _) => Self::Measured(up.inverse() * Vector3::new(0.0, 0.0, -g)),
            (None, true) => Self::LevelBase(g),
            (None, false) => Self::Measured(nominal.gravity_vector()),
        }
    }

    /// Gravity in the arm file's world frame, for the registration `frame`
    /// (world → measurement frame) of `nominal`.
    pub fn in_arm_frame(&self, nominal: &Arm<f64>, frame: &IsometryMatrix3<f64>) -> Vector3<f64> {
        match *self {
            Self::Measured(g) => frame.rotation.inverse() * g,
            Self::LevelBase(g) => nominal.base.isometry().rotation * Vector3::new(0.0, 0.0, -g),
        }
    }
}

/// The registered arm: the rigid motion that places the nominal arm on the
/// measurements, and how far it was from them before and after.
#[derive(Clone, Debug, PartialEq)]
pub struct Registration {
    /// The arm file's world frame → the measurement frame.
    pub frame: IsometryMatrix3<f64>,
    /// The nominal arm's frame 0 in the measurement frame: `frame · base`.
    pub base: IsometryMatrix3<f64>,
    /// Gravity in the measurement frame, m/s².
    pub gravity: Vector3<f64>,
    /// Angle between frame 0's `z` and up (`-gravity`), rad.
    pub base_tilt_rad: f64,
    /// RMS distance of the nominal arm, as the file places it, from the measured points, m.
    pub before_rms_m: f64,
    /// RMS distance after registration over the points kept, m.
    pub after_rms_m: f64,
    /// Largest distance after registration over every point, m.
    pub after_max_m: f64,
    /// The measurements left out of the final solve, `(pose, load kg)`.
    pub trimmed: Vec<(u32, f64)>,
    /// The tool point found (frame 6, m), which the fit starts from; `None`
    /// when the file's was kept.
    pub tool: Option<Vector3<f64>>,
    /// The turn of the last link over the points kept (module docs): what
    /// decided whether the tool point could be found.
    pub tool_turn: f64,
}

impl Registration {
    /// No registration: the arm file's base as it is, `gravity` in its
    /// world frame, which is then the measurement frame.
    pub fn identity(nominal: &Arm<f64>, gravity: Vector3<f64>) -> Self {
        let base = nominal.base.isometry();
        Self {
            frame: IsometryMatrix3::identity(),
            base,
            gravity,
            base_tilt_rad: tilt(&base, &gravity),
            before_rms_m: 0.0,
            after_rms_m: 0.0,
            after_max_m: 0.0,
            trimmed: Vec::new(),
            tool: None,
            tool_turn: 0.0,
        }
    }

    /// `nominal` as the fit uses it: in its own world frame, with gravity
    /// carried there from the measurement frame, and the tool point found.
    pub fn arm_for_fit(&self, nominal: &Arm<f64>) -> Arm<f64> {
        let mut arm = *nominal;
        arm.gravity = (self.frame.rotation.inverse() * self.gravity).into();
        if let Some(tool) = self.tool {
            arm.tool.xyz = tool.into();
        }
        arm
    }

    /// `measurements` carried from the measurement frame into the arm file's world frame.
    pub fn to_arm_frame(&self, measurements: &[Measurement]) -> Vec<Measurement> {
        measurements
            .iter()
            .map(|m| Measurement {
                position: self
                    .frame
                    .inverse_transform_point(&Point3::from(m.position))
                    .coords,
                ..*m
            })
            .collect()
    }

    /// `arm` (in the arm file's world frame, as the fit used it) in the
    /// measurement frame: its base moved by the registered motion, its
    /// gravity turned with it. Predicted points move with the motion
    /// exactly, deflections included (they depend on gravity relative to
    /// the links only).
    pub fn arm_in_measurement_frame(&self, arm: &Arm<f64>) -> Arm<f64> {
        let mut moved = *arm;
        moved.base = frame_of(&(self.frame * arm.base.isometry()));
        moved.gravity = (self.frame.rotation * arm.gravity_vector()).into();
        moved
    }

    /// `identified` (fitted from `nominal` in the arm file's world frame)
    /// in the measurement frame: the rig's arm as
    /// [`Registration::arm_in_measurement_frame`], and the base's estimates
    /// re-expressed there: values of the moved base, corrections relative
    /// to the moved nominal base (angles wrapped), the position's standard
    /// deviations turned with the frame (correlations between its axes
    /// ignored; the angles' keep theirs, a rotation mixing them little for
    /// the small corrections the fit makes).
    pub fn identified_in_measurement_frame(
        &self,
        nominal: &Arm<f64>,
        identified: &Identified,
    ) -> Identified {
        let nominal_m = Rig::from(self.arm_in_measurement_frame(nominal));
        let mut rig = identified.rig.clone();
        rig.arm = self.arm_in_measurement_frame(&rig.arm);
        let std_of = |name: &str| {
            identified
                .estimates
                .iter()
                .find(|e| e.id.name() == name)
                .and_then(|e| e.std)
        };
        let r = self.frame.rotation.matrix();
        let estimates = identified
            .estimates
            .iter()
            .map(|e| {
                let ParamKey::Arm(id) = e.id else {
                    return *e;
                };
                let name = id.name();
                let Some(axis) = name.strip_prefix("base.") else {
                    return *e;
                };
                let value = e.id.value(&rig);
                let mut error = value - e.id.value(&nominal_m);
                let std = match ["x", "y", "z"].iter().position(|a| *a == axis) {
                    // An axis not fitted has no uncertainty of its own.
                    Some(i) => Some(
                        ["base.x", "base.y", "base.z"]
                            .iter()
                            .enumerate()
                            .map(|(j, n)| (r[(i, j)] * std_of(n).unwrap_or(0.0)).powi(2))
                            .sum::<f64>()
                            .sqrt(),
                    ),
                    None => {
                        error = (error + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                            - std::f64::consts::PI;
                        e.std
                    }
                };
                Estimate {
                    value,
                    error,
                    std,
                    ..*e
                }
            })
            .collect();
        Identified {
            rig,
            estimates,
            ..identified.clone()
        }
    }
}

/// `iso` as a [`Frame`]: translation and roll, pitch, yaw.
pub fn frame_of(iso: &IsometryMatrix3<f64>) -> Frame<f64> {
    let (roll, pitch, yaw) = iso.rotation.euler_angles();
    Frame {
        xyz: iso.translation.vector.into(),
        rpy: [roll, pitch, yaw],
    }
}

/// Angle between `base`'s `z` axis and up (`-gravity`), rad.
fn tilt(base: &IsometryMatrix3<f64>, gravity: &Vector3<f64>) -> f64 {
    let z = base.rotation * Vector3::z();
    let up = -gravity;
    if up.norm() == 0.0 {
        return 0.0;
    }
    z.angle(&up)
}

/// The best rigid motion `T` with `T · p ≈ m` over the pairs whose `keep` is
/// true, by the SVD of the cross-covariance; `proper` chooses a rotation,
/// otherwise the reflection is allowed. `None` when the points are too few or
/// lie on a line (a turn about it would be free).
fn align(
    predicted: &[Vector3<f64>],
    measured: &[Vector3<f64>],
    keep: &[bool],
    proper: bool,
) -> Option<Motion> {
    let pairs: Vec<(&Vector3<f64>, &Vector3<f64>)> = predicted
        .iter()
        .zip(measured)
        .zip(keep)
        .filter(|(_, k)| **k)
        .map(|(pair, _)| pair)
        .collect();
    if pairs.len() < 3 {
        return None;
    }
    let n = pairs.len() as f64;
    let pc = pairs.iter().map(|(p, _)| **p).sum::<Vector3<f64>>() / n;
    let mc = pairs.iter().map(|(_, m)| **m).sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = pairs
        .iter()
        .map(|(p, m)| (**p - pc) * (**m - mc).transpose())
        .sum();
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let s = svd.singular_values;
    // Points on a line leave the turn about it free: the second singular value vanishes.
    let spread = pairs
        .iter()
        .map(|(p, _)| (**p - pc).norm_squared())
        .sum::<f64>();
    if s.max() <= 0.0 || s.iter().filter(|v| **v > 1e-9 * spread.max(1e-300)).count() < 2 {
        return None;
    }
    let mut d = Matrix3::identity();
    if proper && (v_t.transpose() * u.transpose()).determinant() < 0.0 {
        // The third singular value is the smallest (nalgebra sorts them): flip it.
        let (smallest, _) = s.argmin();
        d[(smallest, smallest)] = -1.0;
    }
    let r = v_t.transpose() * d * u.transpose();
    Some((r, mc - r * pc))
}

/// Distances of `predicted` under `(r, t)` from `measured`, m.
fn distances((r, t): &Motion, predicted: &[Vector3<f64>], measured: &[Vector3<f64>]) -> Vec<f64> {
    predicted
        .iter()
        .zip(measured)
        .map(|(p, m)| (r * p + t - m).norm())
        .collect()
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.get(s.len() / 2).copied().unwrap_or(0.0)
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
    (sum / n.max(1) as f64).sqrt()
}

/// The trimmed least-squares alignment of `predicted` onto `measured`:
/// the motion, the kept mask and the distances of every point.
fn trimmed_align(
    predicted: &[Vector3<f64>],
    measured: &[Vector3<f64>],
    proper: bool,
) -> Option<(Motion, Vec<bool>, Vec<f64>)> {
    let mut keep = vec![true; predicted.len()];
    let mut motion = align(predicted, measured, &keep, proper)?;
    for _ in 0..MAX_ROUNDS {
        let d = distances(&motion, predicted, measured);
        let limit = (TRIM_FACTOR * median(&d)).max(TRIM_FLOOR_M);
        let next: Vec<bool> = d.iter().map(|e| *e <= limit).collect();
        // Never trim to fewer than half the points: then the "outliers" are the data.
        if next == keep || next.iter().filter(|k| **k).count() * 2 < keep.len() {
            return Some((motion, keep, d));
        }
        keep = next;
        motion = align(predicted, measured, &keep, proper)?;
    }
    let d = distances(&motion, predicted, measured);
    Some((motion, keep, d))
}

/// The nominal arm's predicted points, deflected under `gravity_arm` (arm frame).
fn predicted(
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
fn flange_poses(
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
struct ToolSolve {
    /// The tool point `t` (frame 6) and the motion's translation `b`; `None`
    /// when the turn is below [`MIN_TOOL_TURN`].
    found: Option<(Vector3<f64>, Vector3<f64>)>,
    /// The turn of the last link over the kept points.
    turn: f64,
}

/// The tool point and translation that put the flange poses nearest the
/// kept measurements for the motion's rotation `r` (module docs).
fn solve_tool(
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

/// Registers `nominal` on `measurements` (positions in the measurement
/// frame); see the module docs. Refuses measurements no rigid motion
/// explains, naming what to check.
pub fn register(
    nominal: &Arm<f64>,
    measurements: &[Measurement],
    gravity: Gravity,
) -> Result<Registration, CalibError> {
    let samples: Vec<Sample> = measurements.iter().map(Sample::from).collect();
    let measured: Vec<Vector3<f64>> = measurements.iter().map(|m| m.position).collect();
    if let Some(m) = measurements
        .iter()
        .find(|m| !m.position.iter().all(|v| v.is_finite()))
    {
        return Err(CalibError::Registration {
            problem: format!(
                "pose {} ({} kg) has a position that is not a finite number",
                m.pose.id, m.load_kg
            ),
        });
    }
    let before_gravity = match gravity {
        Gravity::Measured(g) => g,
        Gravity::LevelBase(g) => nominal.base.isometry().rotation * Vector3::new(0.0, 0.0, -g),
    };
    let as_filed = predicted(nominal, before_gravity, &samples)?;
    let before_rms_m = rms(as_filed.iter().zip(&measured).map(|(p, m)| (p - m).norm()));

    // The rigid arm first: its points do not depend on where gravity points.
    let rigid: Vec<Vector3<f64>> = {
        let chain = nominal.chain();
        samples
            .iter()
            .map(|s| chain.rigid_tool_point(&s.q))
            .collect()
    };
    let unplaceable = || CalibError::Registration {
        problem: format!(
            "the {} measured points lie on a line (or at one point) or are fewer than 3, so the arm's turn about them is free; measure poses that spread in 3D",
            measured.len()
        ),
    };
    let (mut motion, mut keep, mut d) =
        trimmed_align(&rigid, &measured, true).ok_or_else(unplaceable)?;
    let elastic =
        nominal.joints.iter().any(|j| j.compliance > 0.0) || nominal.base_compliance > 0.0;
    // The motion and the tool point in turn (module docs); with a rigid arm
    // whose tool point cannot be found, the first alignment is the answer.
    let mut arm = *nominal;
    let mut tool = None;
    let mut tool_turn = 0.0;
    for round in 0..MAX_TOOL_ROUNDS {
        let gravity_arm = gravity.in_arm_frame(nominal, &isometry(&motion));
        let flanges = flange_poses(&arm, gravity_arm, &samples)?;
        let ToolSolve { found, turn } = solve_tool(&flanges, &measured, &keep, &motion.0);
        tool_turn = turn;
        let mut moved = 0.0;
        if let Some((t, b)) = found {
            moved += (t - Vector3::from(arm.tool.xyz)).norm() + (b - motion.1).norm();
            arm.tool.xyz = t.into();
            motion.1 = b;
            tool = Some(t);
        } else if !elastic || round >= 3 {
            break;
        }
        let points = predicted(&arm, gravity_arm, &samples)?;
        let next = trimmed_align(&points, &measured, true).ok_or_else(unplaceable)?;
        moved += (next.0.1 - motion.1).norm() + (next.0.0 - motion.0).norm();
        (motion, keep, d) = next;
        if moved < SETTLED_M {
            break;
        }
    }
    let after_rms_m = rms(d.iter().zip(&keep).filter(|(_, k)| **k).map(|(e, _)| *e));
    if after_rms_m > IMPLAUSIBLE_M {
        let hint = diagnose(nominal, measurements).unwrap_or_else(|| GENERIC_HINT.to_owned());
        return Err(CalibError::Registration {
            problem: format!(
                "no rigid motion places the nominal arm on the measurements: after the best one they are {:.0} mm from it (RMS), expected within {:.0} mm; {hint}",
                after_rms_m * 1e3,
                IMPLAUSIBLE_M * 1e3
            ),
        });
    }
    let frame = isometry(&motion);
    let base = frame * nominal.base.isometry();
    let gravity_m = frame.rotation * gravity.in_arm_frame(nominal, &frame);
    Ok(Registration {
        frame,
        base,
        gravity: gravity_m,
        base_tilt_rad: tilt(&base, &gravity_m),
        before_rms_m,
        after_rms_m,
        after_max_m: d.iter().copied().fold(0.0, f64::max),
        trimmed: measurements
            .iter()
            .zip(&keep)
            .filter(|(_, k)| !**k)
            .map(|(m, _)| (m.pose.id, m.load_kg))
            .collect(),
        tool,
        tool_turn,
    })
}

/// What to check when nothing specific explains a misfit.
pub const GENERIC_HINT: &str = "check that the positions are in millimetres, that the joint columns q1_deg..q6_deg are in the arm's order with its signs and zeros, and that --arm is the arm that was measured";

fn isometry((r, t): &Motion) -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(Translation3::from(*t), Rotation3::from_matrix_unchecked(*r))
}

/// The usual mistake that explains why the nominal arm cannot be placed on
/// `measurements`, if one does: each is undone in turn (positions scaled by
/// 1000 either way, radians in the degree columns, two joint columns swapped,
/// one joint's sign flipped, the frame mirrored) and the one that brings the rigid arm within
/// [`IMPLAUSIBLE_M`] (RMS, after the best rigid motion), and to less than
/// half of the misfit as given, is named.
pub fn diagnose(nominal: &Arm<f64>, measurements: &[Measurement]) -> Option<String> {
    let chain = nominal.chain();
    let measured: Vec<Vector3<f64>> = measurements.iter().map(|m| m.position).collect();
    let misfit = |qs: &dyn Fn(&[f64; 6]) -> [f64; 6], scale: f64, proper: bool| -> Option<f64> {
        let points: Vec<Vector3<f64>> = measurements
            .iter()
            .map(|m| chain.rigid_tool_point(&qs(&m.pose.q)))
            .collect();
        let scaled: Vec<Vector3<f64>> = measured.iter().map(|m| m * scale).collect();
        let (_, keep, d) = trimmed_align(&points, &scaled, proper)?;
        Some(rms(d
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(e, _)| *e)))
    };
    let same = |q: &[f64; 6]| *q;
    let given = misfit(&same, 1.0, true)?;
    let mut tries: Vec<(f64, String)> = Vec::new();
    let mut attempt = |fit: Option<f64>, what: String| {
        if let Some(f) = fit.filter(|f| *f <= IMPLAUSIBLE_M && *f < 0.5 * given) {
            tries.push((f, what));
        }
    };
    attempt(
        misfit(&same, 1e3, true),
        "the positions look like metres in millimetre columns (x_mm, y_mm, z_mm): multiply them by 1000".into(),
    );
    attempt(
        misfit(&same, 1e-3, true),
        "the positions look a thousand times too large (micrometres?): the columns x_mm, y_mm, z_mm take millimetres".into(),
    );
    // Radians in the degree columns were read as degrees: the angles used are
    // the intended ones divided by 180/π.
    let radians_read_as_degrees = |q: &[f64; 6]| q.map(f64::to_degrees);
    attempt(
        misfit(&radians_read_as_degrees, 1.0, true),
        "the joint angles look like radians in degree columns (q1_deg..q6_deg): multiply them by 180/π (57.2958)".into(),
    );
    for a in 0..6 {
        for b in a + 1..6 {
            let swapped = |q: &[f64; 6]| {
                let mut q = *q;
                q.swap(a, b);
                q
            };
            attempt(
                misfit(&swapped, 1.0, true),
                format!(
                    "the joint columns q{}_deg and q{}_deg look swapped: check the order of the joint columns",
                    a + 1,
                    b + 1
                ),
            );
        }
    }
    for j in 0..6 {
        let flipped = |q: &[f64; 6]| {
            let mut q = *q;
            q[j] = -q[j];
            q
        };
        attempt(
            misfit(&flipped, 1.0, true),
            format!(
                "joint {} looks counted the other way: check the sign of q{}_deg (or the arm file's joint {})",
                j + 1,
                j + 1,
                j + 1
            ),
        );
    }
    attempt(
        misfit(&same, 1.0, false),
        "the measurement frame looks mirrored (left-handed: one axis reversed): export the tracker's data in a right-handed frame".into(),
    );
    tries
        .into_iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(fit, what)| {
            format!(
                "{what} (the arm then fits to {:.1} mm RMS, as given {:.0} mm)",
                fit * 1e3,
                given * 1e3
            )
        })
}

/// Coordinates of a rigid motion: what registration takes from the
/// measurements before the fit sees them.
pub const REGISTRATION_DOF: usize = 6;

/// Refuses a fit of `params` parameters from `poses` registered poses when
/// their coordinates (one point a pose) do not also cover the base's place
/// that registration took from them: three poses register exactly and would
/// leave the fit nothing to check itself against.
pub fn check_registered_count(
    poses: usize,
    params: usize,
    option: ModelOption,
) -> Result<(), CalibError> {
    // Fewer coordinates than parameters: the selection and the fit refuse
    // those themselves, with their own counts.
    if 3 * poses >= params && 3 * poses < params + REGISTRATION_DOF {
        return Err(CalibError::Registration {
            problem: format!(
                "the {poses} poses give {} coordinates, fewer than the {REGISTRATION_DOF} the base's place takes plus the {params} parameters of the {option} model; measure more poses, or pass --no-register if the positions are in the arm file's frame",
                3 * poses
            ),
        });
    }
    Ok(())
}

/// [`crate::calib::fit::checks::check_plausible`] on registered measurements: a point
/// still 150 mm off after the best rigid motion gets the likely cause
/// ([`diagnose`]) in its message.
pub fn check_plausible_registered(
    nominal: &Arm<f64>,
    measurements: &[Measurement],
    file: &str,
) -> Result<(), CalibError> {
    crate::calib::fit::checks::check_plausible(nominal, measurements, file).map_err(|e| match e {
        CalibError::BadMeasurement {
            pose,
            load_kg,
            file,
            problem,
        } => {
            let hint = diagnose(nominal, measurements).unwrap_or_else(|| GENERIC_HINT.into());
            CalibError::BadMeasurement {
                pose,
                load_kg,
                file,
                problem: format!("{problem}; {hint}"),
            }
        }
        other => other,
    })
}

impl Registration {
    /// What the calibration file records of it; `registered` is false when
    /// the arm file's base was kept (`--no-register`).
    pub fn record(&self, registered: bool) -> RegistrationRecord {
        RegistrationRecord {
            registered,
            frame: frame_of(&self.frame),
            base: frame_of(&self.base),
            gravity: self.gravity.into(),
            before_rms_m: self.before_rms_m,
            after_rms_m: self.after_rms_m,
            trimmed: self.trimmed.iter().map(|(pose, _)| *pose).collect(),
            tool_m: self.tool.map(Into::into),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{measure, rigid_nominal, small_samples, test_arm};
    use rand::{Rng, SeedableRng, rngs::StdRng};

    const G: f64 = 9.80665;

    fn random_frame(rng: &mut StdRng) -> IsometryMatrix3<f64> {
        let axis = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let angle = rng.random_range(-3.0..3.0);
        let t = Vector3::new(
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
        );
        IsometryMatrix3::from_parts(
            Translation3::from(t),
            Rotation3::from_scaled_axis(axis.normalize() * angle),
        )
    }

    fn moved(meas: &[Measurement], frame: &IsometryMatrix3<f64>) -> Vec<Measurement> {
        meas.iter()
            .map(|m| Measurement {
                position: frame.transform_point(&Point3::from(m.position)).coords,
                ..*m
            })
            .collect()
    }

    /// Registered poses must give the base's six coordinates on top of the
    /// parameters; fewer coordinates than parameters are the fit's to refuse.
    #[test]
    fn a_registered_fit_needs_six_coordinates_more_than_its_parameters() {
        let option = ModelOption::ElastoKinematic;
        let e = check_registered_count(12, 32, option).unwrap_err();
        assert!(
            e.to_string().contains("36 coordinates, fewer than the 6")
                && e.to_string().contains("--no-register"),
            "{e}"
        );
        assert!(check_registered_count(13, 32, option).is_ok());
        assert!(check_registered_count(10, 32, option).is_ok());
    }

    /// A compliant arm measured from random frames: registration finds each
    /// frame (to well below the fit's resolution), carries the gravity
    /// along, and the nominal arm's distance after registration does not
    /// depend on the frame.
    #[test]
    fn finds_the_frame_of_the_measurements() {
        let truth = test_arm();
        let meas = measure(&truth, &small_samples(30));
        let own = register(
            &rigid_nominal(),
            &meas,
            Gravity::Measured(truth.gravity_vector()),
        )
        .unwrap();
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..5 {
            let frame = random_frame(&mut rng);
            let g = frame.rotation * truth.gravity_vector();
            let reg = register(
                &rigid_nominal(),
                &moved(&meas, &frame),
                Gravity::Measured(g),
            )
            .unwrap();
            let expected = frame * own.frame;
            assert!(
                (reg.frame.translation.vector - expected.translation.vector).norm() < 1e-9,
                "{reg:?}"
            );
            assert!((reg.frame.rotation.matrix() - expected.rotation.matrix()).norm() < 1e-9);
            assert!((reg.after_rms_m - own.after_rms_m).abs() < 1e-12);
            assert!((reg.gravity - g).norm() < 1e-12);
            assert!(reg.before_rms_m > 0.1, "{}", reg.before_rms_m);
            let in_arm = reg.arm_for_fit(&rigid_nominal()).gravity_vector();
            let own_arm = own.arm_for_fit(&rigid_nominal()).gravity_vector();
            assert!((in_arm - own_arm).norm() < 1e-9, "{in_arm} vs {own_arm}");
        }
    }

    /// Gross errors on a few points do not move the registration: they are
    /// trimmed and named, and the rest is placed as without them.
    #[test]
    fn a_few_bad_points_are_trimmed() {
        let nominal = rigid_nominal();
        let meas = measure(&nominal, &small_samples(30));
        let clean = register(&nominal, &meas, Gravity::LevelBase(G)).unwrap();
        let mut bad = meas.clone();
        bad[4].position.x += 0.4;
        bad[17].position.z -= 0.25;
        let reg = register(&nominal, &bad, Gravity::LevelBase(G)).unwrap();
        assert_eq!(reg.trimmed, [(4, 0.0), (17, 0.0663)]);
        assert!(
            reg.frame.translation.vector.norm() < 1e-9,
            "{:?}",
            reg.frame
        );
        assert!(clean.trimmed.is_empty() && clean.after_rms_m < 1e-9);
        assert!(reg.after_max_m > 0.25);
    }

    /// A tool point 3 cm off in the file is found exactly from exact
    /// measurements; with only joint 1 turning, a shift of the tool point
    /// along its axis is one of the base, so the file's is kept.
    #[test]
    fn the_tool_point_is_found_when_the_last_link_turns() {
        let nominal = rigid_nominal();
        let mut truth = nominal;
        truth.tool.xyz[0] += 0.03;
        truth.tool.xyz[1] -= 0.01;
        let reg = register(
            &nominal,
            &measure(&truth, &small_samples(20)),
            Gravity::LevelBase(G),
        )
        .unwrap();
        let found = reg.tool.expect("found");
        assert!(
            (found - Vector3::from(truth.tool.xyz)).norm() < 1e-9,
            "{found}"
        );
        assert!(reg.after_rms_m < 1e-9 && reg.tool_turn > MIN_TOOL_TURN);
        assert_eq!(Vector3::from(reg.arm_for_fit(&nominal).tool.xyz), found);

        let pan: Vec<Sample> = (0..12)
            .map(|i| Sample {
                id: i,
                q: [0.3 * i as f64 - 1.5, 0.3, -0.4, 0.2, 0.5, 0.1],
                load_kg: 0.0,
                target: 0,
                approach: lrmcal_core::dataset::FROM_HOME,
            })
            .collect();
        let reg = register(&nominal, &measure(&truth, &pan), Gravity::LevelBase(G)).unwrap();
        assert!(reg.tool.is_none() && reg.tool_turn < 1e-6, "{reg:?}");
        assert_eq!(reg.arm_for_fit(&nominal).tool, nominal.tool);
    }

    /// The level-base rule puts gravity along frame 0's -z, whatever frame the points are in.
    #[test]
    fn a_level_base_gives_gravity_along_its_z() {
        let nominal = rigid_nominal();
        let frame = random_frame(&mut StdRng::seed_from_u64(8));
        let meas = moved(&measure(&nominal, &small_samples(12)), &frame);
        let reg = register(&nominal, &meas, Gravity::LevelBase(G)).unwrap();
        assert!((reg.gravity - frame.rotation * Vector3::new(0.0, 0.0, -G)).norm() < 1e-9);
        assert!(reg.base_tilt_rad < 1e-9);
    }

    fn refused(meas: &[Measurement]) -> String {
        register(&rigid_nominal(), meas, Gravity::LevelBase(G))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn metres_radians_swapped_columns_and_mirrors_are_named() {
        let meas = measure(&rigid_nominal(), &small_samples(30));
        let mut metres = meas.clone();
        metres.iter_mut().for_each(|m| m.position /= 1000.0);
        let e = refused(&metres);
        assert!(e.contains("metres in millimetre columns"), "{e}");
        let mut swapped = meas.clone();
        swapped.iter_mut().for_each(|m| m.pose.q.swap(1, 2));
        let e = refused(&swapped);
        assert!(e.contains("q2_deg and q3_deg look swapped"), "{e}");
        let mut radians = meas.clone();
        radians
            .iter_mut()
            .for_each(|m| m.pose.q = m.pose.q.map(f64::to_radians));
        let e = refused(&radians);
        assert!(e.contains("radians in degree columns"), "{e}");
        let mut mirrored = meas.clone();
        mirrored
            .iter_mut()
            .for_each(|m| m.position.y = -m.position.y);
        let e = refused(&mirrored);
        assert!(e.contains("mirrored"), "{e}");
        let mut line = meas[..2].to_vec();
        line.push(meas[0]);
        let e = refused(&line);
        assert!(e.contains("on a line"), "{e}");
    }

    /// Nothing that a usual mistake explains gets the general advice.
    #[test]
    fn an_unexplained_misfit_says_what_to_check() {
        let meas = measure(&rigid_nominal(), &small_samples(30));
        let mut rng = StdRng::seed_from_u64(1);
        let scrambled: Vec<Measurement> = meas
            .iter()
            .map(|m| Measurement {
                position: Vector3::new(
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                ),
                ..*m
            })
            .collect();
        let e = refused(&scrambled);
        assert!(
            e.contains(GENERIC_HINT) && e.contains("expected within 150 mm"),
            "{e}"
        );
    }
}
