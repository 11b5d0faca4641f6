//! The shortest distance between two line segments in space: what decides
//! whether two capsules (a segment swept by a sphere) touch.

use nalgebra::Vector3;

/// Shortest distance between segments `[p0, p1]` and `[q0, q1]`, m.
///
/// Minimises `|p0 + s d1 - (q0 + t d2)|` over `s, t` in `[0, 1]`: the
/// unconstrained minimiser in `s` is clamped, `t` follows from it, and if `t`
/// has to be clamped, `s` is recomputed for the clamped `t`. Degenerate
/// (zero-length) segments are points.
pub fn segment_distance(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> f64 {
    const TINY: f64 = 1e-18;
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    let (s, t) = if a <= TINY && e <= TINY {
        (0.0, 0.0)
    } else if a <= TINY {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= TINY {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            // Parallel segments (denom 0): any s works; take the start.
            let s = if denom > TINY {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let t = (b * s + f) / e;
            if t < 0.0 {
                ((-c / a).clamp(0.0, 1.0), 0.0)
            } else if t > 1.0 {
                (((b - c) / a).clamp(0.0, 1.0), 1.0)
            } else {
                (s, t)
            }
        }
    };
    ((p0 + d1 * s) - (q0 + d2 * t)).norm()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    #[test]
    fn hand_checked_cases() {
        // Crossing skew lines, 1 apart in z.
        assert_relative_eq!(
            segment_distance(
                &v(-1., 0., 0.),
                &v(1., 0., 0.),
                &v(0., -1., 1.),
                &v(0., 1., 1.)
            ),
            1.0
        );
        // Parallel, overlapping, 2 apart.
        assert_relative_eq!(
            segment_distance(
                &v(0., 0., 0.),
                &v(1., 0., 0.),
                &v(0.5, 2., 0.),
                &v(3., 2., 0.)
            ),
            2.0
        );
        // Collinear with a gap of 1.
        assert_relative_eq!(
            segment_distance(
                &v(0., 0., 0.),
                &v(1., 0., 0.),
                &v(2., 0., 0.),
                &v(3., 0., 0.)
            ),
            1.0
        );
        // End to end in an L: they touch.
        assert_relative_eq!(
            segment_distance(
                &v(0., 0., 0.),
                &v(1., 0., 0.),
                &v(1., 0., 0.),
                &v(1., 1., 0.)
            ),
            0.0
        );
        // A point against a segment.
        assert_relative_eq!(
            segment_distance(
                &v(0.5, 3., 0.),
                &v(0.5, 3., 0.),
                &v(0., 0., 0.),
                &v(1., 0., 0.)
            ),
            3.0
        );
        // Closest points at the ends: the lines would cross, the segments do not reach.
        let d = segment_distance(
            &v(0., 0., 0.),
            &v(1., 0., 0.),
            &v(3., -1., 0.),
            &v(3., -3., 0.),
        );
        assert_relative_eq!(d, (4.0f64 + 1.0).sqrt());
    }

    #[test]
    fn no_sampled_pair_of_points_is_closer() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut p = || {
            v(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
        };
        for _ in 0..200 {
            let (a, b, c, d) = (p(), p(), p(), p());
            let dist = segment_distance(&a, &b, &c, &d);
            let mut sampled = f64::INFINITY;
            for i in 0..=60 {
                for j in 0..=60 {
                    let (s, t) = (i as f64 / 60.0, j as f64 / 60.0);
                    sampled = sampled.min(((a + (b - a) * s) - (c + (d - c) * t)).norm());
                }
            }
            assert!(dist <= sampled + 1e-12, "{dist} > {sampled}");
            assert!(
                sampled - dist < 0.05,
                "{dist} far below the sampled {sampled}"
            );
        }
    }
}
