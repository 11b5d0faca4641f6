//! Candidate poses: the grid of joint levels, filtered by joint limits, a
//! ground plane and self-collision between the arm's bodies.
//!
//! ```text
//! nominal Arm + PlanConfig --candidates--> PlanReport { kept poses, dropped poses with a reason }
//! ```
//!
//! Everything is evaluated on the nominal, rigid arm with the `model` crate
//! (its frames place the bodies). A pose is dropped for the first test it
//! fails, in the order joint limits, ground, self-collision, so every dropped
//! pose has exactly one reason and the counts add up to the grid.
//!
//! | module | what it holds |
//! |---|---|
//! | `grid` | [`Levels`] and the `L^6` grid with stable pose ids |
//! | `volumes` | the bodies as capsules on the model's frames; ground and self-collision tests |
//! | `segment` | the segment-to-segment distance the capsule test needs |

mod grid;
mod segment;
mod volumes;

use std::fmt;

use model::{Arm, ChainFrames};
use serde::Serialize;

use crate::dataset::Pose;
pub use grid::{Levels, LevelsError, MAX_GRID_POSES};
pub use segment::segment_distance;
pub use volumes::{Anchor, Capsule, Contact, elbow_arm_bodies, ground_contact, self_contact};

/// How to build and filter the candidate grid.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanConfig {
    /// Angles every joint takes. Default -100°, 0°, +100° (the paper's 729 poses).
    pub levels: Levels,
    /// Height of the ground plane in the world frame, m; `None` for no ground
    /// test. Default 0: the base stands on the ground.
    pub ground_z_m: Option<f64>,
    /// Smallest gap allowed between two bodies, or a body and the ground, m.
    /// Default 10 mm (servo horns, cables and the model's own error).
    pub clearance_m: f64,
    /// The arm's bodies, base to tip. Default [`elbow_arm_bodies`].
    pub bodies: Vec<Capsule>,
}

impl Default for PlanConfig {
    fn default() -> Self {
        Self {
            levels: Levels::paper(),
            ground_z_m: Some(0.0),
            clearance_m: 0.01,
            bodies: elbow_arm_bodies(),
        }
    }
}

/// Why a grid pose was dropped (the first test it failed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum DropReason {
    /// A joint level lies outside that joint's limits.
    JointLimits {
        /// The first joint out of its limits, 1-based.
        joint: usize,
    },
    /// A body or a pair of bodies comes too close.
    Collision(Contact),
}

impl fmt::Display for DropReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::JointLimits { joint } => write!(f, "joint {joint} out of its limits"),
            Self::Collision(contact) => write!(f, "{contact}"),
        }
    }
}

/// A grid pose that did not survive, and why.
#[derive(Clone, Copy, Debug, PartialEq)]
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
    /// The surviving poses, in grid order, with their grid ids.
    pub kept: Vec<Pose>,
    /// The dropped poses, in grid order.
    pub dropped: Vec<Dropped>,
}

/// Counts of dropped poses per kind of reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DropCounts {
    /// Dropped for joint limits.
    pub joint_limits: usize,
    /// Dropped for a body near the ground.
    pub ground: usize,
    /// Dropped for two bodies near each other.
    pub self_collision: usize,
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
                None => counts.push((d.reason, 1)),
            }
        }
        // Stable: ties stay in order of first appearance in the grid.
        counts.sort_by_key(|c| std::cmp::Reverse(c.1));
        counts
    }
}

impl fmt::Display for PlanReport {
    /// A short human summary: survivors, and drops per reason.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.counts();
        writeln!(
            f,
            "{} of {} grid poses kept, {} dropped:",
            self.kept.len(),
            self.grid_size,
            self.dropped.len()
        )?;
        writeln!(f, "  joint limits:   {:>7}", c.joint_limits)?;
        writeln!(f, "  ground:         {:>7}", c.ground)?;
        writeln!(f, "  self-collision: {:>7}", c.self_collision)?;
        for (reason, n) in self.detailed_counts() {
            writeln!(f, "    {n:>7}  {reason}")?;
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
    /// The nominal arm has a NaN or infinite number.
    #[error("the nominal arm has a non-finite number")]
    NominalNotFinite,
}

impl PlanConfig {
    /// Checks the collision settings: a clearance, ground height and radii
    /// that are finite and not negative.
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
        if let Some(b) = self
            .bodies
            .iter()
            .find(|b| !(b.radius_m.is_finite() && b.radius_m >= 0.0))
        {
            return Err(PlanError::Config {
                field: "bodies.radius_m",
                expected: "a finite radius >= 0 m",
                found: format!("{} for {}", b.radius_m, b.name),
            });
        }
        Ok(())
    }

    /// What the arm's bodies placed by `frames` come too close to first: the
    /// ground (if tested), then each other; `None` if they are clear. The
    /// collision test of [`candidates`], for any pose.
    pub fn contact(&self, frames: &ChainFrames<f64>) -> Option<Contact> {
        self.ground_z_m
            .and_then(|z| ground_contact(&self.bodies, frames, z, self.clearance_m))
            .or_else(|| self_contact(&self.bodies, frames, self.clearance_m))
    }
}

/// Builds the candidate grid and filters it on the nominal arm.
pub fn candidates(arm: &Arm<f64>, config: &PlanConfig) -> Result<PlanReport, PlanError> {
    config.check()?;
    if !arm.is_finite() {
        return Err(PlanError::NominalNotFinite);
    }
    let chain = arm.chain();
    let mut report = PlanReport {
        grid_size: config.levels.grid_size(),
        kept: Vec::new(),
        dropped: Vec::new(),
    };
    for pose in config.levels.grid() {
        match check_pose(arm, &chain, config, &pose.q) {
            None => report.kept.push(pose),
            Some(reason) => report.dropped.push(Dropped { pose, reason }),
        }
    }
    Ok(report)
}

/// The first test `q` fails, if any.
fn check_pose(
    arm: &Arm<f64>,
    chain: &model::Chain<f64>,
    config: &PlanConfig,
    q: &[f64; model::JOINTS],
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
    config
        .contact(&chain.frames(q, 0.0))
        .map(DropReason::Collision)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::test_support::bundled_arm;

    fn deg(q: [f64; 6]) -> [f64; 6] {
        q.map(f64::to_radians)
    }

    fn contact(arm: &Arm<f64>, q: [f64; 6]) -> Option<Contact> {
        let frames = arm.chain().frames(&deg(q), 0.0);
        self_contact(&elbow_arm_bodies(), &frames, 0.01)
    }

    #[test]
    fn bundled_arm_keeps_about_half_of_the_paper_grid() {
        let report = candidates(&bundled_arm(), &PlanConfig::default()).unwrap();
        assert_eq!(report.grid_size, 729);
        assert_eq!(report.kept.len(), 405);
        assert_eq!(report.kept.len() + report.dropped.len(), 729);
        let counts = report.counts();
        assert_eq!(
            counts,
            DropCounts {
                joint_limits: 0,
                ground: 324,
                self_collision: 0
            }
        );
        // The home pose (arm straight up) survives; ids are grid ids in grid order.
        assert!(report.kept.iter().any(|p| p.id == 364 && p.q == [0.0; 6]));
        assert!(report.kept.windows(2).all(|w| w[0].id < w[1].id));
        // Shoulder down, elbow straight: the forearm reaches the ground.
        let low = report
            .dropped
            .iter()
            .find(|d| d.pose.q == deg([0.0, 100.0, 0.0, 0.0, 0.0, 0.0]))
            .unwrap();
        assert_eq!(
            low.reason,
            DropReason::Collision(Contact::Ground { body: "forearm" })
        );
        let text = report.to_string();
        assert!(
            text.starts_with("405 of 729 grid poses kept, 324 dropped"),
            "{text}"
        );
        assert!(
            text.contains("324  forearm too close to the ground"),
            "{text}"
        );
    }

    #[test]
    fn every_kept_pose_is_clear_of_ground_and_itself() {
        let arm = bundled_arm();
        let config = PlanConfig::default();
        let chain = arm.chain();
        for pose in candidates(&arm, &config).unwrap().kept {
            let frames = chain.frames(&pose.q, 0.0);
            assert_eq!(
                self_contact(&config.bodies, &frames, config.clearance_m),
                None
            );
            for b in config.bodies.iter().filter(|b| b.above_ground) {
                for end in [b.from, b.to] {
                    assert!(
                        end.position(&frames).z - b.radius_m >= 0.01,
                        "pose {}",
                        pose.id
                    );
                }
            }
        }
    }

    #[test]
    fn folded_poses_collide_and_the_home_pose_does_not() {
        let arm = bundled_arm();
        assert_eq!(contact(&arm, [0.0; 6]), None);
        // Elbow folded right back: the wrist comes down onto the shoulder and the hand into the base.
        for elbow in [170.0, -170.0] {
            assert!(
                matches!(
                    contact(&arm, [0.0, 0.0, elbow, 0.0, 0.0, 0.0]),
                    Some(Contact::SelfCollision { .. })
                ),
                "elbow {elbow}"
            );
        }
        // Elbow folded to 150°, wrist bent back towards the upper arm.
        let c = contact(&arm, [0.0, 0.0, 150.0, 0.0, 90.0, 0.0])
            .or(contact(&arm, [0.0, 0.0, 150.0, 0.0, -90.0, 0.0]));
        assert!(matches!(c, Some(Contact::SelfCollision { .. })), "{c:?}");
        // A wide clearance makes a pose that is fine at 10 mm collide.
        let frames = arm
            .chain()
            .frames(&deg([0.0, 0.0, 100.0, 0.0, 100.0, 0.0]), 0.0);
        assert_eq!(self_contact(&elbow_arm_bodies(), &frames, 0.01), None);
        assert!(self_contact(&elbow_arm_bodies(), &frames, 0.08).is_some());
    }

    #[test]
    fn self_collision_counts_when_the_limits_allow_folding() {
        let mut arm = bundled_arm();
        for j in &mut arm.joints {
            j.limits = [-3.0, 3.0];
        }
        let config = PlanConfig {
            levels: "-170,0,170".parse().unwrap(),
            ground_z_m: None,
            ..PlanConfig::default()
        };
        let report = candidates(&arm, &config).unwrap();
        let counts = report.counts();
        assert_eq!(counts.ground, 0);
        assert_eq!(counts.joint_limits, 0);
        assert!(counts.self_collision > 100, "{counts:?}");
        assert!(report.dropped.iter().all(|d| matches!(
            d.reason,
            DropReason::Collision(Contact::SelfCollision { .. })
        )));
    }

    #[test]
    fn joint_limits_are_tested_first_and_name_the_joint() {
        let mut arm = bundled_arm();
        arm.joints[2].limits = [-1.0, 1.0];
        let report = candidates(&arm, &PlanConfig::default()).unwrap();
        // q3 at ±100° is out: two thirds of the grid, whatever else they hit.
        assert_eq!(report.counts().joint_limits, 486);
        assert!(
            report
                .dropped
                .iter()
                .all(|d| d.reason != DropReason::JointLimits { joint: 1 })
        );
        assert!(
            report
                .dropped
                .iter()
                .any(|d| d.reason == DropReason::JointLimits { joint: 3 })
        );
        // Limits are inclusive: a level exactly on the limit is kept.
        arm.joints[2].limits = [-100f64.to_radians(), 100f64.to_radians()];
        assert_eq!(
            candidates(&arm, &PlanConfig::default())
                .unwrap()
                .counts()
                .joint_limits,
            0
        );
    }

    #[test]
    fn the_ground_plane_moves_and_switches_off() {
        let arm = bundled_arm();
        let plan = |ground_z_m| {
            candidates(
                &arm,
                &PlanConfig {
                    ground_z_m,
                    ..PlanConfig::default()
                },
            )
            .unwrap()
        };
        let kept = |ground_z_m| plan(ground_z_m).kept.len();
        // Without the ground, poses that reached below it into the base show up as self-collisions.
        let counts = plan(None).counts();
        assert_eq!(counts.ground, 0);
        assert!(counts.self_collision > 0);
        assert_eq!(kept(None), 729 - counts.self_collision);
        assert!(kept(Some(0.1)) < 405);
        assert!(kept(Some(-0.2)) > 405);
    }

    #[test]
    fn finer_grids_are_filtered_too() {
        let config = PlanConfig {
            levels: Levels::even(4).unwrap(),
            ..PlanConfig::default()
        };
        let report = candidates(&bundled_arm(), &config).unwrap();
        assert_eq!(report.grid_size, 4096);
        assert_eq!(report.kept.len() + report.dropped.len(), 4096);
        assert!(
            report.kept.len() > 1000 && report.dropped.len() > 1000,
            "{}",
            report
        );
    }

    #[test]
    fn bad_settings_are_named() {
        let arm = bundled_arm();
        let err = candidates(
            &arm,
            &PlanConfig {
                clearance_m: -0.01,
                ..PlanConfig::default()
            },
        )
        .unwrap_err();
        assert!(err.to_string().contains("clearance_m"), "{err}");
        let err = candidates(
            &arm,
            &PlanConfig {
                ground_z_m: Some(f64::NAN),
                ..PlanConfig::default()
            },
        )
        .unwrap_err();
        assert!(err.to_string().contains("ground_z_m"), "{err}");
        let mut bodies = elbow_arm_bodies();
        bodies[2].radius_m = -1.0;
        let err = candidates(
            &arm,
            &PlanConfig {
                bodies,
                ..PlanConfig::default()
            },
        )
        .unwrap_err();
        assert!(err.to_string().contains("forearm"), "{err}");
        let mut bad = arm;
        bad.joints[0].d = f64::INFINITY;
        assert_eq!(
            candidates(&bad, &PlanConfig::default()).unwrap_err(),
            PlanError::NominalNotFinite
        );
    }
}
