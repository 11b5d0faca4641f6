//! Candidate poses: the grid of joint levels, filtered by joint limits, the
//! floor, self-collision between the arm's bodies and, when a camera
//! measures, whether it sees the board the arm carries.
//!
//! ```text
//! nominal Arm + CollisionSpec (arm file) --PlanConfig::for_arm--> PlanConfig
//! LoadedArm (its collision and grid levels) --PlanConfig::for_loaded--> PlanConfig
//! nominal Arm + PlanConfig --candidates--> PlanReport { kept poses, dropped poses with a reason }
//! ```
//!
//! Everything is evaluated on the nominal, rigid arm with the `model` crate
//! (its frames place the bodies and the board). A pose is dropped for the
//! first test it fails, in the order joint limits, floor, self-collision,
//! camera, so every dropped pose has exactly one reason and the counts add up
//! to the grid.
//!
//! | module | what it holds |
//! |---|---|
//! | `grid` | [`Levels`] and the `L^6` grid with stable pose ids |
//! | [`random`] | random poses off the grid |
//! | [`validation`] | the poses a selection sets aside to validate the fit on |
//!
//! The arm's collision bodies, as described and as placed on the arm, are
//! `lrmcal_core::collision`.

mod grid;
pub mod random;
pub mod validation;

use std::fmt;

use model::{Arm, ChainFrames};
use serde::Serialize;

pub use grid::{Levels, LevelsError, MAX_GRID_POSES};
use lrmcal_core::camera::CameraSetup;
use lrmcal_core::collision::{BodySet, CollisionSpec, Contact, Floor, SpecError};
use lrmcal_core::dataset::Pose;
use lrmcal_core::io::arm_source::LoadedArm;

/// The clearance when the arm file gives none, m: servo horns, cables and
/// the model's own error on a small arm; a large arm's bodies already grow
/// with its size, and the margin it needs is the arm file's `clearance`.
pub const DEFAULT_CLEARANCE_M: f64 = 0.01;

/// How to build and filter the candidate grid.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanConfig {
    /// Angles every joint takes. Default -100°, 0°, +100° (the paper's 729 poses).
    pub levels: Levels,
    /// Height of the floor in the world frame, m; `None` for no floor test.
    /// Default 0: the base stands on it.
    pub ground_z_m: Option<f64>,
    /// Smallest gap allowed between two bodies, or a body and the floor, m.
    /// Default [`DEFAULT_CLEARANCE_M`].
    pub clearance_m: f64,
    /// The arm's bodies; `None` (the default): the skeleton of whichever arm
    /// the frames belong to ([`BodySet::skeleton`]).
    pub bodies: Option<BodySet>,
    /// Random poses off the grid to add, drawn over ±100° and kept when they
    /// pass the same tests (see [`random`]). Default 0: the grid alone.
    pub random: usize,
    /// Seed of the random poses.
    pub seed: u64,
    /// The camera that measures and the board the arm carries: a pose whose
    /// board the camera does not see is dropped. Default `None`: no camera.
    pub camera: Option<CameraSetup>,
}

impl Default for PlanConfig {
    fn default() -> Self {
        Self {
            levels: Levels::paper(),
            ground_z_m: Floor::default().z_m(),
            clearance_m: DEFAULT_CLEARANCE_M,
            bodies: None,
            random: 0,
            seed: DEFAULT_RANDOM_SEED,
            camera: None,
        }
    }
}

/// Seed of the random candidate poses unless told otherwise.
pub const DEFAULT_RANDOM_SEED: u64 = 7;

/// Random poses off the grid `lrmcal plan` (and `simulate` without a pose
/// list) adds to the grid unless told otherwise: they let the servo curves
/// be identified between the grid's angles (see `docs/METHOD.md`).
pub const DEFAULT_RANDOM_POSES: usize = 400;

/// Why a grid pose was dropped (the first test it failed).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub enum DropReason {
    /// A joint level lies outside that joint's limits.
    JointLimits {
        /// The first joint out of its limits, 1-based.
        joint: usize,
    },
    /// A body or a pair of bodies comes too close.
    Collision(Contact),
    /// The camera does not see the whole board, facing it.
    NotSeen,
}

impl fmt::Display for DropReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::JointLimits { joint } => write!(f, "joint {joint} out of its limits"),
            Self::Collision(contact) => write!(f, "{contact}"),
            Self::NotSeen => write!(f, "the camera does not see the board"),
        }
    }
}

/// A grid pose that did not survive, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Dropped {
    /// The pose.
    pub pose: Pose,
    /// The first test it failed.
    pub reason: DropReason,
}

/// The outcome of [`candidates`].
#[derive(Clone, Debug, PartialEq)]
pub struct PlanReport {
    /// Poses in the grid.
    pub grid_size: usize,
    /// The surviving poses, in grid order, with their grid ids, then the
    /// random ones (ids from `grid_size` on).
    pub kept: Vec<Pose>,
    /// The dropped poses, in grid order.
    pub dropped: Vec<Dropped>,
    /// Whether a camera was asked to see the board.
    pub camera: bool,
}

/// Counts of dropped poses per kind of reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DropCounts {
    /// Dropped for joint limits.
    pub joint_limits: usize,
    /// Dropped for a body near the floor.
    pub ground: usize,
    /// Dropped for two bodies near each other.
    pub self_collision: usize,
    /// Dropped because the camera does not see the board.
    pub camera: usize,
}

impl PlanReport {
    /// How many poses were dropped for each kind of reason.
    pub fn counts(&self) -> DropCounts {
        let mut counts = DropCounts::default();
        for d in &self.dropped {
            match d.reason {
                DropReason::JointLimits { .. } => counts.joint_limits += 1,
                DropReason::Collision(Contact::Ground { .. }) => counts.ground += 1,
                DropReason::Collision(Contact::SelfCollision { .. }) => counts.self_collision += 1,
                DropReason::NotSeen => counts.camera += 1,
            }
        }
        counts
    }

    /// Dropped poses per detailed reason (which joint, body or pair), most frequent first.
    pub fn detailed_counts(&self) -> Vec<(DropReason, usize)> {
        let mut counts: Vec<(DropReason, usize)> = Vec::new();
        for d in &self.dropped {
            match counts.iter_mut().find(|(r, _)| *r == d.reason) {
                Some((_, n)) => *n += 1,
                None => counts.push((d.reason.clone(), 1)),
            }
        }
        // Stable: ties stay in order of first appearance in the grid.
        counts.sort_by_key(|c| std::cmp::Reverse(c.1));
        counts
    }
}

impl fmt::Display for PlanReport {
    /// A short human summary: survivors, drops per reason, random poses added.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.counts();
        // Random poses have ids after the grid's.
        let random = self
            .kept
            .iter()
            .filter(|p| p.id as usize >= self.grid_size)
            .count();
        writeln!(
            f,
            "{} of {} grid poses kept, {} dropped:",
            self.kept.len() - random,
            self.grid_size,
            self.dropped.len()
        )?;
        writeln!(f, "  joint limits:   {:>7}", c.joint_limits)?;
        writeln!(f, "  ground:         {:>7}", c.ground)?;
        writeln!(f, "  self-collision: {:>7}", c.self_collision)?;
        if self.camera {
            writeln!(f, "  camera:         {:>7}", c.camera)?;
        }
        for (reason, n) in self.detailed_counts() {
            writeln!(f, "    {n:>7}  {reason}")?;
        }
        if random > 0 {
            let seen = if self.camera { ", the board seen" } else { "" };
            writeln!(
                f,
                "{random} random poses off the grid added, clear of the limits and collisions{seen}"
            )?;
        }
        Ok(())
    }
}

/// Why a plan cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// A configuration value is out of range.
    #[error("planner setting `{field}`: expected {expected}, found {found}")]
    Config {
        /// The [`PlanConfig`] field.
        field: &'static str,
        /// What is allowed.
        expected: &'static str,
        /// The value given.
        found: String,
    },
    /// The collision description does not fit the arm.
    #[error("the arm's collision description")]
    Bodies(#[from] SpecError),
    /// The nominal arm has a NaN or infinite number.
    #[error("the nominal arm has a non-finite number")]
    NominalNotFinite,
    /// The grid of these levels is too large for the arm.
    #[error("planner setting `levels`")]
    Levels(#[from] LevelsError),
}

impl PlanConfig {
    /// The paper's grid with the arm file's collision description: its
    /// bodies (or `arm`'s skeleton), floor and clearance.
    pub fn for_arm(arm: &Arm<f64>, spec: &CollisionSpec) -> Result<Self, PlanError> {
        let config = Self {
            ground_z_m: spec.floor.z_m(),
            clearance_m: spec.clearance_m.unwrap_or(DEFAULT_CLEARANCE_M),
            bodies: Some(BodySet::for_arm(arm, spec)?),
            ..Self::default()
        };
        config.check()?;
        Ok(config)
    }

    /// [`PlanConfig::for_arm`] for a loaded arm, with the grid levels its
    /// arm file gives (`[plan] levels_deg`), else the paper's.
    pub fn for_loaded(loaded: &LoadedArm) -> Result<Self, PlanError> {
        let mut config = Self::for_arm(&loaded.arm, &loaded.collision)?;
        if let Some(degrees) = &loaded.levels_deg {
            config.levels = Levels::from_degrees(degrees.clone())?;
        }
        config.levels.grid_size(loaded.arm.joints.len())?;
        Ok(config)
    }

    /// Checks the collision settings: a clearance, floor height and body
    /// sizes that are finite and not negative.
    pub fn check(&self) -> Result<(), PlanError> {
        if !(self.clearance_m.is_finite() && self.clearance_m >= 0.0) {
            return Err(PlanError::Config {
                field: "clearance_m",
                expected: "a finite distance >= 0 m",
                found: self.clearance_m.to_string(),
            });
        }
        if let Some(z) = self.ground_z_m.filter(|z| !z.is_finite()) {
            return Err(PlanError::Config {
                field: "ground_z_m",
                expected: "a finite height, m",
                found: z.to_string(),
            });
        }
        if let Some(b) = self.bodies.as_ref().and_then(BodySet::invalid_size) {
            return Err(PlanError::Config {
                field: "bodies",
                expected: "radii and box sizes that are finite and >= 0 m",
                found: format!("another size for `{}`", b.name),
            });
        }
        Ok(())
    }

    /// What the arm's bodies placed by `frames` come too close to first: the
    /// floor (if tested), then each other; `None` if they are clear. The
    /// collision test of [`candidates`], for any pose.
    pub fn contact(&self, frames: &ChainFrames<f64>) -> Option<Contact> {
        match &self.bodies {
            Some(bodies) => self.contact_of(bodies, frames),
            None => self.contact_of(&BodySet::skeleton(frames, None), frames),
        }
    }

    fn contact_of(&self, bodies: &BodySet, frames: &ChainFrames<f64>) -> Option<Contact> {
        self.ground_z_m
            .and_then(|z| bodies.floor_contact(frames, z, self.clearance_m))
            .or_else(|| bodies.self_contact(frames, self.clearance_m))
    }
}

/// `config` with its bodies placed for `arm` (the skeleton when it has none:
/// the same in every pose, so placed once), after checking both.
fn placed(
    arm: &Arm<f64>,
    chain: &model::Chain<f64>,
    config: &PlanConfig,
) -> Result<PlanConfig, PlanError> {
    config.check()?;
    if !arm.is_finite() {
        return Err(PlanError::NominalNotFinite);
    }
    config.levels.grid_size(arm.joints.len())?;
    let bodies = match &config.bodies {
        Some(b) => b.clone(),
        None => BodySet::skeleton(
            &chain.frames(&model::PerJoint::splat(arm.joints.len(), 0.0), 0.0),
            None,
        ),
    };
    Ok(PlanConfig {
        bodies: Some(bodies),
        ..config.clone()
    })
}

/// `count` random poses off the grid that pass `config`'s tests on `arm`,
/// drawn with `seed`, ids from `first_id` on (see [`random`]): the poses
/// `candidates` adds, or a validation set of poses none of the grid's.
pub fn random_candidates(
    arm: &Arm<f64>,
    config: &PlanConfig,
    count: usize,
    seed: u64,
    first_id: u32,
) -> Result<Vec<Pose>, PlanError> {
    let chain = arm.chain();
    let config = placed(arm, &chain, config)?;
    Ok(random::random_poses(
        arm, &chain, &config, count, seed, first_id,
    ))
}

/// Builds the candidate grid and filters it on the nominal arm, then adds
/// `config.random` random poses.
pub fn candidates(arm: &Arm<f64>, config: &PlanConfig) -> Result<PlanReport, PlanError> {
    let chain = arm.chain();
    let placed = placed(arm, &chain, config)?;
    let config = &placed;
    let mut report = PlanReport {
        grid_size: config.levels.grid_size(arm.joints.len())?,
        kept: Vec::new(),
        dropped: Vec::new(),
        camera: config.camera.is_some(),
    };
    for pose in config.levels.grid(arm.joints.len()) {
        match check_pose(arm, &chain, config, &pose.q) {
            None => report.kept.push(pose),
            Some(reason) => report.dropped.push(Dropped { pose, reason }),
        }
    }
    let first_id = u32::try_from(report.grid_size).unwrap_or(u32::MAX);
    report.kept.extend(random::random_poses(
        arm,
        &chain,
        config,
        config.random,
        config.seed,
        first_id,
    ));
    Ok(report)
}

/// The first test `q` fails, if any.
fn check_pose(
    arm: &Arm<f64>,
    chain: &model::Chain<f64>,
    config: &PlanConfig,
    q: &[f64],
) -> Option<DropReason> {
    if !arm.within_limits(q) {
        // Name the first joint out of its (inclusive) limits.
        let joint = arm
            .joints
            .iter()
            .zip(q)
            .position(|(j, &qi)| qi < j.limits[0] || qi > j.limits[1]);
        return Some(DropReason::JointLimits {
            joint: joint.map_or(0, |i| i + 1),
        });
    }
    let frames = chain.frames(q, 0.0);
    if let Some(contact) = config.contact(&frames) {
        return Some(DropReason::Collision(contact));
    }
    let camera = config.camera.as_ref()?;
    camera
        .sees_board(&frames.frames.last_value())
        .err()
        .map(|_| DropReason::NotSeen)
}

#[cfg(test)]
mod tests;
