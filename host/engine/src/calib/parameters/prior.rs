//! What a calibration of ours assumes before any measurement: how far each
//! of its effects typically strays from the arm file, one standard
//! deviation per correction, and the prior that says so to the fit.
//!
//! **The sizes** (one table, [`sd`]), each from what bounds the quantity
//! physically (`model::bounds`) or what a hobby servo is:
//!
//! | correction | one standard deviation | why |
//! |---|---|---|
//! | a servo curve's angle at a knot | [`SERVO_SD_DEG`] (2°), knots [`SERVO_CORRELATION_DEG`] apart correlated by `e^-½` | a servo reaches its data sheet's angle to a few degrees (the potentiometer's bow, gear eccentricity), an error that changes smoothly over tens of degrees |
//! | a joint's play | a fifth of the widest the board takes (1°) | a hobby servo's dead band and horn play add up to a degree or two |
//! | a spring's compliance | half its ceiling (a sag of 0.25 rad under its largest torque) | the ceiling, two deviations out, is the sag beyond which a joint does not hold a pose |
//! | a spring's softening | half its ceiling (its compliance half as large again at its largest torque) | likewise |
//! | a link's twist (`alpha`, `beta`) | half the largest a calibration may make ([`TWIST_SD_OF_BOUND`] of [`MAX_TWIST_RAD`]: 5°) | a printed or bent link is a few degrees out of square; where the poses barely see a twist, it would otherwise bend to the noise |
//!
//! The rest of the geometry, the base and the tool points have none: a build is
//! whatever it is (a servo horn one spline tooth off is 14°), and the
//! registration's base and tool point are off by the sag they were found
//! under; the poses determine them. A spring that carries no torque has
//! no ceiling and no prior (its compliance moves nothing).
//!
//! **The prior** on a fit's corrections `e` is Gaussian, centred at the
//! arm the calibration started from (the arm file on its registered base;
//! a refit from an estimate keeps that centre) with these deviations:
//! `|A (e − e₀)|²` with `AᵀA` the inverse of the prior covariance. A
//! servo's knots are correlated (above); the rank analysis holds one of a
//! joint's knots at the arm file's curve (its offset is the joint's `θ`,
//! which has no prior), so the others are the curve's error at them minus
//! its error at the held one, whose covariance follows from the curve's.
//!
//! **How smooth.** The table's correlation length makes most of a servo
//! error's variance lie in wavelengths of 160° and more: a cycle or so over
//! the ±100° travel, as `model::servo` says a servo's error is. A track
//! with sharper features exists too, so a fit of ours is also made with
//! the other lengths of [`SERVO_CORRELATIONS_DEG`] and the one whose
//! measurements are the most probable kept (`calib::grow`).

use nalgebra::{DMatrix, DVector};

use model::JointKind;
use model::bounds::{Bounds, Quantity};
use model::params::ParamPart;

use crate::calib::Rig;
use crate::calib::parameters::params::{Key as _, ParamKey};
use crate::calib::parameters::real_arm::MAX_TWIST_RAD;
use crate::calib::parameters::servo_knots::{FINEST_SPACING_DEG, KNOTS, spacing_of};

/// One standard deviation of a servo curve's error at any angle, degrees.
pub const SERVO_SD_DEG: f64 = 2.0;

/// The correlation length of a servo curve's error, degrees: two angles
/// this far apart have errors correlated by `e^-½` (squared-exponential).
pub const SERVO_CORRELATION_DEG: f64 = 50.0;

/// The correlation lengths a fit chooses among, degrees, roughest first.
pub const SERVO_CORRELATIONS_DEG: [f64; 3] = [25.0, SERVO_CORRELATION_DEG, 100.0];

/// One standard deviation of a joint's play, as a fraction of the widest
/// the board takes (`model::bounds::MAX_BACKLASH_RAD`, 5°): 1°.
pub const PLAY_SD_OF_BOUND: f64 = 0.2;

/// One standard deviation of a link's twist, as a fraction of the largest
/// a calibration may make ([`MAX_TWIST_RAD`], 10°): 5°.
pub const TWIST_SD_OF_BOUND: f64 = 0.5;

/// One standard deviation of a spring's compliance or softening, as a
/// fraction of its ceiling (`model::bounds`).
pub const SPRING_SD_OF_BOUND: f64 = 0.5;

/// One standard deviation of the correction `key` a priori (module docs),
/// on an arm whose joints are of `kinds` and whose physical bounds are
/// `bounds`; `None` where the prior says nothing (the geometry but its
/// twists, placement, a camera's lens, a
/// spring without torque, a slide's servo knots).
pub fn sd(key: ParamKey, kinds: &[JointKind], bounds: &Bounds<f64>) -> Option<f64> {
    let finite = |x: f64| (x.is_finite() && x > 0.0 && x < f64::MAX / 2.0).then_some(x);
    match key {
        ParamKey::ServoKnot { joint, .. } => (kinds.get(usize::from(joint))
            == Some(&JointKind::Revolute))
        .then(|| SERVO_SD_DEG.to_radians()),
        ParamKey::Backlash { joint } => {
            finite(PLAY_SD_OF_BOUND * bounds.range(Quantity::Backlash { joint }).max)
        }
        ParamKey::Softening { spring } => {
            finite(SPRING_SD_OF_BOUND * bounds.range(Quantity::Softening { spring }).max)
        }
        ParamKey::Arm(id) => match (key.quantity(), id.part()) {
            (Some(q @ Quantity::Compliance { .. }), _) => {
                finite(SPRING_SD_OF_BOUND * bounds.range(q).max)
            }
            (_, ParamPart::Dh { field: 3 | 4, .. }) => Some(TWIST_SD_OF_BOUND * MAX_TWIST_RAD),
            _ => None,
        },
        ParamKey::TargetTool { .. } | ParamKey::Lens { .. } => None,
    }
}

/// Angle of knot `knot` of the finest grid, rad.
fn knot_angle_rad(knot: usize) -> f64 {
    ((knot as f64 - (KNOTS - 1) as f64 / 2.0) * FINEST_SPACING_DEG).to_radians()
}

/// The prior covariance of a servo curve's errors at knots `a` and `b`
/// (indices on the finest grid), rad², for errors correlated over
/// `correlation_deg`.
fn servo_covariance(a: usize, b: usize, correlation_deg: f64) -> f64 {
    let s = SERVO_SD_DEG.to_radians();
    let d = (knot_angle_rad(a) - knot_angle_rad(b)) / correlation_deg.to_radians();
    s * s * (-0.5 * d * d).exp()
}

/// The prior of a fit of `keys` (module docs), as rows over the keys in
/// their order: `A (e − e₀)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Prior {
    /// `A`: one row per direction the prior holds, one column per key.
    rows: DMatrix<f64>,
    /// `e₀`: the corrections, from the fit's start, that take each key to
    /// the prior's centre (0 where the fit starts there).
    centre: DVector<f64>,
    /// `log |det A|` over the keys the prior holds: half the log
    /// determinant of the prior's precision.
    log_det: f64,
}

impl Prior {
    /// The prior of a fit of `keys` that starts from `start` and is centred
    /// at `origin` (both with their curves on the grid of the knots among
    /// `keys`, `calib::servo_knots::fit_start`); `None` when no key has one.
    pub fn new(start: &Rig, origin: &Rig, keys: &[ParamKey], correlation_deg: f64) -> Option<Self> {
        let kinds: Vec<JointKind> = start.arm.joints.iter().map(|j| j.kind).collect();
        let m = keys.len();
        let mut rows: Vec<DVector<f64>> = Vec::new();
        // log |det A| over the keys it holds: A is triangular on them.
        let mut log_det = 0.0;
        // Independent corrections: one row each.
        for (c, key) in keys.iter().enumerate() {
            if matches!(key, ParamKey::ServoKnot { .. }) {
                continue;
            }
            if let Some(s) = sd(*key, &kinds, &start.bounds) {
                let mut row = DVector::zeros(m);
                row[c] = 1.0 / s;
                rows.push(row);
                log_det -= s.ln();
            }
        }
        // A servo's knots: correlated, relative to its held knot.
        let spacing = spacing_of(keys);
        for joint in 0..kinds.len() {
            let fitted: Vec<(usize, usize)> = keys
                .iter()
                .enumerate()
                .filter_map(|(c, k)| match k {
                    ParamKey::ServoKnot { joint: j, knot }
                        if usize::from(*j) == joint && sd(*k, &kinds, &start.bounds).is_some() =>
                    {
                        Some((c, usize::from(*knot)))
                    }
                    _ => None,
                })
                .collect();
            let Some(spacing) = spacing.filter(|_| !fitted.is_empty()) else {
                continue;
            };
            let held = (0..KNOTS)
                .filter(|&k| spacing.holds(k))
                .find(|k| fitted.iter().all(|(_, f)| f != k));
            // x_a = δ_a − δ_h: cov(x_a, x_b) = K_ab − K_ah − K_hb + K_hh.
            let n = fitted.len();
            let cov = DMatrix::from_fn(n, n, |i, j| {
                let (a, b) = (fitted[i].1, fitted[j].1);
                match held {
                    Some(h) => {
                        let k = |a, b| servo_covariance(a, b, correlation_deg);
                        k(a, b) - k(a, h) - k(h, b) + k(h, h)
                    }
                    None => servo_covariance(a, b, correlation_deg),
                }
            });
            // A little of the independent prior keeps a smooth kernel invertible.
            let jitter = 1e-6 * SERVO_SD_DEG.to_radians().powi(2);
            let cov = cov + DMatrix::identity(n, n) * jitter;
            let Some(chol) = cov.cholesky() else {
                continue;
            };
            log_det -= chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
            // |L⁻¹ x|² = xᵀ cov⁻¹ x.
            let whiten = chol
                .l()
                .solve_lower_triangular(&DMatrix::identity(n, n))
                .unwrap_or_else(|| DMatrix::zeros(n, n));
            for r in 0..n {
                let mut row = DVector::zeros(m);
                for (i, (c, _)) in fitted.iter().enumerate() {
                    row[*c] = whiten[(r, i)];
                }
                rows.push(row);
            }
        }
        if rows.is_empty() {
            return None;
        }
        let centre = DVector::from_iterator(
            m,
            keys.iter()
                .map(|k| k.value(origin) - k.value(start))
                .map(|v| if v.is_finite() { v } else { 0.0 }),
        );
        let rows = DMatrix::from_rows(&rows.iter().map(|r| r.transpose()).collect::<Vec<_>>());
        Some(Self {
            rows,
            centre,
            log_det,
        })
    }

    /// `log |det A|` over the keys the prior holds (`A` square there): half
    /// the log determinant of the prior's precision, the prior density's
    /// normalisation (up to `2π`) in a model's evidence.
    pub fn log_det(&self) -> f64 {
        self.log_det
    }

    /// Rows of the prior.
    pub fn len(&self) -> usize {
        self.rows.nrows()
    }

    /// Whether it holds nothing (never, as made by [`Prior::new`]).
    pub fn is_empty(&self) -> bool {
        self.rows.nrows() == 0
    }

    /// Whether the prior holds the key at `column` (its index among the keys).
    pub fn holds(&self, column: usize) -> bool {
        column < self.rows.ncols() && self.rows.column(column).iter().any(|v| *v != 0.0)
    }

    /// `A (e − e₀)` for the corrections `errors` (every key, in order).
    pub fn residuals(&self, errors: &[f64]) -> DVector<f64> {
        let e = DVector::from_column_slice(errors);
        &self.rows * (e - &self.centre)
    }

    /// The columns of `A` of the keys at `columns` (indices into the keys):
    /// the prior's Jacobian with respect to them.
    pub fn columns(&self, columns: &[usize]) -> DMatrix<f64> {
        self.rows.select_columns(columns)
    }

    /// The negative log prior density, up to a constant: `½ |A (e − e₀)|²`
    /// (every key's correction in `errors`).
    pub fn cost(&self, errors: &[f64]) -> f64 {
        0.5 * self.residuals(errors).norm_squared()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::parameters::servo_knots::{self, KnotSpacing};
    use crate::calib::testing::{key, rigid_nominal};

    /// The independent corrections get `1/sd`; the geometry but its twists,
    /// and the placement, none.
    #[test]
    fn each_effect_gets_its_size_and_the_geometry_but_twists_none() {
        let rig = Rig::from(rigid_nominal());
        let kinds: Vec<JointKind> = rig.arm.joints.iter().map(|j| j.kind).collect();
        let b = &rig.bounds;
        assert_eq!(sd(key("j2.a"), &kinds, b), None);
        assert_eq!(sd(key("j2.theta"), &kinds, b), None);
        for twist in ["j5.alpha", "j2.beta"] {
            let s = sd(key(twist), &kinds, b).unwrap();
            assert!((s.to_degrees() - 5.0).abs() < 1e-9, "{twist}: {s}");
        }
        assert_eq!(sd(key("base.z"), &kinds, b), None);
        assert_eq!(sd(key("tool.x"), &kinds, b), None);
        let play = sd(key("j2.backlash"), &kinds, b).unwrap();
        assert!((play.to_degrees() - 1.0).abs() < 1e-9, "{play}");
        let k2 = sd(key("k2"), &kinds, b).unwrap();
        assert!((k2 * b.torque_nm(2) - 0.25).abs() < 1e-9, "{k2}");
        let s2 = sd(key("s2"), &kinds, b).unwrap();
        assert!((s2 * b.torque_nm(2) - 0.5).abs() < 1e-9, "{s2}");
        let knot = sd(key("j2.servo[3]"), &kinds, b).unwrap();
        assert!((knot.to_degrees() - SERVO_SD_DEG).abs() < 1e-12);

        let keys = [key("j2.a"), key("k2"), key("j2.backlash")];
        let prior = Prior::new(&rig, &rig, &keys, SERVO_CORRELATION_DEG).unwrap();
        assert_eq!(prior.len(), 2);
        let r = prior.residuals(&[0.01, k2, 0.0]);
        assert!((r.norm() - 1.0).abs() < 1e-12, "{r}");
        assert!(
            Prior::new(
                &rig,
                &rig,
                &[key("j2.a"), key("base.x")],
                SERVO_CORRELATION_DEG
            )
            .is_none()
        );
    }

    /// A joint's knots relative to its held one: each knot's variance is
    /// twice the curve's less what it shares with the held knot, and the
    /// whitened rows give back the covariance.
    #[test]
    fn knots_are_correlated_relative_to_the_held_one() {
        let rig = Rig::from(rigid_nominal());
        let keys: Vec<ParamKey> = servo_knots::keys(&rig.arm, KnotSpacing::Deg50)
            .filter(|k| matches!(k, ParamKey::ServoKnot { joint: 1, knot } if *knot != 8))
            .collect();
        assert_eq!(keys.len(), 4);
        let start = servo_knots::fit_start(&rig, &keys);
        let prior = Prior::new(&start, &start, &keys, SERVO_CORRELATION_DEG).unwrap();
        assert_eq!(prior.len(), 4);
        let a = prior.columns(&[0, 1, 2, 3]);
        let cov = (a.transpose() * &a).try_inverse().unwrap();
        let s2 = SERVO_SD_DEG.to_radians().powi(2);
        // Knot 7 (index 6, 50° from the held +100°) and knot 1 (200° from it).
        let rho = |deg: f64| (-0.5 * (deg / SERVO_CORRELATION_DEG).powi(2)).exp();
        let near = 2.0 * s2 * (1.0 - rho(50.0));
        let far = 2.0 * s2 * (1.0 - rho(200.0));
        assert!((cov[(3, 3)] - near).abs() < 1e-3 * near, "{cov}");
        assert!((cov[(0, 0)] - far).abs() < 1e-3 * far, "{cov}");
        // Centred at the start: no correction costs nothing.
        assert_eq!(prior.cost(&[0.0; 4]), 0.0);
    }

    /// A refit from an estimate keeps the prior's centre where the
    /// calibration started.
    #[test]
    fn a_refit_keeps_the_centre() {
        let origin = Rig::from(rigid_nominal());
        let mut start = origin.clone();
        start.arm.joints[1].compliance += 0.05;
        let prior = Prior::new(&start, &origin, &[key("k2")], SERVO_CORRELATION_DEG).unwrap();
        let sd = sd(key("k2"), &[JointKind::Revolute; 6], &origin.bounds).unwrap();
        assert!((prior.residuals(&[0.0])[0] - 0.05 / sd).abs() < 1e-12);
        assert!(prior.residuals(&[-0.05])[0].abs() < 1e-12);
    }
}
