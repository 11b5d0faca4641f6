//! Measuring the true arm: commanded poses and loads in, tracker positions out.
//!
//! For each load the poses are visited once, in the order given, the passes
//! one after the other, the first starting from home: the rows come out in
//! visiting order, and the way each joint arrives at each row is
//! [`lrmcal_core::dataset::approaches`] of that order, the definition
//! identification uses on a measurement file. A commanded angle `q` becomes
//! the angle the servo really drives to, `q + e(q) - s b` (smooth servo
//! error `e`, half play `b`, `s = ±1` rising or falling); the model of the
//! true arm deflects that under gravity (with springs that soften or
//! stiffen if switched on); the tracker adds Gaussian noise.

use std::collections::HashSet;

use model::{Deflection, PerJoint, SolverOptions};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use super::draw::NOISE_STREAM;
use super::{SimError, Spring, TrueArm, spring_deflection};
use lrmcal_core::dataset::{Measurement, Pose, approaches};
use model::backlash::{Approach, settled};

/// What the simulated tracker saw, and what it would have seen without noise.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    /// Measurements with tracker noise, load-major (all poses for the first load, then the next).
    pub measurements: Vec<Measurement>,
    /// The same rows without tracker noise (every other effect included).
    pub noise_free: Vec<Measurement>,
}

impl TrueArm {
    /// The angle each servo really drives to when commanded `q`, having
    /// arrived the way `approach` says, rad.
    pub fn driven_angles(&self, q: &[f64], approach: &[Approach]) -> PerJoint<f64> {
        PerJoint::from_fn(q.len(), |i| {
            settled(
                q[i] + self.servo_errors[i].at(q[i]),
                2.0 * self.backlash_half_rad[i],
                approach[i],
            )
        })
    }

    /// The true tool point, world frame, m, when the servos drive to `driven` (rad)
    /// under `load_kg`; no tracker noise. With linear springs (softening and
    /// stiffening off) this is exactly the model's prediction for the true arm.
    pub fn tool_point(
        &self,
        driven: &[f64],
        load_kg: f64,
    ) -> Result<Vector3<f64>, model::DeflectionError> {
        self.deflection(driven, load_kg).map(|d| d.tool_point())
    }

    /// The true arm's deflected state when the servos drive to `driven`
    /// (rad) under `load_kg`, its springs as the configuration says.
    pub fn deflection(
        &self,
        driven: &[f64],
        load_kg: f64,
    ) -> Result<Deflection<f64>, model::DeflectionError> {
        match self.config.spring() {
            Spring::Linear => self
                .arm
                .chain()
                .deflect(driven, load_kg, &SolverOptions::default()),
            spring => spring_deflection(&self.arm, driven, load_kg, spring).map(|(d, _)| d),
        }
    }

    /// Measures every pose under every load: one [`Pass`] per load, in
    /// order. See [`TrueArm::simulate_passes`].
    pub fn simulate(&self, poses: &[Pose], loads_kg: &[f64]) -> Result<Simulation, SimError> {
        let passes: Vec<Pass<'_>> = loads_kg
            .iter()
            .map(|&load_kg| Pass { load_kg, poses })
            .collect();
        self.simulate_passes(&passes)
    }

    /// Runs the passes in order, the first from home (see the module docs
    /// for the effects). Deterministic: the same true arm and passes give the
    /// same numbers (the noise comes from the arm's seed).
    pub fn simulate_passes(&self, passes: &[Pass<'_>]) -> Result<Simulation, SimError> {
        check_passes(passes)?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(NOISE_STREAM);
        let capacity = passes.iter().map(|p| p.poses.len()).sum();
        let (mut measurements, mut noise_free) =
            (Vec::with_capacity(capacity), Vec::with_capacity(capacity));
        let ways = approaches(
            passes
                .iter()
                .flat_map(|p| p.poses.iter().map(|pose| &pose.q)),
        );
        let mut ways = ways.into_iter();
        for &Pass { load_kg, poses } in passes {
            for (pose, approach) in poses.iter().zip(ways.by_ref()) {
                let driven = self.driven_angles(&pose.q, &approach);
                let point =
                    self.tool_point(&driven, load_kg)
                        .map_err(|reason| SimError::Model {
                            pose: pose.id,
                            load_kg,
                            reason,
                        })?;
                let noise: [f64; 3] =
                    core::array::from_fn(|_| rng.sample::<f64, _>(StandardNormal));
                let exact = Measurement {
                    pose: *pose,
                    load_kg,
                    position: point,
                    pixel: None,
                    target: None,
                    approach,
                };
                noise_free.push(exact);
                measurements.push(Measurement {
                    position: point + Vector3::from(noise) * self.config.noise_sigma_m,
                    ..exact
                });
            }
        }
        Ok(Simulation {
            measurements,
            noise_free,
        })
    }

    /// The measurements of [`TrueArm::simulate`] (with tracker noise).
    pub fn measure(&self, poses: &[Pose], loads_kg: &[f64]) -> Result<Vec<Measurement>, SimError> {
        self.simulate(poses, loads_kg).map(|s| s.measurements)
    }
}

/// One pass of the tracker: poses measured in order under one load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pass<'a> {
    /// Payload at the tool for the whole pass, kg.
    pub load_kg: f64,
    /// The poses, in the order they are visited.
    pub poses: &'a [Pose],
}

/// Pose ids must be unique within a pass (a measurement file keys rows by
/// (pose, load)), angles finite, loads finite, non-negative and one per pass.
fn check_passes(passes: &[Pass<'_>]) -> Result<(), SimError> {
    for (i, pass) in passes.iter().enumerate() {
        let load = pass.load_kg;
        if !(load.is_finite() && load >= 0.0) {
            return Err(SimError::Load {
                load_kg: load,
                reason: "expected a finite mass >= 0 kg",
            });
        }
        if passes[..i].iter().any(|p| p.load_kg == load) {
            return Err(SimError::Load {
                load_kg: load,
                reason: "each load may be given only once",
            });
        }
        let mut ids = HashSet::new();
        for pose in pass.poses {
            if !ids.insert(pose.id) {
                return Err(SimError::DuplicatePose { pose: pose.id });
            }
            if pose.q.iter().any(|q| !q.is_finite()) {
                return Err(SimError::NonFiniteAngle { pose: pose.id });
            }
        }
    }
    Ok(())
}
