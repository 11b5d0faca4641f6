//! The names of the quantities a calibration may correct: [`ParamKey`], the
//! one vocabulary of parameter names that calibration files, reports and
//! messages write (`j3.d`, `k0`, `s2`, `tool[2].x`, `j3.servo[5]`,
//! `j3.backlash`). The model names its own error parameters
//! ([`model::ParamId`]); the rest are named here. Joints and knots are
//! counted from 1 in names, from 0 in code.

use std::borrow::Cow;
use std::fmt;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use model::ParamId;
use model::bounds::{Bounds, FIT_MARGIN, Quantity};
use model::params::{ParamKind, ParamPart};

/// A quantity the calibration may correct.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ParamKey {
    /// One of the model's error parameters: a field of the arm.
    Arm(ParamId),
    /// Coordinate `axis` (0 x, 1 y, 2 z) of the tool point of measured
    /// target `target` (1 or more; target 0's is the arm's `tool.x/y/z`),
    /// frame 6, m.
    TargetTool {
        /// Index of the target in its measurement set, 1 or more.
        target: u8,
        /// 0 x, 1 y, 2 z.
        axis: u8,
    },
    /// The angle of knot `knot` of joint `joint`'s (from 0) servo curve,
    /// the knot counted from 0 on the finest grid (every 25° from -100°,
    /// whatever the spacing fitted): its correction is the angle the knot's
    /// pulse really reaches minus the angle the curve had for it (see
    /// `calib::servo_knots`).
    ServoKnot {
        /// Joint, from 0.
        joint: u8,
        /// Knot of the joint's curve, from 0.
        knot: u8,
    },
    /// How spring `spring`'s compliance grows with its torque, 1/Nm (0 the
    /// base's, `k0`'s; 1..=n the joints'), `model::Arm::base_softening` and `model::Joint::softening`.
    Softening {
        /// Spring, as the compliances `k0..kn` count them.
        spring: u8,
    },
    /// The full width of joint `joint`'s (from 0) play, rad
    /// (`model::Joint::backlash`, see `calib::backlash`).
    Backlash {
        /// Joint, from 0.
        joint: u8,
    },
    /// A correction of the measuring camera's lens ([`LENS_FIELDS`]), when
    /// the fit refines the intrinsics: not the arm's, the instrument's,
    /// like the registration. Each is dimensionless: a focal length's
    /// relative change, the principal point's shift over the focal length
    /// (the turn of the optical axis, rad), a distortion coefficient's
    /// change.
    Lens {
        /// Index into [`LENS_FIELDS`].
        field: u8,
    },
}

/// The lens corrections' names after `camera.`, in [`ParamKey::Lens`]'s
/// order: focal lengths, principal point, then OpenCV's k1, k2, p1, p2, k3.
pub const LENS_FIELDS: [&str; 9] = ["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"];

/// Axis letters of [`ParamKey::TargetTool`] names.
const AXES: [&str; 3] = ["x", "y", "z"];

impl ParamKey {
    /// Stable name: the arm's parameters keep the model's names (`j3.d`,
    /// `base.pitch`, `k0`); a further target's tool point is `tool[2].x`, a
    /// servo knot `j3.servo[5]` (joint and knot from 1), a backlash width
    /// `j3.backlash` (joint from 1).
    pub fn name(self) -> Cow<'static, str> {
        match self {
            Self::Arm(id) => Cow::Borrowed(id.name()),
            Self::TargetTool { target, axis } => {
                let axis = AXES.get(usize::from(axis)).copied().unwrap_or("?");
                Cow::Owned(format!("tool[{target}].{axis}"))
            }
            Self::ServoKnot { joint, knot } => {
                Cow::Owned(servo_knot_name(joint.into(), knot.into()))
            }
            Self::Backlash { joint } => Cow::Owned(backlash_name(joint.into())),
            Self::Softening { spring } => Cow::Owned(format!("s{spring}")),
            Self::Lens { field } => Cow::Owned(format!(
                "camera.{}",
                LENS_FIELDS.get(usize::from(field)).copied().unwrap_or("?")
            )),
        }
    }

    /// Every lens correction, in [`LENS_FIELDS`]' order.
    pub fn lens() -> impl Iterator<Item = Self> {
        (0..LENS_FIELDS.len() as u8).map(|field| Self::Lens { field })
    }

    /// The key called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        if let Some(id) = ParamId::from_name(name) {
            return Some(Self::Arm(id));
        }
        // Both fit a u8: at most MAX_JOINTS joints and MAX_KNOTS knots.
        if let Some((joint, knot)) = servo_knot_from_name(name) {
            return Some(Self::ServoKnot {
                joint: joint as u8,
                knot: knot as u8,
            });
        }
        if let Some(joint) = backlash_from_name(name) {
            return Some(Self::Backlash { joint: joint as u8 });
        }
        if let Some(field) = name.strip_prefix("camera.") {
            let field = LENS_FIELDS.iter().position(|f| *f == field)?;
            return Some(Self::Lens { field: field as u8 });
        }
        if let Some(spring) = name
            .strip_prefix('s')
            .and_then(|n| n.parse::<u8>().ok())
            .filter(|s| usize::from(*s) <= model::MAX_JOINTS && name == format!("s{s}"))
        {
            return Some(Self::Softening { spring });
        }
        let (target, axis) = name.strip_prefix("tool[")?.split_once("].")?;
        let target: u8 = target.parse().ok().filter(|t| *t > 0)?;
        let axis = AXES.iter().position(|a| *a == axis)?;
        Some(Self::TargetTool {
            target,
            axis: axis as u8,
        })
    }

    /// Coordinate `axis` (0 x, 1 y, 2 z) of target `target`'s tool point:
    /// the arm's `tool.x/y/z` for target 0. `None` past the last axis or key.
    pub fn tool(target: usize, axis: usize) -> Option<Self> {
        match target {
            0 if axis < 3 => ParamId::from_part(ParamPart::Tool { axis }).map(Self::Arm),
            0 => None,
            _ => Some(Self::TargetTool {
                target: u8::try_from(target).ok()?,
                axis: u8::try_from(axis).ok().filter(|a| *a < 3)?,
            }),
        }
    }

    /// The joint (from 0) this key belongs to, if it belongs to one: its
    /// geometry, spring, servo or play.
    pub fn joint(self) -> Option<usize> {
        match self {
            Self::Arm(id) => id.joint(),
            Self::ServoKnot { joint, .. } | Self::Backlash { joint } => Some(joint.into()),
            Self::Softening { spring } => usize::from(spring).checked_sub(1),
            Self::TargetTool { .. } | Self::Lens { .. } => None,
        }
    }

    /// Whether this is a coordinate of the tool: the arm's tool frame or a
    /// further target's tool point.
    pub fn is_tool(self) -> bool {
        match self {
            Self::Arm(id) => matches!(id.part(), ParamPart::Tool { .. }),
            Self::TargetTool { .. } => true,
            _ => false,
        }
    }

    /// Whether an arm of `joints` joints has this quantity.
    pub fn fits(self, joints: usize) -> bool {
        self.joint().is_none_or(|j| j < joints)
    }

    /// Physical kind, which sets the unit and the scale of steps and typical errors.
    pub fn kind(self) -> ParamKind {
        match self {
            Self::Arm(id) => id.kind(),
            Self::TargetTool { .. } => ParamKind::Length,
            Self::ServoKnot { .. } | Self::Backlash { .. } => ParamKind::Angle,
            // Its steps and typical size are a compliance's (about 0.1).
            Self::Softening { .. } => ParamKind::Compliance,
            // Dimensionless, sized like a small angle (a turn of the optical
            // axis, a focal length's relative change).
            Self::Lens { .. } => ParamKind::Angle,
        }
    }

    /// The arm's bounded quantity ([`model::bounds`]) this key corrects, if it is one.
    pub fn quantity(self) -> Option<Quantity> {
        match self {
            // k0 is the base's spring, k1..kn the joints'.
            Self::Arm(id) => match id.part() {
                ParamPart::BaseCompliance => Some(Quantity::Compliance { spring: 0 }),
                ParamPart::Compliance { joint } => Some(Quantity::Compliance {
                    spring: u8::try_from(joint + 1).ok()?,
                }),
                _ => None,
            },
            Self::Softening { spring } => Some(Quantity::Softening { spring }),
            Self::Backlash { joint } => Some(Quantity::Backlash { joint }),
            _ => None,
        }
    }

    /// The smallest and largest value the fit may give the quantity (not its
    /// correction): its physical range in `bounds`, kept inside by
    /// [`model::bounds::FIT_MARGIN`] so that the board's single-precision
    /// check passes too; `None` where it is unbounded.
    pub fn fit_range(self, bounds: &Bounds<f64>) -> (Option<f64>, Option<f64>) {
        let Some(quantity) = self.quantity() else {
            return (None, None);
        };
        let range = bounds.range(quantity).inner(FIT_MARGIN);
        let finite = |x: f64| (x.abs() < f64::MAX / 2.0).then_some(x);
        (finite(range.min), finite(range.max))
    }
}

impl From<ParamId> for ParamKey {
    fn from(id: ParamId) -> Self {
        Self::Arm(id)
    }
}

impl fmt::Display for ParamKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// Files write a key by its [`ParamKey::name`].
impl Serialize for ParamKey {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(&self.name())
    }
}

/// A key is read from its [`ParamKey::name`]; any other text is refused,
/// naming what was found.
impl<'de> Deserialize<'de> for ParamKey {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        Self::from_name(&name).ok_or_else(|| {
            serde::de::Error::custom(format!(
                "expected a parameter name (j1.theta … j10.beta, base.x … tool.yaw, k0 … k10, \
                 s0 … s10, j1.servo[1] … j10.servo[9], j1.backlash … j10.backlash, tool[N].x … \
                 tool[N].z, camera.fx … camera.k3), found `{name}`"
            ))
        })
    }
}

/// The joint and knot (both from 0) of a servo-knot parameter name,
/// `j<joint>.servo[<knot>]`, both counted from 1 for people as everywhere
/// in messages (`j3.servo[5]`: the fifth knot of joint 3's curve).
fn servo_knot_from_name(name: &str) -> Option<(usize, usize)> {
    let (joint, rest) = name.strip_prefix('j')?.split_once(".servo[")?;
    let knot = rest.strip_suffix(']')?;
    let joint: usize = joint.parse().ok()?;
    let knot: usize = knot.parse().ok()?;
    ((1..=model::MAX_JOINTS).contains(&joint) && (1..=model::servo::MAX_KNOTS).contains(&knot))
        .then(|| (joint - 1, knot - 1))
}

/// The name of knot `knot` of joint `joint`'s curve (both from 0).
fn servo_knot_name(joint: usize, knot: usize) -> String {
    format!("j{}.servo[{}]", joint + 1, knot + 1)
}

/// The joint (from 0) of a backlash parameter name, `j<joint>.backlash`
/// (joint from 1, as in every message).
fn backlash_from_name(name: &str) -> Option<usize> {
    let joint: usize = name
        .strip_prefix('j')?
        .strip_suffix(".backlash")?
        .parse()
        .ok()?;
    (1..=model::MAX_JOINTS).contains(&joint).then(|| joint - 1)
}

/// The name of joint `joint`'s (from 0) backlash width.
fn backlash_name(joint: usize) -> String {
    format!("j{}.backlash", joint + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn servo_knot_names_round_trip_and_refuse_what_is_out_of_range() {
        assert_eq!(servo_knot_from_name("j3.servo[5]"), Some((2, 4)));
        assert_eq!(servo_knot_name(2, 4), "j3.servo[5]");
        for bad in [
            "j0.servo[1]",
            "j11.servo[1]",
            "j1.servo[0]",
            "j1.servo[10]",
            "j1.servo[]",
            "j1.servo",
            "j1.theta",
        ] {
            assert_eq!(servo_knot_from_name(bad), None, "{bad}");
        }
    }

    #[test]
    fn keys_are_written_and_read_as_their_names() {
        let keys = [
            "j3.d",
            "k0",
            "s2",
            "tool[2].x",
            "j3.servo[5]",
            "j3.backlash",
            "camera.p1",
        ]
        .map(|n| ParamKey::from_name(n).unwrap());
        let json = serde_json::to_string(&keys).unwrap();
        assert_eq!(
            json,
            r#"["j3.d","k0","s2","tool[2].x","j3.servo[5]","j3.backlash","camera.p1"]"#
        );
        for key in ParamKey::lens() {
            assert_eq!(ParamKey::from_name(&key.name()), Some(key));
        }
        assert_eq!(ParamKey::from_name("camera.k4"), None);
        assert_eq!(serde_json::from_str::<Vec<ParamKey>>(&json).unwrap(), keys);
        let e = serde_json::from_str::<ParamKey>(r#""j3.dd""#).unwrap_err();
        assert!(e.to_string().contains("found `j3.dd`"), "{e}");
    }

    #[test]
    fn compliances_and_tool_axes_are_found_by_part() {
        let k = |n| ParamKey::from_name(n).unwrap();
        assert_eq!(k("k0").quantity(), Some(Quantity::Compliance { spring: 0 }));
        assert_eq!(k("k4").quantity(), Some(Quantity::Compliance { spring: 4 }));
        assert_eq!(k("j2.a").quantity(), None);
        assert_eq!(ParamKey::tool(0, 2), Some(k("tool.z")));
        assert_eq!(ParamKey::tool(0, 3), None);
        assert_eq!(ParamKey::tool(2, 0), Some(k("tool[2].x")));
    }

    #[test]
    fn backlash_names_round_trip_and_refuse_what_is_out_of_range() {
        assert_eq!(backlash_from_name("j6.backlash"), Some(5));
        assert_eq!(backlash_name(5), "j6.backlash");
        for bad in ["j0.backlash", "j11.backlash", "j.backlash", "j1.backlash2"] {
            assert_eq!(backlash_from_name(bad), None, "{bad}");
        }
    }
}
