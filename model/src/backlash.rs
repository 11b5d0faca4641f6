//! Play in a joint's drive (backlash): a joint stops short of its command by
//! half the play when it arrives rising and beyond it when it arrives falling.
//!
//! An RC servo stops as soon as its position is inside its dead band around
//! the command, and the horn's spline and the gears add play on top; both
//! leave the joint on the side it came from. So the angle a joint settles at
//! depends on the way it arrived, and the way it arrived is known to whoever
//! ordered the moves: the host from the order in which poses were measured,
//! the board from the targets it was sent. [`ApproachTracker`] follows it for
//! both, so identification and compensation agree on what "rising" means.
//!
//! The joint's actual angle is `q - s w / 2`, with `w` the full width of the
//! play (`Joint::backlash`) and `s = +1` rising, `-1` falling.

use crate::{PerJoint, Real, real};

/// The way a joint last moved to reach where it stands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Approach {
    /// Its command rose to the present one.
    #[default]
    Rising,
    /// Its command fell to the present one.
    Falling,
}

impl Approach {
    /// `+1` rising, `-1` falling.
    pub fn sign<T: Real>(self) -> T {
        match self {
            Approach::Rising => T::one(),
            Approach::Falling => -T::one(),
        }
    }

    /// The way a joint commanded from `from` to `to` arrives; a joint that is
    /// not moved keeps the way it arrived before (`self`): it stays where it stopped.
    pub fn towards<T: Real>(self, from: T, to: T) -> Approach {
        if to > from {
            Approach::Rising
        } else if to < from {
            Approach::Falling
        } else {
            self
        }
    }
}

/// The angle a joint with play of full width `width` settles at when it
/// arrives at `command` the way `approach`.
pub fn settled<T: Real>(command: T, width: T, approach: Approach) -> T {
    command - approach.sign::<T>() * width * real(0.5)
}

/// The command that makes a joint with play of full width `width` settle at
/// `angle` when it arrives the way `approach` (the inverse of [`settled`]).
pub fn command_for<T: Real>(angle: T, width: T, approach: Approach) -> T {
    angle + approach.sign::<T>() * width * real(0.5)
}

/// Follows the way each joint arrives at each of a sequence of commanded poses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApproachTracker<T> {
    last: PerJoint<T>,
    approach: PerJoint<Approach>,
}

impl<T: Real> ApproachTracker<T> {
    /// Starting at the commanded pose `start`, every joint taken to have
    /// reached it rising.
    pub fn new(start: &[T]) -> Self {
        Self {
            last: PerJoint::from_fn(start.len(), |j| start[j]),
            approach: PerJoint::splat(start.len(), Approach::Rising),
        }
    }

    /// Moves to the commanded pose `q` and returns the way each joint arrives.
    pub fn visit(&mut self, q: &[T]) -> PerJoint<Approach> {
        self.follow(q, T::zero())
    }

    /// Follows a command that moves in small steps (the board's servo
    /// frames): a joint turns round only once its command has gone back by
    /// more than `dead_band` (rad) from the furthest point it reached the
    /// way it was going, so jitter below it never flips the way in. With a
    /// zero dead band this is [`ApproachTracker::visit`].
    pub fn follow(&mut self, q: &[T], dead_band: T) -> PerJoint<Approach> {
        for ((&q, last), approach) in q.iter().zip(&mut self.last).zip(&mut self.approach) {
            // Further on the way the joint was going: compared, not
            // subtracted (the usual case while moving; on the board a
            // subtraction is a call).
            let onward = match approach {
                Approach::Rising => q > *last,
                Approach::Falling => q < *last,
            };
            if onward {
                *last = q;
                continue;
            }
            // How far the command went back.
            let back = match approach {
                Approach::Rising => *last - q,
                Approach::Falling => q - *last,
            };
            if back > dead_band {
                *approach = approach.towards(*last, q);
                *last = q;
            }
        }
        self.approach
    }

    /// The way each joint arrived at the last pose visited.
    pub fn approach(&self) -> PerJoint<Approach> {
        self.approach
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Approach::{Falling, Rising};

    #[test]
    fn a_joint_keeps_its_way_in_when_it_does_not_move() {
        let mut t = ApproachTracker::new(&[0.0f64; 6]);
        assert_eq!(
            t.visit(&[0.5, 0.0, -0.5, 0.0, 0.0, 0.0]),
            [Rising, Rising, Falling, Rising, Rising, Rising]
        );
        assert_eq!(
            t.visit(&[0.2, 0.0, -0.5, 0.3, 0.0, 0.0]),
            [Falling, Rising, Falling, Rising, Rising, Rising]
        );
        assert_eq!(
            t.visit(&[0.2, 1.0, 0.0, 0.3, -0.1, 0.0]),
            [Falling, Rising, Rising, Rising, Falling, Rising]
        );
        assert_eq!(t.approach()[4], Falling);
    }

    #[test]
    fn following_turns_round_only_beyond_the_dead_band() {
        let mut t = ApproachTracker::new(&[0.0f32; 6]);
        let way = |t: &mut ApproachTracker<f32>, x: f32| t.follow(&[x; 6], 1e-3)[0];
        assert_eq!(way(&mut t, 0.5), Rising);
        // Jitter below the dead band from the highest point keeps the way in.
        assert_eq!(way(&mut t, 0.4995), Rising);
        assert_eq!(way(&mut t, 0.5008), Rising);
        assert_eq!(way(&mut t, 0.4999), Rising);
        // Back by more than the dead band from 0.5008: falling, from there on.
        assert_eq!(way(&mut t, 0.4997), Falling);
        assert_eq!(way(&mut t, 0.4999), Falling);
        assert_eq!(way(&mut t, 0.2), Falling);
        assert_eq!(way(&mut t, 0.2011), Rising);
        // A zero dead band visits: any move decides.
        let (mut a, mut b) = (
            ApproachTracker::new(&[0.0; 6]),
            ApproachTracker::new(&[0.0; 6]),
        );
        for x in [0.3, 0.3, 0.1, 0.1, 0.2, -0.4, -0.4] {
            let q = [x, -x, 0.0, x, 1.0, x * x];
            assert_eq!(a.visit(&q), b.follow(&q, 0.0));
        }
    }

    #[test]
    fn following_compares_as_the_differences_would() {
        // The rule as first written: the signed way onward, then the dead band.
        fn by_differences(last: &mut f32, approach: &mut Approach, q: f32, dead_band: f32) {
            let onward = match approach {
                Rising => q - *last,
                Falling => *last - q,
            };
            if onward > 0.0 {
                *last = q;
            } else if onward < -dead_band {
                *approach = approach.towards(*last, q);
                *last = q;
            }
        }
        let values = [
            0.0f32,
            -0.0,
            1e-40,
            -1e-40,
            1e-3,
            -1e-3,
            0.5,
            0.5000001,
            -0.7,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for dead_band in [0.0f32, 2e-3, 1e-40] {
            for &a in &values {
                for &b in &values {
                    for start in [Rising, Falling] {
                        let mut t = ApproachTracker::new(&[a; 6]);
                        t.approach = PerJoint::splat(6, start);
                        let (mut last, mut way) = (a, start);
                        for q in [b, a, b] {
                            t.follow(&[q; 6], dead_band);
                            by_differences(&mut last, &mut way, q, dead_band);
                            assert_eq!(t.approach[0], way, "{a} {b} {start:?} {dead_band}");
                            assert_eq!(t.last[0].to_bits(), last.to_bits());
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn the_command_for_an_angle_undoes_the_play() {
        let w = 0.01f64;
        for way in [Rising, Falling] {
            let c = command_for(0.3, w, way);
            assert!((settled(c, w, way) - 0.3).abs() < 1e-15);
        }
        // Rising, the joint stops short; falling, beyond.
        assert!(settled(0.3, w, Rising) < 0.3);
        assert!(settled(0.3, w, Falling) > 0.3);
        assert_eq!(settled(0.3, 0.0, Falling), 0.3);
    }
}
