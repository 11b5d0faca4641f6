//! The model options a calibration file names: the paper's three and ours,
//! the elasto-kinematic model with each servo's own curve between its tuned
//! points (`docs/METHOD.md`), and the names of the servo-knot parameters.
//!
//! The board stores only the paper's option ([`protocol::ModelOption`]): what
//! ours adds lives in the calibrated servo curves the payload already carries,
//! and the board compensates an elasto-kinematic-servo calibration exactly as
//! an elasto-kinematic one. So ours goes on the wire as elasto-kinematic
//! ([`ModelOption::wire`]) and the protocol stays as it is.

use serde::{Deserialize, Deserializer, Serialize, Serializer, de::Error};

/// Which parameters a calibration identified. Serialized by its name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelOption {
    /// The paper's geometric and elastic parameters, plus each servo's curve
    /// between its tuned points (knot offsets) and each joint's backlash
    /// width. The default.
    ElastoKinematicServo,
    /// The paper's geometric and elastic parameters (28 in the paper).
    ElastoKinematic,
    /// Geometric parameters only (21 in the paper).
    Kinematic,
    /// Compliances only (7).
    Elastic,
}

impl ModelOption {
    /// Every option, worst model first: the paper's table order, then ours.
    pub const ALL: [ModelOption; 4] = [
        Self::Kinematic,
        Self::Elastic,
        Self::ElastoKinematic,
        Self::ElastoKinematicServo,
    ];

    /// The option `identify`, `select` and `demo` use unless told otherwise.
    pub const DEFAULT: ModelOption = Self::ElastoKinematicServo;

    /// The name used on the command line and in calibration files.
    pub fn name(self) -> &'static str {
        match self {
            Self::ElastoKinematicServo => "elasto-kinematic-servo",
            Self::ElastoKinematic => "elasto-kinematic",
            Self::Kinematic => "kinematic",
            Self::Elastic => "elastic",
        }
    }

    /// The option called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|o| o.name() == name)
    }

    /// Whether the option fits the servo curves' knot offsets.
    pub fn fits_servo_curves(self) -> bool {
        self == Self::ElastoKinematicServo
    }

    /// Whether the option fits the joints' backlash widths (`calib::backlash`).
    pub fn fits_backlash(self) -> bool {
        self == Self::ElastoKinematicServo
    }

    /// The option the board stores (see the module docs).
    pub fn wire(self) -> protocol::ModelOption {
        match self {
            Self::ElastoKinematicServo | Self::ElastoKinematic => {
                protocol::ModelOption::ElastoKinematic
            }
            Self::Kinematic => protocol::ModelOption::Kinematic,
            Self::Elastic => protocol::ModelOption::Elastic,
        }
    }
}

impl std::fmt::Display for ModelOption {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The names every option has, for messages: `a, b, c or d`.
pub fn names() -> String {
    let names = ModelOption::ALL.map(ModelOption::name);
    format!(
        "{} or {}",
        names[..names.len() - 1].join(", "),
        names[names.len() - 1]
    )
}

/// Writes the option's name (`#[serde(with = "crate::io::model_option")]`).
pub fn serialize<S: Serializer>(option: &ModelOption, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(option.name())
}

/// Reads an option by name.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ModelOption, D::Error> {
    let name = String::deserialize(d)?;
    ModelOption::from_name(&name).ok_or_else(|| {
        D::Error::custom(format!(
            "unknown model option `{name}`: expected {}",
            names()
        ))
    })
}

/// The joint and knot (both from 0) of a servo-knot parameter name,
/// `j<joint>.servo[<knot>]`, both counted from 1 for people as everywhere
/// in messages (`j3.servo[5]`: the fifth knot of joint 3's curve).
pub fn servo_knot_from_name(name: &str) -> Option<(usize, usize)> {
    let (joint, rest) = name.strip_prefix('j')?.split_once(".servo[")?;
    let knot = rest.strip_suffix(']')?;
    let joint: usize = joint.parse().ok()?;
    let knot: usize = knot.parse().ok()?;
    ((1..=model::JOINTS).contains(&joint) && (1..=model::servo::MAX_KNOTS).contains(&knot))
        .then(|| (joint - 1, knot - 1))
}

/// The name of knot `knot` of joint `joint`'s curve (both from 0).
pub fn servo_knot_name(joint: usize, knot: usize) -> String {
    format!("j{}.servo[{}]", joint + 1, knot + 1)
}

/// The joint (from 0) of a backlash parameter name, `j<joint>.backlash`
/// (joint from 1, as in every message).
pub fn backlash_from_name(name: &str) -> Option<usize> {
    let joint: usize = name
        .strip_prefix('j')?
        .strip_suffix(".backlash")?
        .parse()
        .ok()?;
    (1..=model::JOINTS).contains(&joint).then(|| joint - 1)
}

/// The name of joint `joint`'s (from 0) backlash width.
pub fn backlash_name(joint: usize) -> String {
    format!("j{}.backlash", joint + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_ours_is_elasto_kinematic_on_the_wire() {
        for o in ModelOption::ALL {
            assert_eq!(ModelOption::from_name(o.name()), Some(o));
            assert_eq!(o.wire().name(), o.name().trim_end_matches("-servo"));
        }
        assert_eq!(ModelOption::from_name("rigid"), None);
        assert_eq!(
            names(),
            "kinematic, elastic, elasto-kinematic or elasto-kinematic-servo"
        );
    }

    #[test]
    fn servo_knot_names_round_trip_and_refuse_what_is_out_of_range() {
        assert_eq!(servo_knot_from_name("j3.servo[5]"), Some((2, 4)));
        assert_eq!(servo_knot_name(2, 4), "j3.servo[5]");
        for bad in [
            "j0.servo[1]",
            "j7.servo[1]",
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
    fn backlash_names_round_trip_and_refuse_what_is_out_of_range() {
        assert_eq!(backlash_from_name("j6.backlash"), Some(5));
        assert_eq!(backlash_name(5), "j6.backlash");
        for bad in ["j0.backlash", "j7.backlash", "j.backlash", "j1.backlash2"] {
            assert_eq!(backlash_from_name(bad), None, "{bad}");
        }
    }
}
