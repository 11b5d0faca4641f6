//! The physical bounds of what a calibration may say about an arm: one table,
//! derived from the arm where the arm decides, used by the fit (the bounds of
//! its least squares), by every reader of a calibration and by the board
//! before it stores one. A calibration the fit makes is inside them by
//! construction, so no reader refuses what `identify` writes.
//!
//! | quantity | range | why |
//! |---|---|---|
//! | compliance `k` of spring `s` | `0 ..= MAX_SAG_RAD / tau_s` | a negative one bends the arm against gravity; one that sags further than [`MAX_SAG_RAD`] under its largest torque does not hold a pose (a prismatic joint's: [`MAX_SAG_M`] under its largest force) |
//! | softening of spring `s` | `-1 / (2 tau_s) ..= 1 / tau_s` | the yield `k (1 + s |tau|) tau` must still grow at the largest torque (its rate `k (1 + 2 s |tau|)` stays >= 0, the compliance at least halves: a spring, not a snap-through), and the compliance may at most double there (beyond, a joint giving way, not a spring) |
//! | backlash (full width of the play) | `0 ..= MAX_BACKLASH_RAD` (a prismatic joint's `MAX_BACKLASH_M`) | the board offsets every command by half of it |
//!
//! `tau_s` is [`Bounds::torque_nm`]: an upper bound of the gravity torque on
//! spring `s` (0 the base tilt's, `1..=n` the joints') in any pose, with the
//! arm's rated payload ([`Arm::rated_payload_kg`]) at the tool. It is worked
//! out from the link lengths, masses and centres of mass alone, as the sum
//! of each mass times the longest lever it can have about the spring's axis
//! (the links between stretched out in a line, which is the real largest
//! torque of an arm that can reach out horizontally); so it costs a few
//! dozen operations and the board works out the very same bounds from the
//! nominal arm it stores. A spring that carries no torque (no mass beyond
//! it) has no bound on its compliance and softening: they change nothing.

use nalgebra::Vector3;

use crate::{Arm, JointKind, MAX_JOINTS, Real, real};

/// The most springs an arm has: the base tilt's (0) and the joints' (`1..=n`).
pub const MAX_SPRINGS: usize = MAX_JOINTS + 1;

/// The largest angle a linear spring may yield under the largest torque it
/// can meet, rad (about 29°): a joint that sags further is not a spring that
/// holds a pose. It also keeps the deflection's fixed-point iteration well
/// inside where it converges.
pub const MAX_SAG_RAD: f64 = 0.5;

/// The widest play a calibration may carry, rad (5°): a hobby servo's dead
/// band and horn play add up to a degree or two; a wider fitted play means a
/// loose joint or a bad fit, and compensating it would throw the joint by
/// half of it at every reversal.
pub const MAX_BACKLASH_RAD: f64 = 5.0 * core::f64::consts::PI / 180.0;

/// The furthest a prismatic joint may sag under the largest force it can
/// meet, m: a lift that gives way by more is not a spring holding a pose.
pub const MAX_SAG_M: f64 = 0.05;

/// The widest play a calibration may carry in a prismatic joint, m: a lead
/// screw's or belt's play is a fraction of a millimetre; more is a loose joint.
pub const MAX_BACKLASH_M: f64 = 0.005;

/// How far inside its bounds the fit keeps a value, relative: a value at a
/// bound stays inside after the board's rounding to single precision (a
/// relative 6e-8 per operation) of both the value and the bound.
pub const FIT_MARGIN: f64 = 1e-5;

/// A bounded quantity of the arm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// The compliance of a spring (0 the base's, `1..=n` the joints').
    Compliance {
        /// The spring.
        spring: u8,
    },
    /// The softening of a spring (0 the base's, `1..=n` the joints').
    Softening {
        /// The spring.
        spring: u8,
    },
    /// The full width of a joint's play (joint from 0).
    Backlash {
        /// The joint, from 0.
        joint: u8,
    },
}

impl Quantity {
    /// Every bounded quantity of an arm of `joints` joints: compliances,
    /// softenings, then the plays.
    pub fn all(joints: usize) -> impl Iterator<Item = Quantity> {
        let springs = 0..=joints as u8;
        springs
            .clone()
            .map(|spring| Quantity::Compliance { spring })
            .chain(springs.map(|spring| Quantity::Softening { spring }))
            .chain((0..joints as u8).map(|joint| Quantity::Backlash { joint }))
    }

    /// The quantity's value in `arm`; `None` for a spring or joint it lacks.
    pub fn value<T: Real>(self, arm: &Arm<T>) -> Option<T> {
        let joint = |i: usize| arm.joints.get(i);
        match self {
            Quantity::Compliance { spring: 0 } => Some(arm.base_compliance),
            Quantity::Compliance { spring } => joint(usize::from(spring) - 1).map(|j| j.compliance),
            Quantity::Softening { spring: 0 } => Some(arm.base_softening),
            Quantity::Softening { spring } => joint(usize::from(spring) - 1).map(|j| j.softening),
            Quantity::Backlash { joint: i } => joint(usize::from(i)).map(|j| j.backlash),
        }
    }
}

impl core::fmt::Display for Quantity {
    /// The names of the calibration file's parameters: `k0`, `s2`, `j3.backlash`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Quantity::Compliance { spring } => write!(f, "k{spring}"),
            Quantity::Softening { spring } => write!(f, "s{spring}"),
            Quantity::Backlash { joint } => write!(f, "j{}.backlash", joint + 1),
        }
    }
}

/// An inclusive range of a quantity's value; an end is infinite where the
/// quantity is not bounded that way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range<T> {
    /// Smallest value.
    pub min: T,
    /// Largest value.
    pub max: T,
}

impl<T: Real> Range<T> {
    /// Whether `x` is finite and inside.
    pub fn contains(&self, x: T) -> bool {
        x.is_finite() && x >= self.min && x <= self.max
    }

    /// The range with each finite, non-zero end moved inside by `relative`
    /// of its size ([`FIT_MARGIN`] for the fit).
    pub fn inner(&self, relative: f64) -> Self {
        let shrink = |end: T| end * (T::one() - real::<T>(relative));
        Self {
            min: if self.min < T::zero() {
                shrink(self.min)
            } else {
                self.min * (T::one() + real::<T>(relative))
            },
            max: if self.max > T::zero() {
                shrink(self.max)
            } else {
                self.max * (T::one() + real::<T>(relative))
            },
        }
    }
}

/// A quantity outside its range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Violation<T> {
    /// The quantity.
    pub quantity: Quantity,
    /// Its value in the arm.
    pub value: T,
    /// Its range.
    pub range: Range<T>,
}

/// The bounds of one arm's calibration (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds<T> {
    /// Upper bound of each spring's gravity torque, Nm (0 the base's; 0
    /// past the arm's last joint).
    torque_nm: [T; MAX_SPRINGS],
    /// Whether each joint slides: its compliance and play are lengths.
    prismatic: [bool; MAX_JOINTS],
}

impl<T: Real> Bounds<T> {
    /// The bounds of a calibration of the nominal arm `arm` (module docs):
    /// each spring's torque bound with the arm's rated payload at the tool.
    pub fn of(arm: &Arm<T>) -> Self {
        let mut prismatic = [false; MAX_JOINTS];
        for (p, j) in prismatic.iter_mut().zip(arm.joints.iter()) {
            *p = j.kind == JointKind::Prismatic;
        }
        Self {
            torque_nm: torque_bounds(arm),
            prismatic,
        }
    }

    /// Upper bound of the gravity torque on `spring` (0 the base's) in any
    /// pose with the rated payload, Nm; 0 past the last spring.
    pub fn torque_nm(&self, spring: usize) -> T {
        self.torque_nm.get(spring).copied().unwrap_or_else(T::zero)
    }

    /// Whether joint `joint` (from 0) slides: its spring and play are lengths.
    pub fn slides(&self, joint: usize) -> bool {
        self.prismatic.get(joint).copied().unwrap_or(false)
    }

    /// The range of `quantity` (module docs).
    pub fn range(&self, quantity: Quantity) -> Range<T> {
        let inf = T::max_value().unwrap_or_else(T::one);
        let tau = |spring: u8| self.torque_nm(usize::from(spring));
        match quantity {
            Quantity::Compliance { spring } => Range {
                min: T::zero(),
                max: if tau(spring) > T::zero() {
                    let sag = if spring > 0 && self.slides(usize::from(spring) - 1) {
                        MAX_SAG_M
                    } else {
                        MAX_SAG_RAD
                    };
                    real::<T>(sag) / tau(spring)
                } else {
                    inf
                },
            },
            Quantity::Softening { spring } if tau(spring) > T::zero() => Range {
                min: -T::one() / (tau(spring) + tau(spring)),
                max: T::one() / tau(spring),
            },
            Quantity::Softening { .. } => Range {
                min: -inf,
                max: inf,
            },
            Quantity::Backlash { joint } => Range {
                min: T::zero(),
                max: real(if self.slides(usize::from(joint)) {
                    MAX_BACKLASH_M
                } else {
                    MAX_BACKLASH_RAD
                }),
            },
        }
    }

    /// The first bounded quantity of `arm` outside its range (compliances,
    /// then softenings, then plays), if any.
    pub fn check(&self, arm: &Arm<T>) -> Result<(), Violation<T>> {
        for quantity in Quantity::all(arm.joints.len()) {
            let Some(value) = quantity.value(arm) else {
                continue;
            };
            let range = self.range(quantity);
            if !range.contains(value) {
                return Err(Violation {
                    quantity,
                    value,
                    range,
                });
            }
        }
        Ok(())
    }
}

/// Each spring's torque bound (module docs), Nm.
///
/// Link `j`'s centre of mass, seen from the origin `o_(j-1)` of the frame
/// before it, is `w_j = d_j z_(j-1) + a_j x_j + c_j`; in frame `j`'s own axes
/// `z_(j-1) = (0, sin alpha_j, cos alpha_j)`, so `|w_j|`, and its distance
/// from joint `j`'s own axis, do not depend on the pose. A joint's origin
/// moves from the last one by `sqrt(d² + a²)`. The lever of link `j` about
/// joint `i < j` is at most `|a_i| + Σ_(i<k<j) sqrt(d_k² + a_k²) + |w_j|`
/// (the `d_i` offset lies along joint `i`'s axis); about the base's axis,
/// through `o_0`, the sum runs from the first joint. The payload is a last
/// mass at the payload's centre in the last frame.
fn torque_bounds<T: Real>(arm: &Arm<T>) -> [T; MAX_SPRINGS] {
    let g = arm.gravity_vector().norm();
    let n = arm.joints.len();
    // A prismatic joint's offset reaches as far as its value does.
    let step = arm.joints.map(|j| match j.kind {
        JointKind::Revolute => (j.d * j.d + j.a * j.a).sqrt(),
        JointKind::Prismatic => j.d.abs() + j.limits[0].abs().max(j.limits[1].abs()) + j.a.abs(),
    });
    // Each mass with its w (frame of its last joint) and that joint's index.
    let tool = arm.tool.isometry();
    let payload = tool.translation.vector + tool.rotation * Vector3::from(arm.payload_com);
    let masses = (0..=n).map(|m| {
        let k = m.min(n - 1);
        let j = &arm.joints[k];
        let (s, c) = j.alpha.sin_cos();
        let axis = Vector3::new(T::zero(), s, c);
        let offset = if m < n { Vector3::from(j.com) } else { payload };
        let mass = if m < n { j.mass } else { arm.rated_payload_kg };
        let w = axis * j.d + Vector3::new(j.a, T::zero(), T::zero()) + offset;
        (k, mass, w, axis)
    });
    let mut torque = [T::zero(); MAX_SPRINGS];
    for (k, mass, w, axis) in masses {
        // The base: every joint's step before the mass's own link.
        let before: T = step[..k].iter().fold(T::zero(), |s, &x| s + x);
        torque[0] += mass * (before + w.norm());
        // Joint i + 1 (index i <= k): its own link exactly, the others by the line.
        for i in 0..=k {
            // A prismatic joint carries the weight itself, lever 1 (a force, N).
            let lever = if arm.joints[i].kind == JointKind::Prismatic {
                T::one()
            } else if i == k {
                (w - axis * w.dot(&axis)).norm()
            } else {
                let between: T = step[i + 1..k].iter().fold(T::zero(), |s, &x| s + x);
                arm.joints[i].a.abs() + between + w.norm()
            };
            torque[i + 1] += mass * lever;
        }
    }
    torque.map(|t| t * g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::TEST_ARM_JOINTS as JOINTS;
    use crate::testing::{lrm_like_arm, planar_arm};
    use crate::{Chain, SolverOptions};
    use rand::{Rng, SeedableRng};

    /// The bound is never below the torque of any pose, and near it for the
    /// pose that stretches an arm out horizontally.
    #[test]
    fn torque_bounds_bound_every_pose_and_are_reached_stretched_out() {
        for payload in [0.0, 0.0663, 0.5] {
            let mut arm = lrm_like_arm::<f64>();
            arm.rated_payload_kg = payload;
            let bounds = Bounds::of(&arm);
            let chain: Chain<f64> = arm.chain();
            let mut rng = rand::rngs::StdRng::seed_from_u64(7);
            let mut most = [0.0f64; MAX_SPRINGS];
            for _ in 0..20_000 {
                let q: [f64; JOINTS] = core::array::from_fn(|_| rng.random_range(-3.2..3.2));
                let t = chain.statics(&q, 0.0, payload).torques;
                most[0] = most[0].max(t.base.abs());
                for i in 0..JOINTS {
                    most[i + 1] = most[i + 1].max(t.joints[i].abs());
                }
            }
            for (s, m) in most.iter().enumerate() {
                assert!(
                    *m <= bounds.torque_nm(s) * (1.0 + 1e-12),
                    "spring {s}: {m} Nm above the bound {}",
                    bounds.torque_nm(s)
                );
            }
            // The shoulder (spring 2) nearly reaches its bound stretched out;
            // the base's counts the shoulder's height above it as lever too.
            for (s, share) in [(0, 0.6), (2, 0.9)] {
                assert!(
                    most[s] > share * bounds.torque_nm(s),
                    "spring {s}: {} vs {}",
                    most[s],
                    bounds.torque_nm(s)
                );
            }
            // The deflected state meets no larger torque than the rigid one's bound.
            let q = [0.0, 1.4, 0.2, 0.0, 0.3, 0.0];
            let d = chain
                .deflect(&q, payload, &SolverOptions::default())
                .unwrap();
            let t = chain.statics(&d.qa, d.beta, payload).torques;
            assert!(t.joints[1].abs() <= bounds.torque_nm(2));
        }
    }

    /// The planar arm's joint 1 carries links 1-3 along a line: exactly the bound.
    #[test]
    fn a_planar_arm_stretched_out_meets_its_bound_exactly() {
        let arm = planar_arm::<f64>();
        let bounds = Bounds::of(&arm);
        // Gravity along -z, the planar joints' axes along z: no gravity torque
        // on them at all; turned on its side, the stretched arm meets the bound.
        let mut side = arm;
        side.gravity = [0.0, -9.80665, 0.0];
        let t = side.chain().statics(&[0.0; JOINTS], 0.0, 0.0).torques;
        assert!((t.joints[0].abs() - bounds.torque_nm(1)).abs() < 1e-12);
    }

    /// A prismatic joint's bound is the weight it carries (a force), and
    /// its compliance and play are bounded as lengths.
    #[test]
    fn a_lift_is_bounded_by_its_weight_in_metres() {
        use crate::testing::{lift_arm, random_lift_q};
        let mut arm = lift_arm::<f64>();
        arm.rated_payload_kg = 0.1;
        let bounds = Bounds::of(&arm);
        let g = arm.gravity_vector().norm();
        let carried: f64 = arm.joints.iter().map(|j| j.mass).sum::<f64>() + 0.1;
        assert!((bounds.torque_nm(1) - g * carried).abs() < 1e-12);
        let k = bounds.range(Quantity::Compliance { spring: 1 });
        assert!((k.max - MAX_SAG_M / (g * carried)).abs() < 1e-15);
        let play = bounds.range(Quantity::Backlash { joint: 0 });
        assert_eq!(play.max, MAX_BACKLASH_M);
        assert_eq!(
            bounds.range(Quantity::Backlash { joint: 1 }).max,
            MAX_BACKLASH_RAD
        );
        // Every pose's torques stay within the bounds, the lift's force too.
        let chain = arm.chain();
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(4);
        for _ in 0..500 {
            let q = random_lift_q::<f64>(&mut rng);
            let t = chain.gravity_torques(&q, 0.0, 0.1).joints;
            for (i, tau) in t.iter().enumerate() {
                assert!(
                    tau.abs() <= bounds.torque_nm(i + 1) + 1e-9,
                    "joint {}",
                    i + 1
                );
            }
        }
    }

    #[test]
    fn ranges_follow_the_table() {
        let mut arm = lrm_like_arm::<f64>();
        arm.rated_payload_kg = 0.1;
        let b = Bounds::of(&arm);
        let tau = b.torque_nm(2);
        let k = b.range(Quantity::Compliance { spring: 2 });
        assert_eq!((k.min, k.max), (0.0, MAX_SAG_RAD / tau));
        let s = b.range(Quantity::Softening { spring: 2 });
        assert_eq!((s.min, s.max), (-0.5 / tau, 1.0 / tau));
        let w = b.range(Quantity::Backlash { joint: 5 });
        assert_eq!((w.min, w.max), (0.0, MAX_BACKLASH_RAD));
        // Inside by the fit's margin, still inside.
        let inner = s.inner(FIT_MARGIN);
        assert!(s.contains(inner.min) && s.contains(inner.max));
        assert!(inner.min > s.min && inner.max < s.max);
        assert_eq!(k.inner(FIT_MARGIN).min, 0.0);
    }

    #[test]
    fn check_names_the_first_quantity_outside() {
        let mut arm = lrm_like_arm::<f64>();
        let b = Bounds::of(&arm);
        assert_eq!(b.check(&arm), Ok(()));
        let floor = b.range(Quantity::Softening { spring: 3 }).min;
        arm.joints[2].softening = floor * 1.01;
        let v = b.check(&arm).unwrap_err();
        assert_eq!(v.quantity, Quantity::Softening { spring: 3 });
        assert_eq!(v.value, floor * 1.01);
        arm.joints[2].softening = floor;
        assert_eq!(b.check(&arm), Ok(()));
        arm.joints[4].backlash = -1e-9;
        assert_eq!(
            b.check(&arm).unwrap_err().quantity,
            Quantity::Backlash { joint: 4 }
        );
        arm.joints[4].backlash = 0.0;
        arm.base_compliance = f64::NAN;
        assert_eq!(
            b.check(&arm).unwrap_err().quantity,
            Quantity::Compliance { spring: 0 }
        );
        let names: std::vec::Vec<std::string::String> = [
            Quantity::Compliance { spring: 0 },
            Quantity::Softening { spring: 6 },
            Quantity::Backlash { joint: 2 },
        ]
        .iter()
        .map(std::string::ToString::to_string)
        .collect();
        assert_eq!(names, ["k0", "s6", "j3.backlash"]);
    }

    /// The board's single-precision bounds accept the fit's values at a bound.
    #[test]
    fn values_at_the_fits_bound_pass_in_single_precision() {
        let mut arm = lrm_like_arm::<f64>();
        arm.rated_payload_kg = 0.0663;
        let b = Bounds::of(&arm);
        for q in Quantity::all(6) {
            let r = b.range(q).inner(FIT_MARGIN);
            for end in [r.min, r.max] {
                if !end.is_finite() || end.abs() > 1e30 {
                    continue;
                }
                let mut at = arm;
                match q {
                    Quantity::Compliance { spring: 0 } => at.base_compliance = end,
                    Quantity::Compliance { spring } => {
                        at.joints[usize::from(spring) - 1].compliance = end
                    }
                    Quantity::Softening { spring: 0 } => at.base_softening = end,
                    Quantity::Softening { spring } => {
                        at.joints[usize::from(spring) - 1].softening = end
                    }
                    Quantity::Backlash { joint } => at.joints[usize::from(joint)].backlash = end,
                }
                let single = at.map(|x| x as f32);
                let bounds = Bounds::of(&arm.map(|x| x as f32));
                let r32 = bounds.range(q);
                let v = q.value(&single).unwrap();
                assert!(r32.contains(v), "{q}: {v} outside {r32:?}");
            }
        }
    }
}
