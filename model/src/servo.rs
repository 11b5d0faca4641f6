//! Level-1 calibration: an RC servo's angle -> pulse map as two straight lines
//! through the pulses measured at -100°, 0° and +100°.

use serde::{Deserialize, Serialize};

use crate::{Real, real};

/// Pulse widths (µs) measured at -100°, 0° and +100°.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServoCurve<T> {
    /// Pulse at -100°, µs.
    pub minus100: T,
    /// Pulse at 0°, µs.
    pub zero: T,
    /// Pulse at +100°, µs.
    pub plus100: T,
}

impl<T: Real> ServoCurve<T> {
    /// The data-sheet curve of a hobby servo: 900 / 1650 / 2400 µs.
    pub fn nominal() -> Self {
        Self {
            minus100: real(900.0),
            zero: real(1650.0),
            plus100: real(2400.0),
        }
    }

    /// 100° in radians, the abscissa of the outer calibration points.
    fn span() -> T {
        real(100.0f64.to_radians())
    }

    /// Pulse (µs) for a joint angle (rad); outside ±100° the nearer line is extended.
    pub fn pulse_us(&self, angle: T) -> T {
        let slope = if angle < T::zero() {
            (self.zero - self.minus100) / Self::span()
        } else {
            (self.plus100 - self.zero) / Self::span()
        };
        self.zero + slope * angle
    }

    /// Joint angle (rad) for a pulse (µs): the inverse of [`ServoCurve::pulse_us`].
    ///
    /// Only meaningful for a monotonic curve (see [`ServoCurve::is_monotonic`]).
    pub fn angle(&self, pulse_us: T) -> T {
        let increasing = self.plus100 > self.minus100;
        let below_zero = (pulse_us < self.zero) == increasing;
        let (lo, hi) = if below_zero {
            (self.minus100, self.zero)
        } else {
            (self.zero, self.plus100)
        };
        (pulse_us - self.zero) * Self::span() / (hi - lo)
    }

    /// Whether the pulses run strictly one way (both lines have the same, non-zero slope sign).
    pub fn is_monotonic(&self) -> bool {
        (self.minus100 < self.zero && self.zero < self.plus100)
            || (self.minus100 > self.zero && self.zero > self.plus100)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn passes_through_its_three_points_and_extends_outside() {
        let c = ServoCurve {
            minus100: 1000.0f64,
            zero: 1500.0,
            plus100: 2100.0,
        };
        let r = 100f64.to_radians();
        assert_relative_eq!(c.pulse_us(-r), 1000.0, epsilon = 1e-9);
        assert_relative_eq!(c.pulse_us(0.0), 1500.0);
        assert_relative_eq!(c.pulse_us(r), 2100.0, epsilon = 1e-9);
        assert_relative_eq!(c.pulse_us(-r / 2.0), 1250.0, epsilon = 1e-9);
        assert_relative_eq!(c.pulse_us(r * 1.1), 2160.0, epsilon = 1e-9);
        assert_relative_eq!(c.pulse_us(-r * 1.1), 950.0, epsilon = 1e-9);
    }

    #[test]
    fn angle_inverts_pulse_for_either_direction() {
        for c in [
            ServoCurve {
                minus100: 1000.0f64,
                zero: 1500.0,
                plus100: 2100.0,
            },
            ServoCurve {
                minus100: 2300.0f64,
                zero: 1600.0,
                plus100: 950.0,
            },
        ] {
            assert!(c.is_monotonic());
            for a in [-1.9, -0.5, 0.0, 0.3, 1.7] {
                assert_relative_eq!(c.angle(c.pulse_us(a)), a, epsilon = 1e-12);
            }
        }
        assert!(
            !ServoCurve {
                minus100: 1000.0f64,
                zero: 2200.0,
                plus100: 2100.0
            }
            .is_monotonic()
        );
    }
}
