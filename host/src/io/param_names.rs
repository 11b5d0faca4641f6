//! The names of the calibrated parameters that `model::ParamId` does not
//! name: the knots of each servo's curve (`j3.servo[5]`) and each joint's
//! backlash width (`j3.backlash`), as calibration files and messages write
//! them. Joints and knots are counted from 1 in names, from 0 in code.

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
