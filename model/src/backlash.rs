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

use crate::{JOINTS, Real, real};

/// The way a joint last moved to reach where it stands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Approach {
    /// Its command rose to the present one.
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
    last: [T; JOINTS],
    approach: [Approach; JOINTS],
}

impl<T: Real> ApproachTracker<T> {
    /// Starting at the commanded pose `start`, every joint taken to have
    /// reached it rising.
    pub fn new(start: [T; JOINTS]) -> Self {
        Self {
            last: start,
            approach: [Approach::Rising; JOINTS],
        }
    }

    /// Moves to the commanded pose `q` and returns the way each joint arrives.
    pub fn visit(&mut self, q: &[T; JOINTS]) -> [Approach; JOINTS] {
        for ((way, last), to) in self.approach.iter_mut().zip(&self.last).zip(q) {
            *way = way.towards(*last, *to);
        }
        self.last = *q;
        self.approach
    }

    /// The way each joint arrived at the last pose visited.
    pub fn approach(&self) -> [Approach; JOINTS] {
        self.approach
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Approach::{Falling, Rising};

    #[test]
    fn a_joint_keeps_its_way_in_when_it_does_not_move() {
        let mut t = ApproachTracker::new([0.0f64; JOINTS]);
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
