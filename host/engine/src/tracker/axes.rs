//! Turning a tracker's frame so that a chosen axis points up.
//!
//! Motive's default frame is Y-up, DTrack's rooms and the arm descriptions of
//! `lrmcal` are usually Z-up. `--up +y` rotates the measured points by the
//! right-handed rotation that takes the tracker's up axis to +Z: about X for
//! ±Y and ±Z, about Y for ±X. The result is a right-handed frame with Z up;
//! where its origin and heading are does not matter to the calibration once
//! the arm's base is placed in it.

use std::fmt;
use std::str::FromStr;

use nalgebra::{Rotation3, Vector3};

/// The tracker axis that points up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Up {
    /// +X up.
    PlusX,
    /// -X up.
    MinusX,
    /// +Y up (Motive's default).
    PlusY,
    /// -Y up.
    MinusY,
    /// +Z up (no change).
    PlusZ,
    /// -Z up.
    MinusZ,
}

const NAMES: [(&str, Up); 6] = [
    ("+x", Up::PlusX),
    ("-x", Up::MinusX),
    ("+y", Up::PlusY),
    ("-y", Up::MinusY),
    ("+z", Up::PlusZ),
    ("-z", Up::MinusZ),
];

impl FromStr for Up {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        NAMES
            .iter()
            .find(|(name, _)| name.eq_ignore_ascii_case(s))
            .map(|(_, up)| *up)
            .ok_or_else(|| format!("expected one of +x, -x, +y, -y, +z, -z, found `{s}`"))
    }
}

impl fmt::Display for Up {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = NAMES
            .iter()
            .find(|(_, up)| up == self)
            .map_or("?", |(n, _)| n);
        f.write_str(name)
    }
}

impl Up {
    /// The rotation from the tracker's frame to the Z-up frame.
    pub fn rotation(self) -> Rotation3<f64> {
        let quarter = std::f64::consts::FRAC_PI_2;
        match self {
            Self::PlusX => Rotation3::from_axis_angle(&Vector3::y_axis(), -quarter),
            Self::MinusX => Rotation3::from_axis_angle(&Vector3::y_axis(), quarter),
            Self::PlusY => Rotation3::from_axis_angle(&Vector3::x_axis(), quarter),
            Self::MinusY => Rotation3::from_axis_angle(&Vector3::x_axis(), -quarter),
            Self::PlusZ => Rotation3::identity(),
            Self::MinusZ => Rotation3::from_axis_angle(&Vector3::x_axis(), 2.0 * quarter),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_choice_turns_its_axis_up_and_stays_right_handed() {
        for (name, up) in NAMES {
            assert_eq!(name.parse::<Up>().unwrap(), up);
            assert_eq!(up.to_string(), name);
            let sign = if name.starts_with('-') { -1.0 } else { 1.0 };
            let axis = match &name[1..] {
                "x" => Vector3::x(),
                "y" => Vector3::y(),
                _ => Vector3::z(),
            } * sign;
            let r = up.rotation();
            assert!((r * axis - Vector3::z()).norm() < 1e-12, "{name}");
            assert!((r.matrix().determinant() - 1.0).abs() < 1e-12);
        }
        // Motive's Y-up: x stays, up becomes z, and z (toward the viewer) becomes -y.
        let p = Up::PlusY.rotation() * Vector3::new(1.0, 2.0, 3.0);
        assert!((p - Vector3::new(1.0, -3.0, 2.0)).norm() < 1e-12);
        assert!("up".parse::<Up>().unwrap_err().contains("+x, -x"));
    }
}
