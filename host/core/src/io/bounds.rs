//! A quantity outside its physical range ([`model::bounds`]) as a file
//! reader reports it: the key it was read from, the range and why.

use model::bounds::{Bounds, Quantity, Violation};

use crate::error::{InputError, Location, Problem};

/// The key of `quantity` under the arm object `arm` (`nominal`, `arm`, or ``
/// for an arm file), as the files spell it.
pub fn key(arm: &str, quantity: Quantity, toml: bool) -> String {
    let prefix = if arm.is_empty() {
        String::new()
    } else {
        format!("{arm}.")
    };
    let joint = |i: u8| {
        if toml {
            format!("{prefix}joint[{i}]")
        } else {
            format!("{prefix}joints[{i}]")
        }
    };
    match (quantity, toml) {
        (Quantity::Compliance { spring: 0 }, true) => format!("{prefix}base.compliance"),
        (Quantity::Compliance { spring: 0 }, false) => format!("{prefix}base_compliance"),
        (Quantity::Softening { spring: 0 }, _) => format!("{prefix}base_softening"),
        (Quantity::Compliance { spring }, _) => format!("{}.compliance", joint(spring)),
        (Quantity::Softening { spring }, _) => format!("{}.softening", joint(spring)),
        (Quantity::Backlash { joint: j }, _) => format!("{}.backlash", joint(j + 1)),
    }
}

/// What is wrong with `violation`, with the range and the torque it was worked out from.
pub fn problem(violation: &Violation<f64>, bounds: &Bounds<f64>, rated_kg: f64) -> Problem {
    let range = violation.range;
    let end = |x: f64| {
        if x.abs() >= f64::MAX / 2.0 {
            if x > 0.0 { "inf" } else { "-inf" }.to_string()
        } else {
            format!("{x:.6}")
        }
    };
    let torque = |spring: u8| {
        format!(
            "the largest torque the arm can put on spring {spring} (0 the base), with its rated \
             payload of {rated_kg} kg, is {:.3} Nm",
            bounds.torque_nm(usize::from(spring))
        )
    };
    let (what, unit, why) = match violation.quantity {
        Quantity::Compliance { spring } if spring > 0 && bounds.slides(usize::from(spring) - 1) => {
            (
                "a compliance",
                "m/N",
                format!(
                    "a prismatic joint's spring neither pushes against gravity nor gives way by \
                 more than {:.0} mm under the largest force on it; {} (N for this joint)",
                    model::bounds::MAX_SAG_M * 1e3,
                    torque(spring)
                ),
            )
        }
        Quantity::Backlash { joint } if bounds.slides(usize::from(joint)) => (
            "a backlash width",
            "m",
            format!(
                "up to {:.0} mm: no play is narrower than none, and a slide's play is a \
                 fraction of a millimetre",
                model::bounds::MAX_BACKLASH_M * 1e3
            ),
        ),
        Quantity::Compliance { spring } => (
            "a compliance",
            "rad/Nm",
            format!(
                "a spring neither bends against gravity nor sags more than {:.0}° under its \
                 largest torque; {}",
                model::bounds::MAX_SAG_RAD.to_degrees(),
                torque(spring)
            ),
        ),
        Quantity::Softening { spring } => (
            "a softening",
            "1/Nm",
            format!(
                "at its largest torque a spring's compliance may at most halve (its yield must \
                 still grow) or double; {}",
                torque(spring)
            ),
        ),
        Quantity::Backlash { .. } => (
            "a backlash width",
            "rad",
            format!(
                "up to {:.0}°: no play is narrower than none, nor wider than the board \
                 compensates; found {:.2}°",
                model::bounds::MAX_BACKLASH_RAD.to_degrees(),
                violation.value.to_degrees()
            ),
        ),
    };
    Problem::Invalid {
        message: format!(
            "expected {what} within [{}, {}] {unit} ({why}), found {}",
            end(range.min),
            end(range.max),
            violation.value
        ),
    }
}

/// Checks `arm` (at key `arm_key`) against the bounds of the nominal arm `nominal`.
pub fn check(
    nominal: &model::Arm<f64>,
    arm: &model::Arm<f64>,
    arm_key: &str,
    line: Option<u64>,
    toml: bool,
) -> Result<(), InputError> {
    let bounds = Bounds::of(nominal);
    bounds.check(arm).map_err(|v| {
        InputError::new(
            Location::key(line, key(arm_key, v.quantity, toml)),
            problem(&v, &bounds, nominal.rated_payload_kg),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_name_the_files_fields() {
        let q = |spring| Quantity::Softening { spring };
        assert_eq!(key("arm", q(0), false), "arm.base_softening");
        assert_eq!(key("nominal", q(2), false), "nominal.joints[2].softening");
        assert_eq!(
            key("", Quantity::Compliance { spring: 0 }, true),
            "base.compliance"
        );
        assert_eq!(
            key("", Quantity::Compliance { spring: 6 }, true),
            "joint[6].compliance"
        );
        assert_eq!(
            key("arm", Quantity::Backlash { joint: 0 }, false),
            "arm.joints[1].backlash"
        );
    }
}
