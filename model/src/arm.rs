//! The arm's parameters as plain data: what the TOML describes, what the
//! calibration file carries and what the firmware stores.

use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::{PerJoint, Real, ServoCurve};

/// A rigid frame: `Trans(xyz) * Rz(yaw) * Ry(pitch) * Rx(roll)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frame<T> {
    /// Translation, m.
    pub xyz: [T; 3],
    /// Roll, pitch, yaw, rad.
    pub rpy: [T; 3],
}

impl<T: Real> Frame<T> {
    /// The identity frame.
    pub fn identity() -> Self {
        Self {
            xyz: [T::zero(); 3],
            rpy: [T::zero(); 3],
        }
    }

    /// The frame as an isometry.
    pub fn isometry(&self) -> IsometryMatrix3<T> {
        let [x, y, z] = self.xyz;
        let [roll, pitch, yaw] = self.rpy;
        IsometryMatrix3::from_parts(
            Translation3::new(x, y, z),
            Rotation3::from_euler_angles(roll, pitch, yaw),
        )
    }
}

/// How a joint moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum JointKind {
    /// It turns about its axis: the joint value is an angle, rad.
    #[default]
    Revolute,
    /// It slides along its axis: the joint value is a length, m.
    Prismatic,
}

/// One joint and the link it carries, standard DH with Hayati's twist:
/// `T(i-1,i) = Rz(theta + q) Tz(d) Tx(a) Rx(alpha) Ry(beta)` for a revolute
/// joint, `Rz(theta) Tz(d + q) Tx(a) Rx(alpha) Ry(beta)` for a prismatic one.
///
/// `beta` is 0 in every nominal arm (DH describes any chain); it carries the
/// small tilt between two nominally parallel axes, which no finite change
/// of the DH parameters can ([`crate::params`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "T: Real + Serialize",
    deserialize = "T: Real + Deserialize<'de>"
))]
pub struct Joint<T> {
    /// DH joint-angle offset, rad.
    pub theta: T,
    /// DH offset along z(i-1), m.
    pub d: T,
    /// DH length along x(i), m.
    pub a: T,
    /// DH twist about x(i), rad.
    pub alpha: T,
    /// Hayati's twist about y(i), after `alpha`, rad; 0 in files written before it existed.
    #[serde(default = "crate::zero")]
    pub beta: T,
    /// Revolute or prismatic; revolute in files written before it existed.
    #[serde(default)]
    pub kind: JointKind,
    /// Joint compliance, rad/Nm (m/N for a prismatic joint; never negative).
    pub compliance: T,
    /// Inclusive limits of the commanded joint value, rad (m for a prismatic joint).
    pub limits: [T; 2],
    /// Mass of link i, kg.
    pub mass: T,
    /// Centre of mass of link i in DH frame i, m.
    pub com: [T; 3],
    /// The servo's angle -> pulse curve; `None` for a joint no servo of
    /// ours drives (an arm moved by its own controller, which reaches the
    /// angle it is commanded: calibrated for the host, refused by the board).
    pub servo: Option<ServoCurve<T>>,
    /// Full width of the play in the joint's drive, rad (never negative; see
    /// [`crate::backlash`]). 0 in files written before it existed.
    #[serde(default = "crate::zero")]
    pub backlash: T,
    /// How the joint's compliance grows with its torque, 1/Nm: it yields
    /// `compliance (1 + softening |tau|)` rad per Nm at torque `tau`
    /// (negative: it stiffens; [`crate::bounds`] says how far either way;
    /// see [`crate::elastic`]). 0, a linear spring, in files written before it existed.
    #[serde(default = "crate::zero")]
    pub softening: T,
}

/// The whole arm: geometry, masses, elasticity and servo curves.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound(
    serialize = "T: Real + Serialize",
    deserialize = "T: Real + Deserialize<'de>"
))]
pub struct Arm<T> {
    /// Gravity in the world frame, m/s².
    pub gravity: [T; 3],
    /// World -> arm frame 0.
    pub base: Frame<T>,
    /// Compliance of the base tilt about its own y axis, rad/Nm.
    pub base_compliance: T,
    /// The base tilt's [`Joint::softening`], 1/Nm; 0 in files written before it existed.
    #[serde(default = "crate::zero")]
    pub base_softening: T,
    /// Frame 6 -> measured tool point.
    pub tool: Frame<T>,
    /// Payload centre of mass in the tool frame, m.
    pub payload_com: [T; 3],
    /// The heaviest payload the arm is rated to carry at the tool, kg: the
    /// bounds of its springs ([`crate::bounds`]) hold up to it. 0 in files
    /// written before it existed.
    #[serde(default = "crate::zero")]
    pub rated_payload_kg: T,
    /// The joints, base to tip: 1 to [`crate::MAX_JOINTS`].
    pub joints: PerJoint<Joint<T>>,
}

impl<T: Real> Arm<T> {
    /// The same arm with every number passed through `f` (e.g. `f64 -> f32`).
    pub fn map<U: Real>(&self, f: impl Fn(T) -> U + Copy) -> Arm<U> {
        let v3 = |v: [T; 3]| v.map(f);
        let frame = |fr: &Frame<T>| Frame {
            xyz: v3(fr.xyz),
            rpy: v3(fr.rpy),
        };
        Arm {
            gravity: v3(self.gravity),
            base: frame(&self.base),
            base_compliance: f(self.base_compliance),
            base_softening: f(self.base_softening),
            tool: frame(&self.tool),
            payload_com: v3(self.payload_com),
            rated_payload_kg: f(self.rated_payload_kg),
            joints: self.joints.map(|j| Joint {
                theta: f(j.theta),
                d: f(j.d),
                a: f(j.a),
                alpha: f(j.alpha),
                beta: f(j.beta),
                kind: j.kind,
                compliance: f(j.compliance),
                limits: j.limits.map(f),
                mass: f(j.mass),
                com: v3(j.com),
                servo: j.servo.map(|c| c.map(f)),
                backlash: f(j.backlash),
                softening: f(j.softening),
            }),
        }
    }

    /// Number of joints.
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// How each joint moves, base to tip.
    pub fn kinds(&self) -> PerJoint<JointKind> {
        self.joints.map(|j| j.kind)
    }

    /// Gravity as a vector, world frame.
    pub fn gravity_vector(&self) -> Vector3<T> {
        Vector3::from(self.gravity)
    }

    /// Whether every commanded angle lies within its joint's inclusive limits.
    pub fn within_limits(&self, q: &[T]) -> bool {
        self.joints
            .iter()
            .zip(q)
            .all(|(j, &qi)| qi >= j.limits[0] && qi <= j.limits[1])
    }

    /// Clamps each commanded angle into its joint's limits.
    pub fn clamp_to_limits(&self, q: &[T]) -> PerJoint<T> {
        PerJoint::from_fn(self.joints.len(), |i| {
            let [lo, hi] = self.joints[i].limits;
            q[i].clamp(lo, hi)
        })
    }

    /// Whether every number in the arm is finite (no NaN, no infinity).
    pub fn is_finite(&self) -> bool {
        let ok = core::cell::Cell::new(true);
        self.map(|x| {
            ok.set(ok.get() && x.is_finite());
            x
        });
        ok.get()
    }
}
