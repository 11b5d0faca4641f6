//! Each identified servo curve as a person reads it: against the angle
//! commanded, how far the joint really stands from where the arm file's
//! curve says it goes (reached minus commanded, `model::command::reached`),
//! with one standard deviation of that offset from the covariance of the
//! knot parameters, and the knots themselves.
//!
//! The offset at a commanded angle is affine in the knot angles
//! (`calib::parameters::servo_knots`, [`knot_weight`]), so its variance is
//! `wᵀ C w` with `w` the knots' weights there and `C` their covariance: exact
//! for the linearised fit, between the knots as at them. A knot the rank
//! analysis held (one per joint, its common offset being the joint's `theta`)
//! has no deviation of its own.

use serde::{Deserialize, Serialize};

use crate::calib::ParamKey;
use crate::calib::fit::identify::Identified;
use crate::calib::parameters::servo_knots::{curve_index, knot_weight};
use lrmcal_core::io::json;

/// Degrees between the points of a drawn curve.
const STEP_DEG: f64 = 2.5;

/// One joint's identified servo curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServoCurveReport {
    /// The joint, from 1.
    pub joint: usize,
    /// The curve's knots, in angle order.
    pub knots: Vec<KnotReport>,
    /// The offset and its deviation over the joint's range, every
    /// [`STEP_DEG`] degrees and at each knot.
    pub curve: Vec<CurvePoint>,
}

/// One knot of an identified curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KnotReport {
    /// The knot's parameter (written `j3.servo[5]`).
    pub name: ParamKey,
    /// The angle commanded through the arm file's curve that sends the
    /// knot's pulse, degrees.
    pub commanded_deg: f64,
    /// The angle that pulse really reaches, minus the commanded one, degrees.
    pub offset_deg: f64,
    /// One standard deviation of the offset, degrees; `null` for a knot
    /// not fitted (held by the rank analysis or at a bound).
    #[serde(default)]
    pub std_deg: Option<f64>,
}

/// A point of an identified curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Angle commanded, degrees.
    pub commanded_deg: f64,
    /// Reached minus commanded, degrees.
    pub offset_deg: f64,
    /// One standard deviation of the offset, degrees (`null` when the
    /// covariance could not be worked out).
    #[serde(deserialize_with = "json::nan_if_null")]
    pub std_deg: f64,
}

/// The servo curves `fit` identified, one per joint with a fitted knot.
pub fn servo_curves(fit: &Identified) -> Vec<ServoCurveReport> {
    // The free parameters, in the covariance's order.
    let free: Vec<ParamKey> = fit
        .estimates
        .iter()
        .filter(|e| e.std.is_some())
        .map(|e| e.id)
        .collect();
    let rig = &fit.rig;
    let mut joints: Vec<usize> = Vec::new();
    for e in &fit.estimates {
        if let ParamKey::ServoKnot { joint, .. } = e.id
            && !joints.contains(&usize::from(joint))
        {
            joints.push(usize::from(joint));
        }
    }
    joints.sort_unstable();
    joints
        .into_iter()
        .filter(|&j| j < rig.arm.joints.len() && j < rig.command_curves.len())
        .filter_map(|j| {
            let (Some(own), Some(sent)) = (rig.arm.joints[j].servo, rig.command_curves[j]) else {
                return None;
            };
            // Knots of the finest grid on this curve, with their place in the
            // covariance when fitted.
            let knots: Vec<(usize, usize, Option<usize>)> = (0..own.knot_count().max(9))
                .filter_map(|k| {
                    let i = curve_index(&own, k)?;
                    let key = ParamKey::ServoKnot {
                        joint: j as u8,
                        knot: k as u8,
                    };
                    Some((k, i, free.iter().position(|f| *f == key)))
                })
                .collect();
            let offset = |q: f64| own.angle(sent.pulse_us(q)) - q;
            let std = |q: f64| {
                let mut var = 0.0;
                for &(ka, _, ca) in &knots {
                    let Some(ca) = ca else { continue };
                    let wa = knot_weight(rig, j, ka, q);
                    for &(kb, _, cb) in &knots {
                        let Some(cb) = cb else { continue };
                        var += wa * knot_weight(rig, j, kb, q) * fit.covariance[(ca, cb)];
                    }
                }
                var.max(0.0).sqrt()
            };
            let knot_reports: Vec<KnotReport> = knots
                .iter()
                .map(|&(k, i, c)| {
                    let commanded = sent.angle(own.pulses_us()[i]);
                    KnotReport {
                        name: ParamKey::ServoKnot {
                            joint: j as u8,
                            knot: k as u8,
                        },
                        commanded_deg: commanded.to_degrees(),
                        offset_deg: (own.angles_rad()[i] - commanded).to_degrees(),
                        std_deg: c.map(|c| fit.covariance[(c, c)].max(0.0).sqrt().to_degrees()),
                    }
                })
                .collect();
            let [lo, hi] = rig.arm.joints[j].limits.map(f64::to_degrees);
            let mut at: Vec<f64> = Vec::new();
            let mut q = lo;
            while q < hi {
                at.push(q);
                q += STEP_DEG;
            }
            at.push(hi);
            at.extend(
                knot_reports
                    .iter()
                    .map(|k| k.commanded_deg)
                    .filter(|d| (lo..=hi).contains(d)),
            );
            at.sort_by(f64::total_cmp);
            at.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
            let curve = at
                .into_iter()
                .map(|d| {
                    let q = d.to_radians();
                    CurvePoint {
                        commanded_deg: d,
                        offset_deg: offset(q).to_degrees(),
                        std_deg: std(q).to_degrees(),
                    }
                })
                .collect();
            Some(ServoCurveReport {
                joint: j + 1,
                knots: knot_reports,
                curve,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::ModelOption;
    use crate::calib::fit::identify::{IdentifyOptions, identify};
    use crate::calib::parameters::servo_knots::{KnotSpacing, keys};
    use crate::calib::testing::{measure_rig, rigid_nominal, small_samples};
    use crate::calib::{Rig, Sample};

    /// A true arm whose joint-2 servo reaches 1.5° further than commanded
    /// at +50°: the fitted curve says so at that knot, within its deviation,
    /// and its band is as wide at a knot as the knot's own deviation.
    #[test]
    fn a_servo_error_shows_at_its_knot_with_its_deviation() {
        let arm = rigid_nominal();
        let spacing = KnotSpacing::Deg50;
        let nominal = Rig::from(crate::calib::parameters::servo_knots::on_grid(
            &arm, spacing,
        ));
        let mut truth = nominal.arm;
        // Knot at +50° is the 4th of 5 (index 3).
        truth.joints[1].servo.as_mut().unwrap().angles_rad_mut()[3] += 1.5f64.to_radians();
        let samples: Vec<Sample> = small_samples(60);
        // Commanded through the nominal curves, as a real arm is.
        let mut true_rig = Rig::from(truth);
        true_rig.command_curves = nominal.command_curves;
        let meas = measure_rig(&true_rig, &samples);
        let mut ks: Vec<ParamKey> = keys(&nominal.arm, spacing)
            .filter(|k| matches!(k, ParamKey::ServoKnot { joint: 1, knot } if *knot != 4))
            .collect();
        ks.extend(["j2.theta"].iter().map(|n| ParamKey::from_name(n).unwrap()));
        let fit = identify(
            &nominal,
            ModelOption::ElastoKinematicServo,
            &ks,
            &meas,
            &IdentifyOptions::default(),
        )
        .unwrap();
        let curves = servo_curves(&fit);
        assert_eq!(curves.len(), 1);
        let c = &curves[0];
        assert_eq!(c.joint, 2);
        assert_eq!(c.knots.len(), 5);
        let at50 = c
            .knots
            .iter()
            .find(|k| (k.commanded_deg - 50.0).abs() < 1e-6)
            .unwrap();
        let std = at50.std_deg.unwrap();
        assert!((at50.offset_deg - 1.5).abs() < 0.05 + 3.0 * std, "{at50:?}");
        // The held knot (0°) has no deviation of its own.
        let held = c
            .knots
            .iter()
            .find(|k| k.name.to_string() == "j2.servo[5]")
            .unwrap();
        assert_eq!(held.std_deg, None);
        let point = c
            .curve
            .iter()
            .find(|p| (p.commanded_deg - 50.0).abs() < 1e-9)
            .unwrap();
        assert!(
            (point.std_deg - std).abs() < 1e-9 * (1.0 + std),
            "{point:?}"
        );
        assert!((point.offset_deg - at50.offset_deg).abs() < 1e-9);
    }
}
