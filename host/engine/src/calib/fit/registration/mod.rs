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

use model::params::ParamPart;
use model::{Arm, Frame, ParamId};
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Vector3};

use crate::calib::fit::checks::IMPLAUSIBLE_M;
use crate::calib::fit::identify::{Estimate, Identified};
use crate::calib::parameters::params::Key as _;
use crate::calib::parameters::params::ParamKey;
use crate::calib::{CalibError, Rig, Sample};
use lrmcal_core::dataset::Measurement;
use lrmcal_core::io::calibration_file::RegistrationRecord;

mod align;
mod diagnose;
mod tool;

pub use diagnose::{
    GENERIC_HINT, REGISTRATION_DOF, check_plausible_registered, check_registered_count, diagnose,
};

use align::{isometry, rms, trimmed_align};
use tool::{ToolSolve, flange_poses, predicted, solve_tool};

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
        let std_of = |axis: usize| {
            let id = ParamId::from_part(ParamPart::Base { axis }).map(ParamKey::Arm);
            identified
                .estimates
                .iter()
                .find(|e| Some(e.id) == id)
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
                let ParamPart::Base { axis } = id.part() else {
                    return *e;
                };
                let value = e.id.value(&rig);
                let mut error = value - e.id.value(&nominal_m);
                let std = match axis {
                    // An axis not fitted has no uncertainty of its own.
                    i if i < 3 => Some(
                        (0..3)
                            .map(|j| (r[(i, j)] * std_of(j).unwrap_or(0.0)).powi(2))
                            .sum::<f64>()
                            .sqrt(),
                    ),
                    _ => {
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
mod tests;
