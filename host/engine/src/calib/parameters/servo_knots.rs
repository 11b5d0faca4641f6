//! Each servo's own curve between its tuned points: the knot offsets our
//! model option (`elasto-kinematic-servo`) identifies with the rest.
//!
//! **What is identified.** A hobby servo commanded `q` through its level-1
//! curve (the arm file's, tuned at a few points) reaches `q + δ(q)`, with `δ`
//! smooth and unknown between the tuned points. The fit takes each joint's
//! curve on knots evenly spaced over ±100° ([`on_grid`]: the same
//! angle → pulse map, resampled) and lets every knot's *angle* move, its pulse
//! fixed: knot `k` of the calibrated curve says which angle the pulse `p_k`
//! really reaches. A measurement commanded through the arm file's curve sent
//! the pulse `c_file(q)`, so the joint really stood at `c_fit⁻¹(c_file(q))`
//! (`model::command::reached`); when the file's knots are among the grid's (the default 3
//! are among every grid's, servo-tune's 5 among those every 25° and 50°)
//! this is exactly `q + δ(q)` with `δ` piecewise linear through the knot
//! offsets. The calibrated curve is then the file the
//! board needs as it is: commanding an angle through it sends the pulse that
//! reaches that angle.
//!
//! **How many knots.** The finest grid is 9 knots every 25° ([`KNOTS`]),
//! the most a curve holds (`model::servo`, whose docs work out what a
//! spacing follows of a smooth error); on the simulated arms 5 knots (every
//! 50°) leave the off-grid error twice the 9 knots' (see `docs/METHOD.md`).
//! But each knot is a parameter the poses must determine: from fewer poses a
//! coarser grid predicts better ([`KnotSpacing`]: every 25°, 50° or 100°;
//! the fit picks the one that predicts the poses it leaves out best,
//! `calib::knot_choice`). A knot is named by its place on the finest grid
//! whatever the spacing (`j3.servo[5]` is joint 3's knot at 0°), so a coarser
//! curve's knots are the finest grid's every second or fourth. A constant
//! offset of all of a joint's knots is the joint's `theta` (or, for joint 1,
//! the base yaw): the knots come after the paper's parameters in the rank
//! analysis's preference order, so one knot per joint is removed as
//! confounded with them.
//!
//! **The Jacobian** of a knot column is exact and cheap: the reached angle is
//! affine in the knot angles (the segment is chosen by the pulse, which does
//! not move), so a knot's column is the joint-angle column of the model times
//! the knot's weight at that pose ([`knot_weight`], `calib::joint_columns`):
//! two model evaluations per joint instead of two per knot.

use model::{Arm, ServoCurve};
use serde::{Deserialize, Serialize};

use crate::calib::{CalibError, Rig};
use lrmcal_core::param_key::ParamKey;

/// Knots of the finest identified grid, every [`FINEST_SPACING_DEG`] over
/// ±100°; a knot key's index counts on this grid.
pub const KNOTS: usize = 9;

/// Degrees between the finest grid's knots; the grid spans ±100°, the range
/// the level-1 tuning covers.
pub const FINEST_SPACING_DEG: f64 = 25.0;

/// How far apart the identified knots of the servo curves are.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub enum KnotSpacing {
    /// 9 knots, every 25°.
    #[serde(rename = "25deg")]
    Deg25,
    /// 5 knots, every 50°.
    #[serde(rename = "50deg")]
    Deg50,
    /// 3 knots, at -100°, 0° and +100° (the level-1 tuning's points).
    #[serde(rename = "100deg")]
    Deg100,
}

impl KnotSpacing {
    /// Every spacing, finest first.
    pub const ALL: [Self; 3] = [Self::Deg25, Self::Deg50, Self::Deg100];

    /// The finest spacing, the default grid.
    pub const FINEST: Self = Self::Deg25;

    /// Knots of the finest grid from one knot to the next.
    fn step(self) -> usize {
        match self {
            Self::Deg25 => 1,
            Self::Deg50 => 2,
            Self::Deg100 => 4,
        }
    }

    /// Degrees between knots.
    pub fn degrees(self) -> f64 {
        FINEST_SPACING_DEG * self.step() as f64
    }

    /// Knots of a curve on this grid.
    pub fn knots(self) -> usize {
        (KNOTS - 1) / self.step() + 1
    }

    /// The next coarser spacing, if any.
    pub fn coarser(self) -> Option<Self> {
        match self {
            Self::Deg25 => Some(Self::Deg50),
            Self::Deg50 => Some(Self::Deg100),
            Self::Deg100 => None,
        }
    }

    /// Whether knot `knot` of the finest grid is one of this grid's.
    pub fn holds(self, knot: usize) -> bool {
        knot < KNOTS && knot.is_multiple_of(self.step())
    }

    /// The grid's knot angles, rad, from -100° to +100°.
    pub fn angles_rad(self) -> Vec<f64> {
        (0..KNOTS)
            .filter(|&k| self.holds(k))
            .map(finest_angle_rad)
            .collect()
    }

    /// The spacing of a curve of `knots` knots on a grid, if it is one's.
    fn of_knot_count(knots: usize) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.knots() == knots)
    }

    /// The coarsest spacing whose grid holds every one of `knots` (indices
    /// on the finest grid).
    fn holding(knots: impl Iterator<Item = usize> + Clone) -> Self {
        Self::ALL
            .into_iter()
            .rev()
            .find(|s| knots.clone().all(|k| s.holds(k)))
            .unwrap_or(Self::FINEST)
    }
}

impl std::fmt::Display for KnotSpacing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "every {}°", self.degrees())
    }
}

/// Angle of knot `knot` of the finest grid, rad: -100°, -75°, …, +100°.
fn finest_angle_rad(knot: usize) -> f64 {
    ((knot as f64 - 4.0) * FINEST_SPACING_DEG).to_radians()
}

/// Where knot `knot` (an index on the finest grid) is among the knots of
/// `curve`, a curve on one of the grids: the same index on a 9-knot curve,
/// every second on a 5-knot one, every fourth on a 3-knot one; `None` when
/// the curve has no such knot.
pub fn curve_index(curve: &ServoCurve<f64>, knot: usize) -> Option<usize> {
    let spacing = KnotSpacing::of_knot_count(curve.knot_count())?;
    spacing.holds(knot).then(|| knot / spacing.step())
}

/// The knot parameters of every joint of `arm` driven through a servo
/// curve, joint by joint, on the grid of `spacing`: the candidates our
/// option adds to the paper's 43. A joint without one (an arm moved by its
/// own controller, whose file has no `servo` table) has no curve to correct.
pub fn keys(arm: &Arm<f64>, spacing: KnotSpacing) -> impl Iterator<Item = ParamKey> + '_ {
    (0..arm.joints.len())
        .filter(|&joint| arm.joints[joint].servo.is_some())
        .flat_map(move |joint| {
            (0..KNOTS)
                .filter(move |&knot| spacing.holds(knot))
                .map(move |knot| ParamKey::ServoKnot {
                    joint: joint as u8,
                    knot: knot as u8,
                })
        })
}

/// `keys` without the knots off the grid of `spacing`.
pub fn on_spacing(keys: &[ParamKey], spacing: KnotSpacing) -> Vec<ParamKey> {
    keys.iter()
        .copied()
        .filter(|k| match k {
            ParamKey::ServoKnot { knot, .. } => spacing.holds(usize::from(*knot)),
            _ => true,
        })
        .collect()
}

/// `keys` with each joint's knots on the grid of `spacing`, finer or
/// coarser than theirs: the knots of that grid, less those the knots among
/// `keys` hold at the arm file's curve (the grid's knots of their spacing
/// that are not among them, `calib::identifiability`), in the place of the
/// first knot. A finer grid's knots are not all determined by poses
/// chosen for a coarser one: only a fit under a prior
/// (`calib::parameters::prior`) takes them.
pub fn respaced(keys: &[ParamKey], spacing: KnotSpacing) -> Vec<ParamKey> {
    let Some(own) = spacing_of(keys) else {
        return keys.to_vec();
    };
    let knots_of = |joint: u8| -> Vec<usize> {
        keys.iter()
            .filter_map(|k| match k {
                ParamKey::ServoKnot { joint: j, knot } if *j == joint => Some(usize::from(*knot)),
                _ => None,
            })
            .collect()
    };
    let mut joints: Vec<u8> = Vec::new();
    for k in keys {
        if let ParamKey::ServoKnot { joint, .. } = k
            && !joints.contains(joint)
        {
            joints.push(*joint);
        }
    }
    let respaced = joints.iter().flat_map(|&joint| {
        let fitted = knots_of(joint);
        let held: Vec<usize> = (0..KNOTS)
            .filter(|k| own.holds(*k) && !fitted.contains(k))
            .collect();
        (0..KNOTS)
            .filter(move |k| spacing.holds(*k) && !held.contains(k))
            .map(move |knot| ParamKey::ServoKnot {
                joint,
                knot: knot as u8,
            })
    });
    let first = keys
        .iter()
        .position(|k| matches!(k, ParamKey::ServoKnot { .. }))
        .unwrap_or(keys.len());
    let others = |range: std::ops::Range<usize>| {
        keys[range]
            .iter()
            .copied()
            .filter(|k| !matches!(k, ParamKey::ServoKnot { .. }))
            .collect::<Vec<_>>()
    };
    let mut out = others(0..first);
    out.extend(respaced);
    out.extend(others(first..keys.len()));
    out
}

/// The spacing of the knots among `keys`: the coarsest grid holding every
/// knot key; `None` when there is none.
pub fn spacing_of(keys: &[ParamKey]) -> Option<KnotSpacing> {
    let knots = keys.iter().filter_map(|k| match k {
        ParamKey::ServoKnot { knot, .. } => Some(usize::from(*knot)),
        _ => None,
    });
    knots
        .clone()
        .next()
        .is_some()
        .then(|| KnotSpacing::holding(knots))
}

/// `arm` with the servo curve of every joint that has one resampled on the
/// knots of `spacing`: the same map where the curve's own knots are among
/// the grid's, and the curve the knot parameters move. A curve that already
/// has as many knots as the grid is kept as it is: an identified one (a
/// refit starts from it) has its knots' angles moved off the grid, and
/// resampling would move its pulses instead.
pub fn on_grid(arm: &Arm<f64>, spacing: KnotSpacing) -> Arm<f64> {
    let mut out = *arm;
    let grid = spacing.angles_rad();
    for servo in out.joints.iter_mut().filter_map(|j| j.servo.as_mut()) {
        if servo.knot_count() == spacing.knots() {
            continue;
        }
        // Every grid has at most MAX_KNOTS knots: resampling cannot fail.
        if let Ok(curve) = servo.resampled(&grid) {
            *servo = curve;
        }
    }
    out
}

/// Where a fit of `keys` from `nominal` starts: its arm's curves on the grid
/// of the knots among `keys` ([`on_grid`], [`spacing_of`]), `nominal`
/// itself when there is none. The measurements stay commanded through
/// `nominal`'s `command_curves`.
pub fn fit_start(nominal: &Rig, keys: &[ParamKey]) -> Rig {
    let mut start = nominal.clone();
    if let Some(spacing) = spacing_of(keys) {
        start.arm = on_grid(&nominal.arm, spacing);
    }
    start
}

/// d(reached angle of `joint`)/d(angle of `knot`) at commanded angle `q`:
/// the knot's weight in the interpolation, exact because the reached angle is
/// affine in the knot angles (the segment is chosen by the pulse, which the
/// knot angles do not move).
pub(crate) fn knot_weight(rig: &Rig, joint: usize, knot: usize, q: f64) -> f64 {
    let (Some(sent), Some(own)) = (rig.command_curves[joint], rig.arm.joints[joint].servo) else {
        return 0.0;
    };
    let pulse = sent.pulse_us(q);
    let mut moved = own;
    match curve_index(&own, knot).and_then(|i| moved.angles_rad_mut().get_mut(i)) {
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
        let Some(curve) = joint.servo.filter(|_| joint.servo != was.servo) else {
            continue;
        };
        if let Err(fault) = curve.check() {
            let knots: Vec<String> = curve
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
