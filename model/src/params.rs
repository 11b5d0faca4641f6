//! The 43 error parameters of the method, each with a stable name.
//!
//! Order (and index): `j1.theta j1.d j1.a j1.alpha … j6.alpha` (0..24),
//! `base.x base.y base.z base.roll base.pitch base.yaw` (24..30),
//! `tool.x … tool.yaw` (30..36), `k1 … k6` (36..42), `k0` (42).
//! An error is a correction *added* to the nominal value of the arm field it
//! names; [`ParamId::value_mut`] gives that field.

use crate::{Arm, Real};

/// Number of error parameters.
pub const PARAM_COUNT: usize = 43;

const NAMES: [&str; PARAM_COUNT] = [
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
    "k0",
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

/// One of the 43 error parameters, by index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ParamId(u8);

impl ParamId {
    /// Every parameter in order.
    pub fn all() -> impl Iterator<Item = ParamId> + Clone {
        (0..PARAM_COUNT as u8).map(ParamId)
    }

    /// The parameter at `index`, if there is one.
    pub fn from_index(index: usize) -> Option<Self> {
        (index < PARAM_COUNT).then_some(ParamId(index as u8))
    }

    /// The parameter called `name` (e.g. `j3.d`, `base.pitch`, `k0`).
    pub fn from_name(name: &str) -> Option<Self> {
        NAMES
            .iter()
            .position(|n| *n == name)
            .map(|i| ParamId(i as u8))
    }

    /// Position in [`ParamId::all`].
    pub fn index(self) -> usize {
        self.0 as usize
    }

    /// Stable name.
    pub fn name(self) -> &'static str {
        NAMES[self.index()]
    }

    /// Physical kind.
    pub fn kind(self) -> ParamKind {
        match self.index() {
            0..24 => match self.index() % 4 {
                1 | 2 => ParamKind::Length,
                _ => ParamKind::Angle,
            },
            24..27 | 30..33 => ParamKind::Length,
            27..30 | 33..36 => ParamKind::Angle,
            _ => ParamKind::Compliance,
        }
    }

    /// Whether this is a geometric (kinematic) parameter, as opposed to a compliance.
    pub fn is_geometric(self) -> bool {
        self.kind() != ParamKind::Compliance
    }

    /// The arm field this parameter corrects.
    pub fn value_mut<T: Real>(self, arm: &mut Arm<T>) -> &mut T {
        let i = self.index();
        match i {
            0..24 => {
                let j = &mut arm.joints[i / 4];
                match i % 4 {
                    0 => &mut j.theta,
                    1 => &mut j.d,
                    2 => &mut j.a,
                    _ => &mut j.alpha,
                }
            }
            24..27 => &mut arm.base.xyz[i - 24],
            27..30 => &mut arm.base.rpy[i - 27],
            30..33 => &mut arm.tool.xyz[i - 30],
            33..36 => &mut arm.tool.rpy[i - 33],
            36..42 => &mut arm.joints[i - 36].compliance,
            _ => &mut arm.base_compliance,
        }
    }

    /// The current value of the field this parameter corrects.
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

    /// All 43 parameter values of this arm, in [`ParamId::all`] order.
    pub fn param_values(&self) -> [T; PARAM_COUNT] {
        core::array::from_fn(|i| ParamId(i as u8).value(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_are_unique() {
        for id in ParamId::all() {
            assert_eq!(ParamId::from_name(id.name()), Some(id));
        }
        assert_eq!(ParamId::from_name("j3.d").map(ParamId::index), Some(9));
        assert_eq!(
            ParamId::from_name("base.pitch").map(ParamId::index),
            Some(28)
        );
        assert_eq!(ParamId::from_name("k0").map(ParamId::index), Some(42));
        assert_eq!(ParamId::from_name("j7.d"), None);
    }

    #[test]
    fn kinds_partition_36_geometric_and_7_compliances() {
        assert_eq!(ParamId::all().filter(|p| p.is_geometric()).count(), 36);
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
