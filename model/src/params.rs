//! The error parameters of the method, each with a stable name, for an arm
//! of any number of joints `n` (at most [`MAX_JOINTS`]).
//!
//! Order of [`ParamId::all`]: `j1.theta j1.d j1.a j1.alpha … jn.alpha`,
//! `base.x base.y base.z base.roll base.pitch base.yaw`, `tool.x … tool.yaw`,
//! `k1 … kn`, `k0`: `5 n + 13` parameters, 43 for six joints. Hayati's
//! twists `j1.beta … jn.beta` ([`ParamId::beta`]) come after every other
//! id: a calibration adds the one of a link whose two joint axes are
//! nominally parallel ([`crate::arm::Joint::beta`]), where DH has no
//! parameter for their tilt.
//! A parameter's id does not depend on `n` (`j3.d` is the same id for every
//! arm), so its [`ParamId::index`] is a name's place in the table of the
//! longest arm, not a place in [`ParamId::all`].
//! An error is a correction *added* to the nominal value of the arm field it
//! names; [`ParamId::value_mut`] gives that field.

use crate::{Arm, MAX_JOINTS, Real};

/// Number of error parameters of an arm of [`MAX_JOINTS`] joints in
/// [`ParamId::all`], Hayati's twists not counted.
pub const MAX_PARAMS: usize = 5 * MAX_JOINTS + 13;

/// Every id there is: [`MAX_PARAMS`] and one Hayati twist per joint.
const IDS: usize = MAX_PARAMS + MAX_JOINTS;

/// Where each group of ids starts in the table.
const BASE: usize = 4 * MAX_JOINTS;
const TOOL: usize = BASE + 6;
const SPRINGS: usize = TOOL + 6;
const K0: usize = SPRINGS + MAX_JOINTS;
const BETA: usize = K0 + 1;

/// Number of error parameters of an arm of `joints` joints.
pub const fn param_count(joints: usize) -> usize {
    5 * joints + 13
}

const NAMES: [&str; IDS] = [
    "j1.theta",
    "j1.d",
    "j1.a",
    "j1.alpha",
    "j2.theta",
    "j2.d",
    "j2.a",
    "j2.alpha",
    "j3.theta",
    "j3.d",
    "j3.a",
    "j3.alpha",
    "j4.theta",
    "j4.d",
    "j4.a",
    "j4.alpha",
    "j5.theta",
    "j5.d",
    "j5.a",
    "j5.alpha",
    "j6.theta",
    "j6.d",
    "j6.a",
    "j6.alpha",
    "j7.theta",
    "j7.d",
    "j7.a",
    "j7.alpha",
    "j8.theta",
    "j8.d",
    "j8.a",
    "j8.alpha",
    "j9.theta",
    "j9.d",
    "j9.a",
    "j9.alpha",
    "j10.theta",
    "j10.d",
    "j10.a",
    "j10.alpha",
    "base.x",
    "base.y",
    "base.z",
    "base.roll",
    "base.pitch",
    "base.yaw",
    "tool.x",
    "tool.y",
    "tool.z",
    "tool.roll",
    "tool.pitch",
    "tool.yaw",
    "k1",
    "k2",
    "k3",
    "k4",
    "k5",
    "k6",
    "k7",
    "k8",
    "k9",
    "k10",
    "k0",
    "j1.beta",
    "j2.beta",
    "j3.beta",
    "j4.beta",
    "j5.beta",
    "j6.beta",
    "j7.beta",
    "j8.beta",
    "j9.beta",
    "j10.beta",
];

/// What physical quantity a parameter is, which sets its unit and scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamKind {
    /// A length, m.
    Length,
    /// An angle, rad.
    Angle,
    /// A compliance, rad/Nm; never negative in total.
    Compliance,
}

/// What an error parameter corrects, by part of the arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParamPart {
    /// Link field `field` (0 theta, 1 d, 2 a, 3 alpha, 4 Hayati's beta) of
    /// joint `joint` (from 0).
    Dh {
        /// The joint, from 0.
        joint: usize,
        /// 0 theta, 1 d, 2 a, 3 alpha, 4 beta.
        field: usize,
    },
    /// Coordinate `axis` (0 x, 1 y, 2 z, 3 roll, 4 pitch, 5 yaw) of the base frame.
    Base {
        /// 0..3 translation, 3..6 roll, pitch, yaw.
        axis: usize,
    },
    /// Coordinate `axis` (as [`ParamPart::Base`]) of the tool frame.
    Tool {
        /// 0..3 translation, 3..6 roll, pitch, yaw.
        axis: usize,
    },
    /// The compliance of joint `joint` (from 0).
    Compliance {
        /// The joint, from 0.
        joint: usize,
    },
    /// The compliance of the base tilt, `k0`.
    BaseCompliance,
}

/// One error parameter, by its place in the table of the longest arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ParamId(u8);

impl ParamId {
    /// Every parameter of an arm of `joints` joints, in order (module docs).
    pub fn all(joints: usize) -> impl Iterator<Item = ParamId> + Clone {
        let n = joints.min(MAX_JOINTS);
        (0..4 * n)
            .chain(BASE..SPRINGS)
            .chain(SPRINGS..SPRINGS + n)
            .chain(K0..=K0)
            .map(|i| ParamId(i as u8))
    }

    /// Every parameter of `arm`, in order.
    pub fn of<T: Real>(arm: &Arm<T>) -> impl Iterator<Item = ParamId> + Clone {
        Self::all(arm.joints.len())
    }

    /// The parameter at table place `index`, if there is one.
    pub fn from_index(index: usize) -> Option<Self> {
        (index < IDS).then_some(ParamId(index as u8))
    }

    /// Hayati's twist `j<joint + 1>.beta` of joint `joint` (from 0).
    pub fn beta(joint: usize) -> Option<Self> {
        (joint < MAX_JOINTS).then_some(ParamId((BETA + joint) as u8))
    }

    /// The parameter called `name` (e.g. `j3.d`, `base.pitch`, `k0`), for an
    /// arm of any length: [`ParamId::fits`] says whether a given arm has it.
    pub fn from_name(name: &str) -> Option<Self> {
        NAMES
            .iter()
            .position(|n| *n == name)
            .map(|i| ParamId(i as u8))
    }

    /// Place in the table of the longest arm (module docs).
    pub fn index(self) -> usize {
        self.0 as usize
    }

    /// Stable name.
    pub fn name(self) -> &'static str {
        NAMES[self.index()]
    }

    /// The joint (from 0) whose geometry or spring this is; `None` for the
    /// base, the tool and `k0`.
    pub fn joint(self) -> Option<usize> {
        match self.index() {
            i if i < BASE => Some(i / 4),
            i if (SPRINGS..K0).contains(&i) => Some(i - SPRINGS),
            i if i >= BETA => Some(i - BETA),
            _ => None,
        }
    }

    /// What the parameter corrects.
    pub fn part(self) -> ParamPart {
        match self.index() {
            i if i < BASE => ParamPart::Dh {
                joint: i / 4,
                field: i % 4,
            },
            i if i < TOOL => ParamPart::Base { axis: i - BASE },
            i if i < SPRINGS => ParamPart::Tool { axis: i - TOOL },
            i if i < K0 => ParamPart::Compliance { joint: i - SPRINGS },
            K0 => ParamPart::BaseCompliance,
            i => ParamPart::Dh {
                joint: i - BETA,
                field: 4,
            },
        }
    }

    /// The parameter that corrects `part`, if the table has one (joints
    /// past [`MAX_JOINTS`], fields past 4 and axes past 5 have none).
    pub fn from_part(part: ParamPart) -> Option<Self> {
        let index = match part {
            ParamPart::Dh { joint, field } if joint < MAX_JOINTS && field < 4 => 4 * joint + field,
            ParamPart::Dh { joint, field: 4 } if joint < MAX_JOINTS => BETA + joint,
            ParamPart::Base { axis } if axis < 6 => BASE + axis,
            ParamPart::Tool { axis } if axis < 6 => TOOL + axis,
            ParamPart::Compliance { joint } if joint < MAX_JOINTS => SPRINGS + joint,
            ParamPart::BaseCompliance => K0,
            _ => return None,
        };
        Self::from_index(index)
    }

    /// Whether an arm of `joints` joints has this parameter.
    pub fn fits(self, joints: usize) -> bool {
        self.joint().is_none_or(|j| j < joints)
    }

    /// Physical kind.
    pub fn kind(self) -> ParamKind {
        match self.index() {
            i if i < BASE => match i % 4 {
                1 | 2 => ParamKind::Length,
                _ => ParamKind::Angle,
            },
            i if (BASE..BASE + 3).contains(&i) || (TOOL..TOOL + 3).contains(&i) => {
                ParamKind::Length
            }
            i if !(SPRINGS..BETA).contains(&i) => ParamKind::Angle,
            _ => ParamKind::Compliance,
        }
    }

    /// Whether this is a geometric (kinematic) parameter, as opposed to a compliance.
    pub fn is_geometric(self) -> bool {
        self.kind() != ParamKind::Compliance
    }

    /// The arm field this parameter corrects.
    ///
    /// # Panics
    /// If the arm lacks the parameter's joint ([`ParamId::fits`]).
    pub fn value_mut<T: Real>(self, arm: &mut Arm<T>) -> &mut T {
        match self.part() {
            ParamPart::Dh { joint, field } => {
                let j = &mut arm.joints[joint];
                match field {
                    0 => &mut j.theta,
                    1 => &mut j.d,
                    2 => &mut j.a,
                    3 => &mut j.alpha,
                    _ => &mut j.beta,
                }
            }
            ParamPart::Base { axis } if axis < 3 => &mut arm.base.xyz[axis],
            ParamPart::Base { axis } => &mut arm.base.rpy[axis - 3],
            ParamPart::Tool { axis } if axis < 3 => &mut arm.tool.xyz[axis],
            ParamPart::Tool { axis } => &mut arm.tool.rpy[axis - 3],
            ParamPart::Compliance { joint } => &mut arm.joints[joint].compliance,
            ParamPart::BaseCompliance => &mut arm.base_compliance,
        }
    }

    /// The current value of the field this parameter corrects (panics as
    /// [`ParamId::value_mut`]).
    pub fn value<T: Real>(self, arm: &Arm<T>) -> T {
        let mut copy = *arm;
        *self.value_mut(&mut copy)
    }
}

impl core::fmt::Display for ParamId {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

impl<T: Real> Arm<T> {
    /// The arm with `errors[k]` added to parameter `ids[k]`.
    ///
    /// Compliances are clamped at zero: a negative total compliance is not physical.
    pub fn with_errors(&self, ids: &[ParamId], errors: &[T]) -> Arm<T> {
        let mut arm = *self;
        for (&id, &e) in ids.iter().zip(errors) {
            let v = id.value_mut(&mut arm);
            *v += e;
            if id.kind() == ParamKind::Compliance && *v < T::zero() {
                *v = T::zero();
            }
        }
        arm
    }

    /// Every parameter value of this arm, in [`ParamId::of`] order.
    pub fn param_values(&self) -> impl Iterator<Item = T> + '_ {
        ParamId::of(self).map(|id| id.value(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::format;

    #[test]
    fn names_round_trip_and_are_unique() {
        for id in ParamId::all(MAX_JOINTS) {
            assert_eq!(ParamId::from_name(id.name()), Some(id));
        }
        assert_eq!(ParamId::all(MAX_JOINTS).count(), MAX_PARAMS);
        assert_eq!(ParamId::from_name("j3.d").map(ParamId::index), Some(9));
        assert_eq!(ParamId::from_name("j11.d"), None);
        let six: std::vec::Vec<_> = ParamId::all(6).map(ParamId::name).collect();
        assert_eq!(six.len(), param_count(6));
        assert_eq!(&six[22..26], ["j6.a", "j6.alpha", "base.x", "base.y"]);
        assert_eq!(&six[40..], ["k5", "k6", "k0"]);
        assert!(ParamId::from_name("j7.d").unwrap().fits(7));
        assert!(!ParamId::from_name("k7").unwrap().fits(6));
        assert!(ParamId::from_name("tool.z").unwrap().fits(1));
        let beta = ParamId::from_name("j3.beta").unwrap();
        assert_eq!(ParamId::beta(2), Some(beta));
        assert_eq!(beta.part(), ParamPart::Dh { joint: 2, field: 4 });
        assert!(beta.fits(3) && !beta.fits(2) && beta.is_geometric());
        assert!(ParamId::all(MAX_JOINTS).all(|id| id != beta));
    }

    #[test]
    fn parts_and_ids_are_one_to_one() {
        let every = (0..IDS).map(|i| ParamId::from_index(i).unwrap());
        for id in every {
            assert_eq!(ParamId::from_part(id.part()), Some(id), "{id}");
        }
        assert_eq!(
            ParamId::from_part(ParamPart::Base { axis: 4 }).map(ParamId::name),
            Some("base.pitch")
        );
        assert_eq!(ParamId::from_part(ParamPart::Tool { axis: 6 }), None);
        assert_eq!(
            ParamId::from_part(ParamPart::Compliance { joint: MAX_JOINTS }),
            None
        );
    }

    #[test]
    fn each_name_says_its_part() {
        // The table of names is written out once; this holds it to the parts.
        let axes = ["x", "y", "z", "roll", "pitch", "yaw"];
        let fields = ["theta", "d", "a", "alpha", "beta"];
        for i in 0..IDS {
            let id = ParamId::from_index(i).unwrap();
            let said = match id.part() {
                ParamPart::Dh { joint, field } => format!("j{}.{}", joint + 1, fields[field]),
                ParamPart::Base { axis } => format!("base.{}", axes[axis]),
                ParamPart::Tool { axis } => format!("tool.{}", axes[axis]),
                ParamPart::Compliance { joint } => format!("k{}", joint + 1),
                ParamPart::BaseCompliance => "k0".into(),
            };
            assert_eq!(id.name(), said);
        }
    }

    #[test]
    fn kinds_partition_36_geometric_and_7_compliances() {
        assert_eq!(ParamId::all(6).filter(|p| p.is_geometric()).count(), 36);
        assert_eq!(ParamId::all(2).filter(|p| !p.is_geometric()).count(), 3);
        assert_eq!(
            ParamId::from_name("j2.a").unwrap().kind(),
            ParamKind::Length
        );
        assert_eq!(
            ParamId::from_name("tool.yaw").unwrap().kind(),
            ParamKind::Angle
        );
        assert_eq!(
            ParamId::from_name("k0").unwrap().kind(),
            ParamKind::Compliance
        );
    }
}
