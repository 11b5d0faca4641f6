//! The calibration payload: what `lrmcal push` sends and the board keeps in flash.
//!
//! It is one postcard-encoded [`Calibration`]: the calibrated arm (whose
//! joints carry the servo curves, 2 to [`model::servo::MAX_KNOTS`] knots
//! each, and the joint limits, and which
//! carries the payload centre of mass), the nominal arm it was identified
//! against (the firmware needs it to know where the user means the tool to
//! be), the model option, the home pose and an id. On the wire it travels in
//! [`crate::CHUNK_LEN`] chunks behind a length and CRC-32 announced up
//! front; the board applies it only after the commit finds every byte, the
//! CRC and [`Calibration::check`] in order.

use model::Arm;
use model::bounds::{Bounds, Quantity};
use model::servo::CurveFault;

use crate::{CHANNELS, PerChannel};
use serde::{Deserialize, Serialize};

/// Largest encoded calibration, bytes: two `Arm<f32>` are about 840 with
/// three-knot servo curves and about 1,600 with nine-knot ones.
pub const MAX_CALIBRATION_LEN: usize = 2048;

/// The largest correction any calibration may allow a joint, rad (60°): the
/// board never commands a joint further than this from its nominal target.
pub const MAX_CORRECTION_RAD: f32 = core::f32::consts::FRAC_PI_3;

/// Which parameters the calibration identified; the model's own type
/// ([`model::ModelOption`]), re-exported here because the payload and
/// `status` carry it. Postcard encodes the variant's index, so its place in
/// `model` changes nothing on the wire.
pub use model::ModelOption;

/// A complete calibration as the board stores it, single precision.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Chosen by the host (e.g. a hash of the calibration file) to recognise it in `status`.
    pub id: u32,
    /// The model option it was identified with.
    pub option: ModelOption,
    /// The nominal arm: where a joint target means the tool to be.
    pub nominal: Arm<f32>,
    /// The calibrated arm: servo curves, joint limits, geometry, compliances, payload COM.
    pub calibrated: Arm<f32>,
    /// The pose `motion/home` goes to, nominal joint angles, rad.
    pub home_rad: PerChannel<f32>,
    /// How far the compensation may move each joint from its nominal
    /// target, rad: the host works it out from the calibration (the largest
    /// correction its model asks for within the limits, with a margin); a
    /// solve that asks for more is treated as failed. At most
    /// [`MAX_CORRECTION_RAD`].
    pub max_correction_rad: PerChannel<f32>,
}

/// What makes a calibration unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalibrationFault {
    /// The arm has `joints` joints where the board drives 1 to [`CHANNELS`],
    /// or the nominal arm, the calibrated arm, the home pose and the
    /// corrections do not all have the same number.
    JointCount {
        /// The calibrated arm's joints.
        joints: u8,
    },
    /// Joint `joint` (0-based) slides: the board drives revolute servo joints only.
    Prismatic {
        /// Joint index.
        joint: u8,
    },
    /// A number is NaN or infinite.
    NotFinite,
    /// Joint `joint` (0-based) has lower limit ≥ upper limit.
    Limits {
        /// Joint index.
        joint: u8,
    },
    /// Joint `joint` (0-based) has no servo curve: the board does not drive it.
    NoServo {
        /// Joint index.
        joint: u8,
    },
    /// Joint `joint`'s servo curve does not map angle to pulse one-to-one.
    ServoCurve {
        /// Joint index.
        joint: u8,
        /// What is wrong with it, and at which knot.
        fault: CurveFault,
    },
    /// A mass or the rated payload is negative.
    Negative,
    /// A compliance, softening or play of the nominal or the calibrated arm
    /// is outside its physical range ([`model::bounds`], worked out from the
    /// nominal arm).
    Bound {
        /// The quantity, named as the calibration file names it.
        quantity: Quantity,
        /// Whether it is the calibrated arm's (else the nominal's).
        calibrated: bool,
    },
    /// The home pose is outside the joint limits.
    Home,
    /// Joint `joint`'s largest correction is not a finite angle in
    /// `(0, MAX_CORRECTION_RAD]`.
    Correction {
        /// Joint index.
        joint: u8,
    },
}

impl core::fmt::Display for CalibrationFault {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::JointCount { joints } => write!(
                f,
                "an arm of {joints} joints: the board drives arms of 1 to {CHANNELS} joints, \
                 and the nominal and calibrated arms, the home pose and the corrections must \
                 all have that many"
            ),
            Self::Prismatic { joint } => write!(
                f,
                "joint {} is prismatic: the board drives revolute servo joints only, so this \
                 calibration is for the host (predict, validate, export)",
                joint + 1
            ),
            Self::NotFinite => f.write_str("a value is NaN or infinite"),
            Self::Limits { joint } => {
                write!(f, "joint {}: lower limit not below upper limit", joint + 1)
            }
            Self::NoServo { joint } => write!(
                f,
                "joint {} has no servo curve: the board drives servo joints only, so this \
                 calibration is for the host (predict, validate, export)",
                joint + 1
            ),
            Self::ServoCurve { joint, fault } => write!(
                f,
                "joint {}: the servo curve does not map angle to pulse one-to-one (monotonic): {fault}",
                joint + 1
            ),
            Self::Negative => f.write_str("a mass or the rated payload is negative"),
            Self::Bound {
                quantity,
                calibrated,
            } => write!(
                f,
                "`{quantity}` of the {} arm is outside its physical range (see the bounds in \
                 docs/METHOD.md)",
                if *calibrated { "calibrated" } else { "nominal" }
            ),
            Self::Home => f.write_str("the home pose is outside the joint limits"),
            Self::Correction { joint } => write!(
                f,
                "joint {}: the largest correction is not an angle above 0 and up to {:.0}°",
                joint + 1,
                MAX_CORRECTION_RAD.to_degrees()
            ),
        }
    }
}

impl Calibration {
    /// Checks that the board can run on this calibration. Both ends call it:
    /// the host before sending, the board before storing.
    pub fn check(&self) -> Result<(), CalibrationFault> {
        let joints = self.calibrated.joints.len();
        if !(1..=CHANNELS).contains(&joints)
            || [
                self.nominal.joints.len(),
                self.home_rad.len(),
                self.max_correction_rad.len(),
            ]
            .iter()
            .any(|&n| n != joints)
        {
            return Err(CalibrationFault::JointCount {
                joints: joints as u8,
            });
        }
        if let Some(joint) = (self
            .nominal
            .joints
            .iter()
            .chain(self.calibrated.joints.iter()))
        .position(|j| j.kind != model::JointKind::Revolute)
        {
            return Err(CalibrationFault::Prismatic {
                joint: (joint % joints) as u8,
            });
        }
        if !self.nominal.is_finite()
            || !self.calibrated.is_finite()
            || !self.home_rad.iter().all(|x| x.is_finite())
        {
            return Err(CalibrationFault::NotFinite);
        }
        let bounds = Bounds::of(&self.nominal);
        for (arm, calibrated) in [(&self.nominal, false), (&self.calibrated, true)] {
            if arm.rated_payload_kg < 0.0 || arm.joints.iter().any(|j| j.mass < 0.0) {
                return Err(CalibrationFault::Negative);
            }
            if let Err(v) = bounds.check(arm) {
                return Err(CalibrationFault::Bound {
                    quantity: v.quantity,
                    calibrated,
                });
            }
        }
        for (i, j) in self.calibrated.joints.iter().enumerate() {
            let joint = i as u8;
            if j.limits[0] >= j.limits[1] {
                return Err(CalibrationFault::Limits { joint });
            }
            j.servo
                .ok_or(CalibrationFault::NoServo { joint })?
                .check()
                .map_err(|fault| CalibrationFault::ServoCurve { joint, fault })?;
        }
        if let Some(joint) = self
            .max_correction_rad
            .iter()
            .position(|m| !(m.is_finite() && *m > 0.0 && *m <= MAX_CORRECTION_RAD))
        {
            return Err(CalibrationFault::Correction { joint: joint as u8 });
        }
        if !self.calibrated.within_limits(&self.home_rad) {
            return Err(CalibrationFault::Home);
        }
        Ok(())
    }

    /// Encodes the calibration for upload or storage; returns the bytes used in `buf`.
    pub fn encode<'a>(
        &self,
        buf: &'a mut [u8; MAX_CALIBRATION_LEN],
    ) -> Result<&'a [u8], postcard::Error> {
        postcard::to_slice(self, buf).map(|used| &*used)
    }

    /// Decodes and checks a calibration; `None` if the bytes are not one or it fails [`Calibration::check`].
    pub fn decode(bytes: &[u8]) -> Option<Self> {
        match postcard::take_from_bytes::<Self>(bytes) {
            Ok((c, [])) if c.check().is_ok() => Some(c),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn postcard_indices_of_the_paper_options_are_those_of_protocol_3() {
        let index = |o: ModelOption| {
            let mut buf = [0u8; 1];
            postcard::to_slice(&o, &mut buf).unwrap()[0]
        };
        assert_eq!(index(ModelOption::ElastoKinematic), 0);
        assert_eq!(index(ModelOption::Kinematic), 1);
        assert_eq!(index(ModelOption::Elastic), 2);
        assert_eq!(index(ModelOption::ElastoKinematicServo), 3);
        assert_eq!(index(ModelOption::PaperElastoKinematic), 4);
        assert_eq!(index(ModelOption::PaperKinematic), 5);
    }
}
