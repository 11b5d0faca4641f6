//! The typical size of each parameter's error on an arm: what the analysis
//! weighs a column's effect by, to tell a coupling no tracker resolves from
//! an identifiable direction.

use model::Arm;
use model::params::{ParamKind, ParamPart};

use crate::calib::parameters::params::ParamKey;

/// Typical sizes of the parameters' errors on one arm: 1 mm, 1 mrad, for
/// compliances 0.01 rad/Nm and for softenings 0.1 1/Nm on the bundled arm,
/// carried to another arm by the ratio of gravity torques ([`crate::scale`]):
/// the same sag angle, so a UR10's shoulder, a hundred times the torque,
/// gets 1e-4 rad/Nm; and the same change of compliance over the arm's
/// torques (`s |tau|`), so 1e-3 1/Nm there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TypicalErrors {
    /// A joint compliance's, rad/Nm.
    joint_compliance: f64,
    /// The base compliance's, rad/Nm.
    base_compliance: f64,
    /// A joint spring's softening, 1/Nm.
    joint_softening: f64,
    /// The base spring's softening, 1/Nm.
    base_softening: f64,
}

impl TypicalErrors {
    /// The typical errors of `arm`'s parameters.
    pub fn of_arm(arm: &Arm<f64>) -> Self {
        let [joints, base] = crate::scale::torque_ratio_to_bundled(arm);
        Self {
            joint_compliance: 1e-2 * joints,
            base_compliance: 1e-2 * base,
            joint_softening: 0.1 * joints,
            base_softening: 0.1 * base,
        }
    }

    /// A typical size of an error of `key`.
    pub fn of(&self, key: ParamKey) -> f64 {
        match key {
            ParamKey::Softening { spring: 0 } => self.base_softening,
            ParamKey::Softening { .. } => self.joint_softening,
            // A webcam's calibration is good to about 1 % in its focal
            // lengths and distortion; p1, p2 are tenths of that.
            ParamKey::Lens { field: 6 | 7 } => 1e-3,
            ParamKey::Lens { .. } => 1e-2,
            _ => match key.kind() {
                ParamKind::Length | ParamKind::Angle => 1e-3,
                ParamKind::Compliance => match key {
                    ParamKey::Arm(id) if id.part() == ParamPart::BaseCompliance => {
                        self.base_compliance
                    }
                    _ => self.joint_compliance,
                },
            },
        }
    }
}
