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
//! the knot's weight at that pose ([`knot_weight`], `calib::joint_columns`):
//! two model evaluations per joint instead of two per knot.

use model::{Arm, JOINTS, ServoCurve};

use super::params::ParamKey;
use super::{CalibError, Rig};

/// Knots per identified curve.
pub const KNOTS: usize = 9;

/// Degrees between identified knots; the grid spans ±100°, the range the
/// level-1 tuning covers.
pub const KNOT_SPACING_DEG: f64 = 25.0;

/// The identified curves' knot angles, rad: -100°, -75°, …, +100°.
pub fn grid_rad() -> [f64; KNOTS] {
    std::array::from_fn(|k| ((k as f64 - 4.0) * KNOT_SPACING_DEG).to_radians())
}

/// The knot parameters of every joint of `arm` driven through a servo
/// curve, joint by joint: the candidates our option adds to the paper's 43.
/// A joint without one (an arm moved by its own controller, whose file has
/// no `servo` table) has no curve to correct.
pub fn keys(arm: &Arm<f64>) -> impl Iterator<Item = ParamKey> + '_ {
    (0..JOINTS)
        .filter(|&joint| has_curve(&arm.joints[joint].servo))
        .flat_map(|joint| {
            (0..KNOTS).map(move |knot| ParamKey::ServoKnot {
                joint: joint as u8,
                knot: knot as u8,
            })
        })
}

/// Whether `curve` maps angle to pulse (a joint without a servo table has
/// a flat one the model never reads).
fn has_curve(curve: &ServoCurve<f64>) -> bool {
    curve.is_monotonic()
}

/// `arm` with every servo curve resampled on the [`grid_rad`] knots: the same
/// map where the curve's own knots are among the grid's, and the curve the
/// knot parameters move. A curve that already has [`KNOTS`] knots is kept
/// as it is: an identified one (a refit starts from it) has its knots' angles
/// moved off the grid, and resampling would move its pulses instead.
pub fn on_grid(arm: &Arm<f64>) -> Arm<f64> {
    let mut out = *arm;
    let grid = grid_rad();
    for joint in &mut out.joints {
        if joint.servo.knot_count() == KNOTS || !has_curve(&joint.servo) {
            continue;
        }
        // KNOTS <= MAX_KNOTS: resampling on the grid cannot fail.
        if let Ok(curve) = joint.servo.resampled(&grid) {
            joint.servo = curve;
        }
    }
    out
}

/// Where a fit of `keys` from `nominal` starts: its arm's curves on the grid
/// when a key is a servo knot ([`on_grid`]), `nominal` itself otherwise. The
/// measurements stay commanded through `nominal`'s `command_curves`.
pub fn fit_start(nominal: &Rig, keys: &[ParamKey]) -> Rig {
    let mut start = nominal.clone();
    if keys.iter().any(|k| matches!(k, ParamKey::ServoKnot { .. })) {
        start.arm = on_grid(&nominal.arm);
    }
    start
}

/// The joint angles the servos of `arm` (whose curves map the angles they
/// really reach to pulses) drive to when commanded `q` through the curves
/// `sent`, rad. A joint whose two curves are the same drives to `q` exactly.
pub fn reached(
    sent: &[ServoCurve<f64>; JOINTS],
    arm: &Arm<f64>,
    q: &[f64; JOINTS],
) -> [f64; JOINTS] {
    std::array::from_fn(|j| {
        let own = &arm.joints[j].servo;
        if sent[j] == *own {
            q[j]
        } else {
            own.angle(sent[j].pulse_us(q[j]))
        }
    })
}

/// d(reached angle of `joint`)/d(angle of `knot`) at commanded angle `q`:
/// the knot's weight in the interpolation, exact because the reached angle is
/// affine in the knot angles (the segment is chosen by the pulse, which the
/// knot angles do not move).
pub(super) fn knot_weight(rig: &Rig, joint: usize, knot: usize, q: f64) -> f64 {
    let pulse = rig.command_curves[joint].pulse_us(q);
    let own = rig.arm.joints[joint].servo;
    let mut moved = own;
    match moved.angles_rad_mut().get_mut(knot) {
        Some(angle) => *angle += 1.0,
        None => return 0.0,
    }
    moved.angle(pulse) - own.angle(pulse)
}

/// Checks that every curve the fit moved from `start`'s still maps angle to
/// pulse one-to-one: a fit that moved a knot past its neighbour made a curve
/// the board must never receive. A curve the fit left alone is the arm
/// file's (or none, for a joint without a servo table).
pub fn check_curves(start: &Arm<f64>, fitted: &Arm<f64>) -> Result<(), CalibError> {
    for (j, (was, joint)) in start.joints.iter().zip(&fitted.joints).enumerate() {
        if joint.servo == was.servo {
            continue;
        }
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
