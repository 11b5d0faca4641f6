//! Drawing the seeded "true" arm around a nominal one.
//!
//! Every random number is drawn whatever the configuration says, in a fixed
//! order, and only then scaled by it: switching an effect off (or changing its
//! size) never changes the geometry drawn for the same seed.

use model::params::{ParamKind, ParamPart};
use model::{Arm, ParamId};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::{Harmonic, ServoError, ServoErrorShape, SimConfig, SimError};
use crate::calib::parameters::option::parallel_twists;

/// RNG stream of the arm draw; the tracker noise uses [`NOISE_STREAM`].
const DRAW_STREAM: u64 = 0;
/// RNG stream of the tracker noise.
pub(super) const NOISE_STREAM: u64 = 1;

/// The simulated real arm: the nominal arm plus drawn errors, and the drawn
/// effects that the calibration model does not contain.
///
/// Its file form is the truth file ([`TrueArm::truth_json`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TrueArm {
    /// The seed everything was drawn from.
    pub seed: u64,
    /// The configuration it was drawn with.
    pub config: SimConfig,
    /// The nominal arm it was drawn around.
    pub nominal: Arm<f64>,
    /// The true arm in the model's terms: `nominal.with_errors(all, errors)`.
    pub arm: Arm<f64>,
    /// The true errors (true minus nominal), in [`ParamId::of`] order, then
    /// the twists of parallel axes when drawn ([`TrueArm::named_errors`]).
    pub errors: Vec<f64>,
    /// Each servo's smooth angle error (zero amplitude when switched off).
    pub servo_errors: Vec<ServoError>,
    /// Each joint's half width of direction-dependent play, rad (0 when off).
    pub backlash_half_rad: Vec<f64>,
}

impl TrueArm {
    /// Draws the true arm for `seed` around `nominal`.
    ///
    /// DH, base and tool parameters get Gaussian errors of the configured
    /// sigmas; the true compliances are drawn log-uniformly from the
    /// configured ranges (whatever the nominal compliances are).
    pub fn draw(nominal: &Arm<f64>, seed: u64, config: &SimConfig) -> Result<Self, SimError> {
        config.validate()?;
        if !nominal.is_finite() {
            return Err(SimError::NominalNotFinite);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(DRAW_STREAM);

        let mut ids: Vec<ParamId> = ParamId::of(nominal).collect();
        let joints = nominal.joints.len();
        let mut errors: Vec<f64> = ids
            .iter()
            .map(|&id| {
                let normal: f64 = rng.sample(StandardNormal);
                let unit: f64 = rng.random();
                let dh = matches!(id.part(), ParamPart::Dh { .. });
                match id.kind() {
                    ParamKind::Length if dh => normal * config.dh_length_sigma_m,
                    ParamKind::Length => normal * config.frame_length_sigma_m,
                    ParamKind::Angle if dh => normal * config.dh_angle_sigma_rad,
                    ParamKind::Angle => normal * config.frame_angle_sigma_rad,
                    ParamKind::Compliance => {
                        let range = if id.part() == ParamPart::BaseCompliance {
                            config.base_compliance
                        } else {
                            config.joint_compliance
                        };
                        log_uniform(range, unit) - id.value(nominal)
                    }
                }
            })
            .collect();

        let mut servo_errors: Vec<ServoError> = (0..joints)
            .map(|_| {
                let (u, v, w, phase): (f64, f64, f64, f64) =
                    (rng.random(), rng.random(), rng.random(), rng.random());
                let amplitude = config.servo_error_rad;
                ServoError {
                    sine_rad: amplitude * (0.5 + 0.5 * u),
                    omega: 1.5 + 1.5 * w,
                    phase_rad: std::f64::consts::TAU * phase,
                    cubic_rad: amplitude * (v - 0.5),
                    harmonics: [Harmonic::default(); 2],
                }
            })
            .collect();
        let backlash_half_rad = (0..joints)
            .map(|_| {
                let u: f64 = rng.random();
                0.5 * config.backlash_rad * (0.5 + u)
            })
            .collect();
        // Drawn last, so everything drawn before them is what it always was.
        for servo in &mut servo_errors {
            let (u2, u3, phase2, phase3): (f64, f64, f64, f64) =
                (rng.random(), rng.random(), rng.random(), rng.random());
            if config.servo_error_shape == ServoErrorShape::Harmonics {
                // The n-th harmonic at (0.5..1) A / n, in place of the cubic.
                let amplitude = config.servo_error_rad;
                servo.cubic_rad = 0.0;
                servo.harmonics =
                    [(2.0, u2, phase2), (3.0, u3, phase3)].map(|(n, u, phase)| Harmonic {
                        amplitude_rad: amplitude * (0.5 + 0.5 * u) / n,
                        phase_rad: std::f64::consts::TAU * phase,
                    });
            }
        }

        // The twists of nominally parallel axes, drawn after everything else
        // and kept only when switched on: without them the true arm and its
        // errors are what they always were.
        for id in drawn_twists(nominal, config) {
            let normal: f64 = rng.sample(StandardNormal);
            ids.push(id);
            errors.push(normal * config.parallel_twist_sigma_rad);
        }

        let arm = nominal.with_errors(&ids, &errors);
        // `with_errors` clamps compliances at 0; recompute so `errors` stays exactly true - nominal.
        let errors = ids
            .iter()
            .map(|id| id.value(&arm) - id.value(nominal))
            .collect();
        Ok(Self {
            seed,
            config: *config,
            nominal: *nominal,
            arm,
            errors,
            servo_errors,
            backlash_half_rad,
        })
    }

    /// The true errors with their stable names, in [`ParamId::of`] order,
    /// then the twist of each link with nominally parallel axes when the
    /// configuration draws them.
    pub fn named_errors(&self) -> impl Iterator<Item = (ParamId, f64)> + '_ {
        ParamId::of(&self.nominal)
            .chain(drawn_twists(&self.nominal, &self.config))
            .zip(self.errors.iter().copied())
    }
}

/// The twists of `nominal`'s links with parallel axes that `config` draws:
/// all of them when it has a twist sigma, none otherwise.
fn drawn_twists<'a>(
    nominal: &'a Arm<f64>,
    config: &SimConfig,
) -> impl Iterator<Item = ParamId> + 'a {
    let on = config.parallel_twist_sigma_rad > 0.0;
    parallel_twists(nominal).filter(move |_| on)
}

/// `lo (hi/lo)^unit`: log-uniform in `[lo, hi]` for `unit` uniform in `[0, 1)`.
fn log_uniform([lo, hi]: [f64; 2], unit: f64) -> f64 {
    lo * (hi / lo).powf(unit)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::test_support::bundled_arm;

    #[test]
    fn same_seed_same_arm_and_other_seed_other_arm() {
        let nominal = bundled_arm();
        let config = SimConfig::default();
        let a = TrueArm::draw(&nominal, 7, &config).unwrap();
        let b = TrueArm::draw(&nominal, 7, &config).unwrap();
        let c = TrueArm::draw(&nominal, 8, &config).unwrap();
        assert_eq!(a, b);
        assert_ne!(a.errors, c.errors);
    }

    #[test]
    fn switching_effects_off_keeps_the_drawn_geometry() {
        let nominal = bundled_arm();
        let with = TrueArm::draw(&nominal, 3, &SimConfig::default()).unwrap();
        let without = TrueArm::draw(&nominal, 3, &SimConfig::model_only()).unwrap();
        assert_eq!(with.arm, without.arm);
        assert!(
            without
                .servo_errors
                .iter()
                .all(|s| s.sine_rad == 0.0 && s.cubic_rad == 0.0)
        );
        assert!(without.backlash_half_rad.iter().all(|&b| b == 0.0));
    }

    #[test]
    fn the_harmonic_shape_keeps_the_arm_the_sine_and_the_play() {
        let nominal = bundled_arm();
        let sine_cubic = TrueArm::draw(&nominal, 3, &SimConfig::default()).unwrap();
        let config = SimConfig {
            servo_error_shape: ServoErrorShape::Harmonics,
            ..SimConfig::default()
        };
        let harmonics = TrueArm::draw(&nominal, 3, &config).unwrap();
        assert_eq!(sine_cubic.arm, harmonics.arm);
        assert_eq!(sine_cubic.backlash_half_rad, harmonics.backlash_half_rad);
        let amplitude = config.servo_error_rad;
        for (a, b) in sine_cubic.servo_errors.iter().zip(&harmonics.servo_errors) {
            assert_eq!(
                (a.sine_rad, a.omega, a.phase_rad),
                (b.sine_rad, b.omega, b.phase_rad)
            );
            assert!(a.harmonics.iter().all(|h| h.amplitude_rad == 0.0));
            assert_eq!(b.cubic_rad, 0.0);
            for (h, n) in b.harmonics.iter().zip([2.0, 3.0]) {
                assert!(
                    (0.5 * amplitude / n..=amplitude / n).contains(&h.amplitude_rad),
                    "{h:?}"
                );
            }
        }
    }

    /// The twists of parallel axes come on their own: the rest of the arm,
    /// the servos and the play stay as drawn without them, and the truth
    /// names them after the other errors.
    #[test]
    fn parallel_twists_are_drawn_only_when_switched_on() {
        let nominal = bundled_arm();
        let plain = TrueArm::draw(&nominal, 3, &SimConfig::default()).unwrap();
        assert!(plain.arm.joints.iter().all(|j| j.beta == 0.0));
        let config = SimConfig {
            parallel_twist_sigma_rad: 0.5f64.to_radians(),
            ..SimConfig::default()
        };
        let twisted = TrueArm::draw(&nominal, 3, &config).unwrap();
        let parallel: Vec<ParamId> = parallel_twists(&nominal).collect();
        assert!(!parallel.is_empty());
        let mut untwisted = twisted.arm;
        untwisted.joints.iter_mut().for_each(|j| j.beta = 0.0);
        assert_eq!(untwisted, plain.arm);
        assert_eq!(twisted.servo_errors, plain.servo_errors);
        assert_eq!(twisted.backlash_half_rad, plain.backlash_half_rad);
        let named: Vec<(ParamId, f64)> = twisted.named_errors().collect();
        assert_eq!(named.len(), plain.errors.len() + parallel.len());
        for (id, error) in &named[plain.errors.len()..] {
            assert!(parallel.contains(id) && *error != 0.0, "{id}: {error}");
            assert_eq!(id.value(&twisted.arm), *error, "{id}");
        }
    }

    #[test]
    fn errors_are_true_minus_nominal_and_compliances_in_range() {
        let nominal = bundled_arm();
        let config = SimConfig::default();
        for seed in 0..20 {
            let t = TrueArm::draw(&nominal, seed, &config).unwrap();
            for (id, e) in t.named_errors() {
                assert_eq!(id.value(&t.arm) - id.value(&nominal), e, "{id}");
            }
            for j in &t.arm.joints {
                assert!((0.05..=0.2).contains(&j.compliance), "{}", j.compliance);
            }
            assert!((0.01..=0.03).contains(&t.arm.base_compliance));
            // Gaussian DH length errors of sigma 1 mm stay well inside 6 sigma.
            assert!(
                t.arm
                    .joints
                    .iter()
                    .zip(&nominal.joints)
                    .all(|(a, b)| (a.d - b.d).abs() < 6e-3)
            );
        }
    }

    #[test]
    fn bad_configuration_is_rejected_with_the_field_named() {
        let nominal = bundled_arm();
        let config = SimConfig {
            noise_sigma_m: -1.0,
            ..SimConfig::default()
        };
        let err = TrueArm::draw(&nominal, 0, &config).unwrap_err().to_string();
        assert!(
            err.contains("noise_sigma_m") && err.contains(">= 0"),
            "{err}"
        );
        let config = SimConfig {
            joint_compliance: [0.2, 0.01],
            ..SimConfig::default()
        };
        let err = TrueArm::draw(&nominal, 0, &config).unwrap_err().to_string();
        assert!(
            err.contains("joint_compliance") && err.contains("lo <= hi"),
            "{err}"
        );
        let mut bad = nominal;
        bad.joints[2].a = f64::NAN;
        assert!(matches!(
            TrueArm::draw(&bad, 0, &SimConfig::default()),
            Err(SimError::NominalNotFinite)
        ));
    }
}
