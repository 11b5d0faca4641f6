//! Each servo's own curve between its tuned points: the knot offsets our
//! model option (`elasto-kinematic-servo`) identifies with the rest.
//!
//! **What is identified.** A hobby servo commanded `q` through its level-1
//! curve (the arm file's, tuned at a few points) reaches `q + δ(q)`, with `δ`
//! smooth and unknown between the tuned points. The fit takes each joint's
//! curve on [`KNOTS`] knots every 25° over ±100° ([`on_grid`]: the same
//! angle → pulse map, resampled) and lets every knot's *angle* move, its pulse
//! fixed: knot `k` of the calibrated curve says which angle the pulse `p_k`
//! really reaches. A measurement commanded through the arm file's curve sent
//! the pulse `c_file(q)`, so the joint really stood at `c_fit⁻¹(c_file(q))`
//! ([`reached`]); when the file's knots are among the grid's (the default 3
//! and servo-tune's 5 are) this is exactly `q + δ(q)` with `δ` piecewise
//! linear through the knot offsets. The calibrated curve is then the file the
//! board needs as it is: commanding an angle through it sends the pulse that
//! reaches that angle.
//!
//! **Why 9 knots every 25°.** The most a curve holds (`model::servo`, whose
//! docs work out what a spacing follows of a smooth error); on the simulated
//! arms 5 knots (every 50°) leave the off-grid error twice the 9 knots' (see
//! `docs/METHOD.md`). A constant offset of all of a joint's knots is the
//! joint's `theta` (or, for joint 1, the base yaw): the knots come after the
//! paper's parameters in the rank analysis's preference order, so one knot
//! per joint is removed as confounded with them.
//!
//! **The Jacobian** of a knot column is exact and cheap: the reached angle is
//! affine in the knot angles (the segment is chosen by the pulse, which does
//! not move), so a knot's column is the joint-angle column of the model times
//! the knot's weight at that pose ([`jacobian_columns`]): two model
//! evaluations per joint instead of two per knot.

use model::{Arm, JOINTS};
use nalgebra::{DMatrix, Vector3};

use super::jacobian::tool_points;
use super::params::ParamKey;
use super::{CalibError, Sample};

/// Knots per identified curve.
pub const KNOTS: usize = 9;

/// Degrees between identified knots; the grid spans ±100°, the range the
/// level-1 tuning covers.
pub const KNOT_SPACING_DEG: f64 = 25.0;

/// The identified curves' knot angles, rad: -100°, -75°, …, +100°.
pub fn grid_rad() -> [f64; KNOTS] {
    std::array::from_fn(|k| ((k as f64 - 4.0) * KNOT_SPACING_DEG).to_radians())
}

/// The knot parameters of every joint, joint by joint: the candidates our
/// option adds to the paper's 43.
pub fn keys() -> impl Iterator<Item = ParamKey> {
    (0..JOINTS).flat_map(|joint| {
        (0..KNOTS).map(move |knot| ParamKey::ServoKnot {
            joint: joint as u8,
            knot: knot as u8,
        })
    })
}

/// `arm` with every servo curve resampled on the [`grid_rad`] knots: the same
/// map where the curve's own knots are among the grid's, and the curve the
/// knot parameters move.
pub fn on_grid(arm: &Arm<f64>) -> Arm<f64> {
    let mut out = *arm;
    let grid = grid_rad();
    for joint in &mut out.joints {
        // KNOTS <= MAX_KNOTS: resampling on the grid cannot fail.
        if let Ok(curve) = joint.servo.resampled(&grid) {
            joint.servo = curve;
        }
    }
    out
}

/// Where a fit of `keys` from `nominal` starts: on the grid when a key is a
/// servo knot ([`on_grid`]), `nominal` itself otherwise.
pub fn fit_start(nominal: &Arm<f64>, keys: &[ParamKey]) -> Arm<f64> {
    if keys.iter().any(|k| matches!(k, ParamKey::ServoKnot { .. })) {
        on_grid(nominal)
    } else {
        *nominal
    }
}

/// The joint angles the servos of `arm` (whose curves map the angles they
/// really reach to pulses) stand at when commanded `q` through `commanding`'s
/// curves, rad. A joint whose two curves are the same stands at `q` exactly.
pub fn reached(commanding: &Arm<f64>, arm: &Arm<f64>, q: &[f64; JOINTS]) -> [f64; JOINTS] {
    std::array::from_fn(|j| {
        let (sent, own) = (&commanding.joints[j].servo, &arm.joints[j].servo);
        if sent == own {
            q[j]
        } else {
            own.angle(sent.pulse_us(q[j]))
        }
    })
}

/// `samples` with their commanded angles replaced by the angles reached ([`reached`]).
pub fn reached_samples(commanding: &Arm<f64>, arm: &Arm<f64>, samples: &[Sample]) -> Vec<Sample> {
    samples
        .iter()
        .map(|s| Sample {
            q: reached(commanding, arm, &s.q),
            ..*s
        })
        .collect()
}

/// d(reached angle of `joint`)/d(angle of `knot`) at commanded angle `q`:
/// the knot's weight in the interpolation, exact because the reached angle is
/// affine in the knot angles.
fn knot_weight(commanding: &Arm<f64>, arm: &Arm<f64>, joint: usize, knot: usize, q: f64) -> f64 {
    let pulse = commanding.joints[joint].servo.pulse_us(q);
    let own = arm.joints[joint].servo;
    let mut moved = own;
    moved.angles_rad_mut()[knot] += 1.0;
    moved.angle(pulse) - own.angle(pulse)
}

/// The identification Jacobian's columns of the servo-knot `keys` (3 rows per
/// sample, as `jacobian::jacobian`), at `arm` commanded through `commanding`.
pub fn jacobian_columns(
    commanding: &Arm<f64>,
    arm: &Arm<f64>,
    keys: &[(usize, usize)],
    samples: &[Sample],
) -> Result<DMatrix<f64>, CalibError> {
    let mut j = DMatrix::zeros(3 * samples.len(), keys.len());
    let reached = reached_samples(commanding, arm, samples);
    // One central difference per joint that has a knot column: d point / d q_joint.
    let h = f64::EPSILON.cbrt();
    let mut joints: Vec<usize> = keys.iter().map(|&(joint, _)| joint).collect();
    joints.dedup();
    for joint in joints {
        let shifted = |by: f64| {
            let moved: Vec<Sample> = reached
                .iter()
                .map(|s| {
                    let mut s = *s;
                    s.q[joint] += by;
                    s
                })
                .collect();
            tool_points(arm, &moved)
        };
        let (up, down) = (shifted(h)?, shifted(-h)?);
        let slope: Vec<Vector3<f64>> = up
            .iter()
            .zip(&down)
            .map(|(u, d)| (u - d) / (2.0 * h))
            .collect();
        for (col, &(_, knot)) in keys.iter().enumerate().filter(|(_, k)| k.0 == joint) {
            for (i, (s, d)) in samples.iter().zip(&slope).enumerate() {
                let w = knot_weight(commanding, arm, joint, knot, s.q[joint]);
                j.fixed_view_mut::<3, 1>(3 * i, col).copy_from(&(d * w));
            }
        }
    }
    Ok(j)
}

/// Checks that every identified curve still maps angle to pulse one-to-one:
/// a fit that moved a knot past its neighbour made a curve the board must
/// never receive.
pub fn check_curves(arm: &Arm<f64>) -> Result<(), CalibError> {
    for (j, joint) in arm.joints.iter().enumerate() {
        if let Err(fault) = joint.servo.check() {
            let knots: Vec<String> = joint
                .servo
                .angles_rad()
                .iter()
                .map(|a| format!("{:.2}°", a.to_degrees()))
                .collect();
            return Err(CalibError::ServoCurve {
                joint: j + 1,
                fault: fault.to_string(),
                knots: knots.join(", "),
            });
        }
    }
    Ok(())
}
