//! Joint motion: every joint follows the same trapezoidal speed profile,
//! scaled to its own distance, so all joints start and arrive together and
//! none exceeds the speed or acceleration limit.
//!
//! The joint with the longest way `D` sets the pace. With acceleration `a`
//! and a duration `T ≥ 2√(D/a)`, its peak speed is the smaller root of
//! `D = v (T − v/a)`, i.e. `v = (aT − √(a²T² − 4aD)) / 2`; the other joints
//! move by the same fraction of their way at every instant.
//!
//! A profile moves the arm's joints, however many: one value per joint in
//! each [`PerChannel`].

use crate::PerChannel;
use crate::float::{clamp, ordered};
use protocol::Timing;

/// Speed and acceleration limits of every joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionLimits {
    /// rad/s.
    pub max_speed_rad_s: f32,
    /// rad/s².
    pub max_accel_rad_s2: f32,
}

/// Why a move cannot be planned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlanError {
    /// A target, speed or the limits are not finite.
    NotFinite,
    /// A speed is not positive, the move would take longer than allowed, or
    /// start and end have different numbers of joints.
    OutOfRange,
}

/// One planned move from `start` to `end`, starting at `t0_us`, of every joint of the arm.
///
/// What the servo frame's [`Profile::at`] needs and only changes per move
/// (each joint's way, the trapezoid's area) is worked out once, here, and
/// it compares times on their bits (`crate::float`): on the Cortex-M0+ a
/// float subtraction or comparison is a call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    start: PerChannel<f32>,
    end: PerChannel<f32>,
    /// `end - start`, per joint.
    way: PerChannel<f32>,
    t0_us: u64,
    /// Total duration, s.
    duration_s: f32,
    /// Acceleration (and deceleration) phase, s.
    ramp_s: f32,
    /// `duration_s - ramp_s`: the area of the unit trapezoid with ramps
    /// `ramp_s` and top `duration_s - 2 ramp_s`, and when its top ends.
    area_s: f32,
}

impl Profile {
    /// Standing still at `q`.
    pub fn hold(q: PerChannel<f32>) -> Self {
        Self::new(q, q, 0, 0.0, 0.0)
    }

    /// The move from `start` to `end` (as many joints) over `duration_s`
    /// from `t0_us`, with ramps of `ramp_s`.
    fn new(
        start: PerChannel<f32>,
        end: PerChannel<f32>,
        t0_us: u64,
        duration_s: f32,
        ramp_s: f32,
    ) -> Self {
        Self {
            start,
            end,
            way: PerChannel::from_fn(end.len(), |i| end[i] - start[i]),
            t0_us,
            duration_s,
            ramp_s,
            area_s: duration_s - ramp_s,
        }
    }

    /// Plans a move; the duration is the requested one or the shortest the
    /// limits allow, whichever is longer, and at most `max_duration_s`.
    pub fn plan(
        start: PerChannel<f32>,
        end: PerChannel<f32>,
        t0_us: u64,
        timing: Timing,
        limits: MotionLimits,
        max_duration_s: f32,
    ) -> Result<Self, PlanError> {
        if start.len() != end.len() {
            return Err(PlanError::OutOfRange);
        }
        let a = limits.max_accel_rad_s2;
        let finite = start.iter().chain(&end).all(|x| x.is_finite());
        if !finite || !a.is_finite() || !limits.max_speed_rad_s.is_finite() {
            return Err(PlanError::NotFinite);
        }
        let speed = match timing {
            Timing::SpeedRadPerS(v) if !v.is_finite() => return Err(PlanError::NotFinite),
            Timing::SpeedRadPerS(v) if v <= 0.0 => return Err(PlanError::OutOfRange),
            Timing::SpeedRadPerS(v) => v.min(limits.max_speed_rad_s),
            Timing::DurationMs(_) => limits.max_speed_rad_s,
        };
        let way = start
            .iter()
            .zip(&end)
            .fold(0.0f32, |m, (s, e)| m.max((e - s).abs()));
        let fastest = if way >= speed * speed / a {
            way / speed + speed / a
        } else {
            2.0 * libm::sqrtf(way / a)
        };
        let wanted = match timing {
            Timing::DurationMs(ms) => ms as f32 / 1000.0,
            Timing::SpeedRadPerS(_) => 0.0,
        };
        let duration_s = fastest.max(wanted);
        if duration_s > max_duration_s {
            return Err(PlanError::OutOfRange);
        }
        if way == 0.0 || duration_s == 0.0 {
            return Ok(Self::new(end, end, t0_us, 0.0, 0.0));
        }
        let disc = (a * a * duration_s * duration_s - 4.0 * a * way).max(0.0);
        let peak = (a * duration_s - libm::sqrtf(disc)) / 2.0;
        let ramp_s = (peak / a).min(duration_s / 2.0);
        Ok(Self::new(start, end, t0_us, duration_s, ramp_s))
    }

    /// Where every joint is at `now_us`, and whether the move is over.
    pub fn at(&self, now_us: u64) -> (PerChannel<f32>, bool) {
        let t = now_us.saturating_sub(self.t0_us) as f32 * 1e-6;
        // Times are never NaN.
        if ordered(t) >= ordered(self.duration_s) {
            return (self.end, true);
        }
        let s = self.fraction(t);
        let mut q = self.start;
        for (q, way) in q.iter_mut().zip(&self.way) {
            *q += way * s;
        }
        (q, false)
    }

    /// Where the move ends.
    pub fn end(&self) -> PerChannel<f32> {
        self.end
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f32 {
        self.duration_s
    }

    /// Fraction of the way done after `t` s: a trapezoidal speed, normalised.
    fn fraction(&self, t: f32) -> f32 {
        let (big_t, r, area) = (self.duration_s, self.ramp_s, self.area_s);
        // The top of the trapezoid ends at `big_t - r`, which is `area`.
        let x = if ordered(t) < ordered(r) {
            0.5 * t * t / r
        } else if ordered(t) <= ordered(area) {
            0.5 * r + (t - r)
        } else {
            let left = big_t - t;
            area - 0.5 * left * left / r
        };
        // `area` is at least half the duration, which is not 0 here.
        clamp(x / area, [0.0, 1.0]).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: MotionLimits = MotionLimits {
        max_speed_rad_s: 1.5,
        max_accel_rad_s2: 4.0,
    };
    const FRAME_US: u64 = 20_000;

    /// Samples a profile every servo frame until it is over.
    fn samples(p: &Profile) -> Vec<PerChannel<f32>> {
        let mut out = vec![];
        for k in 0.. {
            let (q, done) = p.at(1_000 + k * FRAME_US);
            out.push(q);
            if done {
                break;
            }
        }
        out
    }

    fn check_limits<const N: usize>(
        start: [f32; N],
        end: [f32; N],
        timing: Timing,
    ) -> Vec<PerChannel<f32>> {
        let (start, end) = (PerChannel::from(start), PerChannel::from(end));
        let p = Profile::plan(start, end, 1_000, timing, LIMITS, 600.0).unwrap();
        let mut q = vec![start];
        q.extend(samples(&p));
        let dt = FRAME_US as f32 * 1e-6;
        for w in q.windows(3) {
            let [a, b, c] = [w[0], w[1], w[2]];
            for j in 0..N {
                let v1 = (b[j] - a[j]) / dt;
                let v2 = (c[j] - b[j]) / dt;
                assert!(
                    v2.abs() <= LIMITS.max_speed_rad_s * 1.001,
                    "joint {j} speed {v2}"
                );
                assert!(
                    ((v2 - v1) / dt).abs() <= LIMITS.max_accel_rad_s2 * 1.01,
                    "joint {j} accel"
                );
            }
        }
        assert_eq!(*q.last().unwrap(), end);
        q
    }

    #[test]
    fn long_and_short_moves_keep_speed_and_acceleration_limits() {
        check_limits(
            [0.0; 6],
            [1.7, -1.2, 0.3, 0.0, -0.9, 0.5],
            Timing::DurationMs(0),
        );
        check_limits(
            [0.0; 6],
            [0.05, -0.02, 0.0, 0.01, 0.0, 0.0],
            Timing::DurationMs(0),
        );
        check_limits([0.3; 6], [-1.0; 6], Timing::SpeedRadPerS(100.0));
    }

    #[test]
    fn all_joints_arrive_together() {
        let start = [0.0, 0.2, -0.4, 0.1, 0.0, 1.0];
        let end = [1.2, 0.25, 0.4, -0.1, 0.0, -0.2];
        let q = check_limits(start, end, Timing::DurationMs(0));
        // The fraction of the way done is the same for every moving joint at every frame.
        for frame in &q {
            let fractions: Vec<f32> = (0..6)
                .filter(|&j| end[j] != start[j])
                .map(|j| (frame[j] - start[j]) / (end[j] - start[j]))
                .collect();
            for f in &fractions {
                assert!((f - fractions[0]).abs() < 1e-4, "{fractions:?}");
            }
        }
    }

    #[test]
    fn requested_duration_and_speed_are_honoured() {
        let p = Profile::plan(
            [0.0; 6].into(),
            [0.5; 6].into(),
            0,
            Timing::DurationMs(3000),
            LIMITS,
            600.0,
        )
        .unwrap();
        assert!((p.duration_s() - 3.0).abs() < 1e-6);
        assert!(!p.at(2_990_000).1 && p.at(3_000_000).1);
        // 1 rad at 0.5 rad/s: 2 s cruising plus one ramp of 0.125 s.
        let p = Profile::plan(
            [0.0; 6].into(),
            [1.0; 6].into(),
            0,
            Timing::SpeedRadPerS(0.5),
            LIMITS,
            600.0,
        )
        .unwrap();
        assert!((p.duration_s() - 2.125).abs() < 1e-5, "{}", p.duration_s());
        // Too short a duration is stretched to what the limits allow.
        let p = Profile::plan(
            [0.0; 6].into(),
            [1.5; 6].into(),
            0,
            Timing::DurationMs(10),
            LIMITS,
            600.0,
        )
        .unwrap();
        assert!((p.duration_s() - (1.0 + 1.5 / 4.0)).abs() < 1e-5);
    }

    #[test]
    fn bad_timings_are_refused() {
        let plan = |t| Profile::plan([0.0; 6].into(), [1.0; 6].into(), 0, t, LIMITS, 600.0);
        assert_eq!(plan(Timing::SpeedRadPerS(0.0)), Err(PlanError::OutOfRange));
        assert_eq!(
            plan(Timing::SpeedRadPerS(f32::NAN)),
            Err(PlanError::NotFinite)
        );
        assert_eq!(
            plan(Timing::DurationMs(u32::MAX)),
            Err(PlanError::OutOfRange)
        );
        let nan_target = Profile::plan(
            [0.0; 6].into(),
            [f32::NAN; 6].into(),
            0,
            Timing::DurationMs(0),
            LIMITS,
            600.0,
        );
        assert_eq!(nan_target, Err(PlanError::NotFinite));
        let mismatched = Profile::plan(
            [0.0; 6].into(),
            [1.0; 5].into(),
            0,
            Timing::DurationMs(0),
            LIMITS,
            600.0,
        );
        assert_eq!(mismatched, Err(PlanError::OutOfRange));
    }

    /// An arm of fewer joints moves the same way: five joints, and one.
    #[test]
    fn arms_of_fewer_joints_keep_the_limits_and_arrive_together() {
        let q = check_limits(
            [0.0, 0.2, -0.4, 0.1, 0.0],
            [1.2, 0.25, 0.4, -0.1, 0.7],
            Timing::DurationMs(0),
        );
        assert!(q.iter().all(|q| q.len() == 5));
        let q = check_limits([0.3], [-1.1], Timing::SpeedRadPerS(1.0));
        assert!(q.len() > 50 && q.iter().all(|q| q.len() == 1));
    }
}
