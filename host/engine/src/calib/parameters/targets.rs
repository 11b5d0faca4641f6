//! Several measured targets per pose: one arm, one tool point per target.
//!
//! A laser tracker or a motion-capture rig measures several targets on the end
//! effector at each pose. They share everything but their position on the
//! flange, so they are fitted together: the arm's parameters once, and per
//! target a tool point (x, y, z in frame 6, the tool frame's parent). Target
//! 0, the first one a measurement file names, is the arm's own tool point
//! (`tool.x/y/z`); each further target `t` has the three keys
//! [`ParamKey::TargetTool`], named `tool[t].x` … ([`Rig`] holds their values).
//!
//! The deflection does not depend on which target is measured (the payload
//! hangs where it hangs), so a target's point is the deflected frame 6 times
//! its tool point.
//!
//! **What a calibration means** is [`Rig::evaluate`]: a commanded pose, its
//! load and the way each joint arrived in, the joint angles the arm stands
//! at, its deflected state and the tool point out. The fit, its validation,
//! `predict`, `validate` and the simulator's comparisons all go through it.
//!
//! A target's three coordinates are fixed by its own measurements only: with
//! fewer than [`MIN_TARGET_POSES`] poses the fit would have as many unknowns
//! as equations for it and nothing would check them, so such a file is
//! refused ([`Targets::check_poses`]).

use model::bounds::Bounds;
use model::{Arm, Deflection, PerJoint, ServoCurve, SolverOptions};
use nalgebra::{IsometryMatrix3, Point3, Vector3};

use super::camera::{Observation, RigCamera, tracked};
use crate::calib::{CalibError, Sample};
use lrmcal_core::camera::Mount;
use lrmcal_core::dataset::{Measurement, TargetName};
use lrmcal_core::param_key::ParamKey;

/// Fewest distinct poses a target must be measured at to be fitted.
pub const MIN_TARGET_POSES: usize = 3;

/// The arm and the tool points of its further targets: what the calibration's
/// parameters correct.
#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    /// The arm; its tool point is target 0's.
    pub arm: Arm<f64>,
    /// Tool points of targets 1, 2, … in the last frame, m.
    pub tools: Vec<Vector3<f64>>,
    /// The targets' names, as many as tool points.
    pub targets: Targets,
    /// The servo curves the measurements were commanded through (the
    /// nominal arm's); where the arm's own curves differ, a command stands
    /// elsewhere (`model::command::reached`).
    pub command_curves: PerJoint<Option<ServoCurve<f64>>>,
    /// The physical bounds of its parameters: those of the nominal arm the
    /// rig was first made from, whatever the fit changes after.
    pub bounds: Bounds<f64>,
    /// When its targets are the corners of a board: each target's corner
    /// (m) in the tool frame, which is the board's frame, or, when the
    /// camera rides the flange ([`RigCamera::mount`] eye-in-hand), in the
    /// world, where the board lies; `tools` is then empty, and the tool
    /// frame's six parameters place the board (or the camera).
    pub board: Option<Vec<Vector3<f64>>>,
    /// The camera that measures the targets, when one does ([`RigCamera`]):
    /// the measurements are then pixels.
    pub camera: Option<RigCamera>,
    /// When the base stands level: gravity's magnitude, m/s², along frame
    /// 0's `-z` wherever the fit turns the base ([`Rig::placed_arm`]). The
    /// base's tilt then turns gravity with it instead of leaning the arm
    /// against it: with a camera, whose frame says nothing of up, the
    /// base's six parameters place the arm before the camera and gravity
    /// stays under the base.
    pub level_base: Option<f64>,
}

/// Where the arm's last frame stands for a sample (deflected), and the
/// sample's tool point on it.
type Standing = (IsometryMatrix3<f64>, Vector3<f64>);

/// A commanded pose evaluated: where the rig stands and where its target goes.
#[derive(Clone, Copy, Debug)]
pub struct Evaluated {
    /// The joint angles the arm stands at before it deflects, rad
    /// ([`Rig::standing_angles`]).
    pub standing: PerJoint<f64>,
    /// Its deflected state under the load (deflected angles, base tilt).
    pub deflection: Deflection<f64>,
    /// Where the sample's target goes, world frame, m.
    pub tool_m: Vector3<f64>,
}

impl From<Arm<f64>> for Rig {
    /// The arm alone: one unnamed target, its tool point.
    fn from(arm: Arm<f64>) -> Self {
        Self::new(arm, Targets::single())
    }
}

impl Rig {
    /// `arm` measured at `targets`, each further one starting at the arm's
    /// tool point (a tool point enters the measured point linearly, so the
    /// fit needs no better start).
    pub fn new(arm: Arm<f64>, targets: Targets) -> Self {
        let start = Vector3::from(arm.tool.xyz);
        Self {
            arm,
            tools: vec![start; targets.len().saturating_sub(1)],
            targets,
            command_curves: arm.joints.map(|j| j.servo),
            bounds: Bounds::of(&arm),
            board: None,
            camera: None,
            level_base: None,
        }
    }

    /// `arm` carrying a board whose `corners` (the tool frame's, m, one per
    /// target of `targets`) `camera` measures: the tool frame is the board's.
    pub fn on_board(
        arm: Arm<f64>,
        targets: Targets,
        corners: Vec<Vector3<f64>>,
        camera: RigCamera,
    ) -> Self {
        Self {
            tools: Vec::new(),
            board: Some(corners),
            camera: Some(camera),
            ..Self::new(arm, targets)
        }
    }

    /// The world point the instrument measures for `sample`, the arm's
    /// last frame standing at `last`: the target the arm carries (its tool
    /// point `tool_point` on that frame), or, with a camera on the flange,
    /// the board's corner where it lies.
    pub fn measured_point(
        &self,
        sample: &Sample,
        last: &IsometryMatrix3<f64>,
        tool_point: &Vector3<f64>,
    ) -> Vector3<f64> {
        match (&self.camera, &self.board) {
            (Some(c), Some(corners)) if c.mount == Mount::EyeInHand => {
                corners.get(sample.target).copied().unwrap_or_default()
            }
            // As `model::Chain::frames` places the tool point on the last frame.
            _ => last.rotation * tool_point + last.translation.vector,
        }
    }

    /// What the rig's instrument measures of `point` (the arm's world
    /// frame, [`Rig::measured_point`]) for `sample`, the arm's last frame
    /// standing at `last`: the point, or its pixel when a camera measures.
    pub fn observe(
        &self,
        sample: &Sample,
        last: &IsometryMatrix3<f64>,
        point: &Vector3<f64>,
    ) -> Result<Observation, CalibError> {
        let Some(camera) = &self.camera else {
            return Ok(tracked(point));
        };
        let seen = match camera.mount {
            Mount::EyeToHand => camera.observe(point),
            Mount::EyeInHand => camera.observe_carried(&(last * self.arm.tool.isometry()), point),
        };
        seen.ok_or_else(|| {
            deflection_error(
                sample,
                "the board's corner falls behind the camera or outside its lens's field".into(),
            )
        })
    }

    /// How many axes a measurement's block has: 3 for a tracker's point, 2
    /// for a camera's pixel (its third row is always zero).
    pub fn measured_axes(&self) -> usize {
        match self.camera {
            Some(_) => 2,
            None => 3,
        }
    }

    /// What the rig's instrument measures for every sample ([`Rig::observe`]).
    pub fn observations(&self, samples: &[Sample]) -> Result<Vec<Observation>, CalibError> {
        self.standing(samples)?
            .iter()
            .zip(samples)
            .map(|((last, tool), s)| self.observe(s, last, &self.measured_point(s, last, tool)))
            .collect()
    }

    /// The residual blocks of every sample against its measurement's
    /// `measured` block (`calib::parameters::camera`), m: the fit's
    /// residuals and every comparison with measurements.
    pub fn residuals(
        &self,
        samples: &[Sample],
        measured: &[Vector3<f64>],
    ) -> Result<Vec<Vector3<f64>>, CalibError> {
        Ok(self
            .observations(samples)?
            .iter()
            .zip(measured)
            .map(|(o, m)| o.residual(m))
            .collect())
    }

    /// The arm's chain, its springs softening as the arm says, gravity as
    /// [`Rig::placed_arm`] has it.
    pub fn chain(&self) -> model::Chain<f64> {
        self.placed_arm().chain()
    }

    /// The arm, its gravity along its base's `-z` when the base stands level
    /// ([`Rig::level_base`]), else as it is.
    pub fn placed_arm(&self) -> Arm<f64> {
        let mut arm = self.arm;
        if let Some(g) = self.level_base {
            arm.gravity = (arm.base.isometry().rotation * Vector3::new(0.0, 0.0, -g)).into();
        }
        arm
    }

    /// The joint angles the arm stands at when `sample` was commanded: where
    /// its servos drive the command sent through [`Rig::command_curves`],
    /// short of it or beyond by half the play the way each joint arrived.
    pub fn standing_angles(&self, sample: &Sample) -> PerJoint<f64> {
        model::command::standing(&self.arm, &self.command_curves, &sample.q, &sample.approach)
    }

    /// What the calibration means for `sample` (module docs): the joint
    /// angles the arm stands at, its deflected state and where the sample's
    /// target goes.
    pub fn evaluate(&self, sample: &Sample) -> Result<Evaluated, CalibError> {
        let chain = self
            .target_chain(sample.target)
            .ok_or_else(|| unknown_target(self.targets.len(), sample))?;
        evaluate_on(self, &chain, sample)
    }

    /// The chain of target `t`: the arm's with that target's tool point (the
    /// deflection does not depend on which target is measured).
    fn target_chain(&self, t: usize) -> Option<model::Chain<f64>> {
        let mut chain = self.chain();
        chain.tool_point = self.tool_point(t)?;
        Some(chain)
    }

    /// The tool points of [`Rig::evaluate`] for every sample (each its own
    /// target's), world frame, m: the fit's residuals and every comparison
    /// with measurements come from here.
    ///
    /// Samples of one pose (several targets measured at once: a camera's
    /// corners) share its deflection, solved once ([`same_pose`]).
    pub fn tool_points(&self, samples: &[Sample]) -> Result<Vec<Vector3<f64>>, CalibError> {
        Ok(self
            .standing(samples)?
            .iter()
            .map(|(last, tool)| last.rotation * tool + last.translation.vector)
            .collect())
    }

    /// For every sample, where the arm's last frame stands (deflected) and
    /// the sample's tool point on it; the samples of one pose share its
    /// deflection, solved once ([`same_pose`]).
    fn standing(&self, samples: &[Sample]) -> Result<Vec<Standing>, CalibError> {
        let chains = target_chains(self);
        let mut points = Vec::with_capacity(samples.len());
        let mut standing: Option<(&Sample, IsometryMatrix3<f64>)> = None;
        for sample in samples {
            let chain = chain_of(&chains, sample)?;
            let last = match standing {
                Some((before, last)) if same_pose(before, sample) => last,
                _ => {
                    let last = evaluate_on(self, chain, sample)?
                        .deflection
                        .frames
                        .frames
                        .last_value();
                    standing = Some((sample, last));
                    last
                }
            };
            points.push((last, chain.tool_point));
        }
        Ok(points)
    }

    /// The same rig with no play: a joint whose approach is unknown is
    /// taken to stand at the middle of its play, its command (the error is
    /// then at most half the play, either way).
    pub fn without_play(&self) -> Self {
        let mut rig = self.clone();
        for j in &mut rig.arm.joints {
            j.backlash = 0.0;
        }
        rig
    }

    /// Tool point of target `t` in frame 6, m, if the rig has it.
    pub fn tool_point(&self, t: usize) -> Option<Vector3<f64>> {
        if let Some(corners) = &self.board {
            let corner = corners.get(t)?;
            // A camera on the flange: every corner is seen from its origin.
            if self.camera.as_ref().map(|c| c.mount) == Some(Mount::EyeInHand) {
                return Some(Vector3::from(self.arm.tool.xyz));
            }
            return Some(self.arm.tool.isometry() * Point3::from(*corner)).map(|p| p.coords);
        }
        match t {
            0 => Some(Vector3::from(self.arm.tool.xyz)),
            _ => self.tools.get(t - 1).copied(),
        }
    }

    /// The arm as it measures target `t`: its tool point moved to the target's.
    pub fn arm_of(&self, t: usize) -> Option<Arm<f64>> {
        let mut arm = self.arm;
        arm.tool.xyz = self.tool_point(t)?.into();
        Some(arm)
    }

    /// The keys of every target's tool point beyond target 0's, in target order.
    pub fn tool_keys(&self) -> Vec<ParamKey> {
        match self.board {
            // A board's corners sit where the board's frame puts them.
            Some(_) => Vec::new(),
            None => tool_keys(1..self.targets.len()),
        }
    }

    /// The samples of `measurements`, each with its target's index; a
    /// target the rig does not have is refused, listing those it has.
    pub fn samples(&self, measurements: &[Measurement]) -> Result<Vec<Sample>, CalibError> {
        measurements
            .iter()
            .map(|m| {
                let target =
                    self.targets
                        .index(m.target)
                        .ok_or_else(|| CalibError::UnknownTarget {
                            target: name_of(m.target),
                            known: self.targets.names().join(", "),
                        })?;
                Ok(Sample {
                    target,
                    ..Sample::from(m)
                })
            })
            .collect()
    }
}

/// [`Rig::evaluate`] with the chain of the sample's target.
fn evaluate_on(
    rig: &Rig,
    chain: &model::Chain<f64>,
    sample: &Sample,
) -> Result<Evaluated, CalibError> {
    let standing = rig.standing_angles(sample);
    let deflection = chain
        .deflect(&standing, sample.load_kg, &SolverOptions::default())
        .map_err(|e| deflection_error(sample, e.to_string()))?;
    Ok(Evaluated {
        standing,
        tool_m: deflection.tool_point(),
        deflection,
    })
}

/// Whether two samples stand the arm the same way: the same pose, load and
/// approach, so the same deflection whichever target each measures.
pub(crate) fn same_pose(a: &Sample, b: &Sample) -> bool {
    a.id == b.id && a.q == b.q && a.load_kg == b.load_kg && a.approach == b.approach
}

/// One chain per target ([`Rig::target_chain`]), in target order.
pub(crate) fn target_chains(rig: &Rig) -> Vec<model::Chain<f64>> {
    (0..rig.targets.len())
        .filter_map(|t| rig.target_chain(t))
        .collect()
}

/// The chain of `sample`'s target.
pub(crate) fn chain_of<'a>(
    chains: &'a [model::Chain<f64>],
    sample: &Sample,
) -> Result<&'a model::Chain<f64>, CalibError> {
    chains
        .get(sample.target)
        .ok_or_else(|| unknown_target(chains.len(), sample))
}

/// The error of a sample of a target the calibration (of `targets` targets) lacks.
fn unknown_target(targets: usize, sample: &Sample) -> CalibError {
    deflection_error(
        sample,
        format!(
            "the calibration has {targets} targets, not a target {}",
            sample.target
        ),
    )
}

/// The error of a sample whose deflection cannot be solved.
pub(crate) fn deflection_error(sample: &Sample, message: String) -> CalibError {
    CalibError::Deflection {
        pose: sample.id,
        load_kg: sample.load_kg,
        message,
    }
}

/// A target's name as files and messages show it: `tool` for the unnamed one.
fn name_of(name: Option<TargetName>) -> String {
    name.map_or_else(|| UNNAMED.to_string(), |n| n.to_string())
}

/// What the one target of a file without a `target` column is called.
pub const UNNAMED: &str = "tool";

/// The tool-point keys of `targets` (target 0's are the arm's `tool.x/y/z`).
pub fn tool_keys(targets: impl IntoIterator<Item = usize>) -> Vec<ParamKey> {
    targets
        .into_iter()
        .flat_map(|t| (0..3).filter_map(move |axis| ParamKey::tool(t, axis)))
        .collect()
}

/// The targets of a measurement set, in the order the file first names them.
#[derive(Clone, Debug, PartialEq)]
pub struct Targets {
    /// Names, in order; one `None` for a file without a `target` column.
    names: Vec<Option<TargetName>>,
}

impl Targets {
    /// The one unnamed target of a file without a `target` column.
    pub fn single() -> Self {
        Self { names: vec![None] }
    }

    /// Targets with these names, in order.
    pub fn named_as(names: &[TargetName]) -> Self {
        Self {
            names: names.iter().copied().map(Some).collect(),
        }
    }

    /// The targets `measurements` name, in order of first appearance (the
    /// measurement reader refuses a file with more than
    /// [`lrmcal_core::dataset::MAX_TARGETS`]).
    pub fn of(measurements: &[Measurement]) -> Self {
        let mut names: Vec<Option<TargetName>> = Vec::new();
        for m in measurements {
            if !names.contains(&m.target) {
                names.push(m.target);
            }
        }
        if names.is_empty() {
            names.push(None);
        }
        Self { names }
    }

    /// Number of targets.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Whether there is no target (never: a set has at least its one tool point).
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Whether the measurements name their targets (the file has a `target` column).
    pub fn named(&self) -> bool {
        self.names.iter().any(Option::is_some)
    }

    /// The targets' names in order ([`UNNAMED`] for the unnamed one).
    pub fn names(&self) -> Vec<String> {
        self.names.iter().map(|n| name_of(*n)).collect()
    }

    /// The name of target `t` (`None` for the unnamed one or past the last).
    pub fn name_at(&self, t: usize) -> Option<TargetName> {
        self.names.get(t).copied().flatten()
    }

    /// Index of the target called `name`. The unnamed target is the one
    /// called [`UNNAMED`], as the calibration file writes it: a calibration
    /// re-taught (`--tool-only`) from a file without a `target` column lists
    /// its target as `tool`, and that file's rows are that target's.
    pub fn index(&self, name: Option<TargetName>) -> Option<usize> {
        self.names
            .iter()
            .position(|n| *n == name)
            .or_else(|| self.names.iter().position(|n| name_of(*n) == name_of(name)))
    }

    /// Refuses a set where some target is measured at fewer than
    /// [`MIN_TARGET_POSES`] distinct poses: its three coordinates would not
    /// be checked by anything.
    pub fn check_poses(&self, measurements: &[Measurement], file: &str) -> Result<(), CalibError> {
        for (t, name) in self.names().into_iter().enumerate() {
            let mut poses: Vec<u32> = measurements
                .iter()
                .filter(|m| self.index(m.target) == Some(t))
                .map(|m| m.pose.id)
                .collect();
            poses.sort_unstable();
            poses.dedup();
            if poses.len() < MIN_TARGET_POSES {
                return Err(CalibError::TargetTooFewPoses {
                    file: file.into(),
                    target: name,
                    poses: poses.len(),
                    needed: MIN_TARGET_POSES,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::parameters::params::Key as _;
    use crate::calib::testing::{measure, measure_rig, rigid_nominal, small_samples};

    fn names(names: &[&str]) -> Targets {
        let names: Vec<TargetName> = names
            .iter()
            .map(|n| TargetName::from(n).expect("short name"))
            .collect();
        Targets::named_as(&names)
    }

    /// Measurements at `n` poses, each named in turn after `targets`.
    fn rows(n: usize, targets: &[&str]) -> Vec<Measurement> {
        let mut rows = measure(&rigid_nominal(), &small_samples(n));
        for (k, m) in rows.iter_mut().enumerate() {
            m.target = TargetName::from(targets[k % targets.len()]).ok();
        }
        rows
    }

    #[test]
    fn targets_are_indexed_in_order_of_first_appearance() {
        let rows = rows(6, &["b", "a"]);
        let targets = Targets::of(&rows);
        assert_eq!(targets, names(&["b", "a"]));
        assert!(targets.named());
        let rig = Rig::new(rigid_nominal(), targets.clone());
        let samples = rig.samples(&rows).unwrap();
        assert_eq!(
            samples.iter().map(|s| s.target).collect::<Vec<_>>(),
            [0, 1, 0, 1, 0, 1]
        );
        let plain = Targets::of(&measure(&rigid_nominal(), &small_samples(2)));
        assert_eq!(
            (plain.names(), plain.named()),
            (vec![UNNAMED.to_string()], false)
        );
        // The unnamed target is the one a calibration file lists as `tool`.
        let listed = names(&[UNNAMED]);
        assert_eq!(listed.index(None), Some(0));
        assert_eq!(
            Targets::single().index(TargetName::from(UNNAMED).ok()),
            Some(0)
        );
        assert_eq!(names(&["b", "a"]).index(None), None);
        // Rows of a target the rig lacks are refused with the rig's names.
        let e = Rig::new(rigid_nominal(), names(&["b"]))
            .samples(&rows)
            .unwrap_err()
            .to_string();
        assert!(e.contains("`a`") && e.contains("targets b"), "{e}");
    }

    /// A target measured at two poses is refused, naming the file, the
    /// target, its count and the count needed; three poses are enough.
    #[test]
    fn a_target_seen_at_two_poses_is_refused() {
        let mut rows = rows(8, &["m1"]);
        rows[3].target = TargetName::from("m2").ok();
        rows[6].target = TargetName::from("m2").ok();
        let targets = Targets::of(&rows);
        let text = targets.check_poses(&rows, "m.csv").unwrap_err().to_string();
        for part in ["m.csv", "`m2`", "at 2 poses", "at least 3"] {
            assert!(text.contains(part), "{text}");
        }
        rows[1].target = TargetName::from("m2").ok();
        targets.check_poses(&rows, "m.csv").unwrap();
    }

    #[test]
    fn target_zero_uses_the_arm_tool_and_others_their_own() {
        let mut rig = Rig::new(rigid_nominal(), names(&["a", "b", "c"]));
        rig.tools[1] = Vector3::new(0.01, 0.02, 0.03);
        assert_eq!(rig.tool_point(0), Some(Vector3::from(rig.arm.tool.xyz)));
        assert_eq!(rig.tool_point(1), Some(Vector3::from(rig.arm.tool.xyz)));
        assert_eq!(rig.tool_point(2), Some(Vector3::new(0.01, 0.02, 0.03)));
        assert_eq!(rig.tool_point(3), None);
        assert_eq!(rig.arm_of(2).unwrap().tool.xyz, [0.01, 0.02, 0.03]);
        let keys = tool_keys(0..3);
        let names: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
        assert_eq!(
            names,
            [
                "tool.x",
                "tool.y",
                "tool.z",
                "tool[1].x",
                "tool[1].y",
                "tool[1].z",
                "tool[2].x",
                "tool[2].y",
                "tool[2].z"
            ]
        );
        assert_eq!(rig.tool_keys(), keys[3..]);
        for k in &keys {
            assert_eq!(ParamKey::from_name(&k.name()), Some(*k));
        }
        assert_eq!(ParamKey::from_name("tool[0].x"), None);
        assert_eq!(ParamKey::from_name("tool[1].w"), None);
        // Each key corrects its own target's coordinate.
        let mut v = crate::calib::ParamVector::new(keys.iter().copied()).unwrap();
        v.set(keys[7], 0.005).unwrap();
        let moved = v.apply(&rig);
        assert_eq!(moved.tools[1].y, 0.025);
        assert_eq!(moved.tools[0], rig.tools[0]);
        assert_eq!(keys[7].value(&moved), 0.025);
    }

    /// Three markers 0, 30 and 60 mm apart measured at every pose, with
    /// 0.1 mm noise: one fit shares the arm and gives each its tool point,
    /// and on poses not used it is no worse for any marker than that marker
    /// calibrated alone (it sees three times the data for the same arm).
    #[test]
    fn three_targets_fitted_together_beat_each_alone_on_held_out_poses() {
        use crate::calib::ModelOption;
        use crate::calib::fit::pipeline::{Choice, RunSettings};
        use crate::calib::testing::calibrate_in_arm_frame;
        use lrmcal_core::dataset::Pose;

        let nominal = rigid_nominal();
        let sizes = model::testing::ErrorSizes {
            length_m: 1e-3,
            angle_rad: 5e-3,
            compliance: 1e-2..5e-2,
        };
        let errors = model::testing::random_errors(
            &mut <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(3),
            &sizes,
        );
        let mut truth = Rig::new(
            nominal.with_errors(&model::ParamId::of(&nominal).collect::<Vec<_>>(), &errors),
            names(&["m0", "m30", "m60"]),
        );
        // The arm's own tool rotation is invisible; keep the truth's tool frame nominal.
        truth.arm.tool = nominal.tool;
        let base = Vector3::from(nominal.tool.xyz);
        truth.tools = vec![
            base + Vector3::new(0.03, 0.0, 0.0),
            base + Vector3::new(0.0, 0.06, 0.0),
        ];
        let load = 0.0663;
        let samples: Vec<Sample> = small_samples(60)
            .into_iter()
            .flat_map(|s| {
                (0..3).map(move |target| Sample {
                    id: s.id,
                    q: s.q,
                    load_kg: load,
                    target,
                    approach: s.approach,
                })
            })
            .collect();
        let mut rows = measure_rig(&truth, &samples);
        for (k, m) in rows.iter_mut().enumerate() {
            // Deterministic noise of about 0.1 mm per axis.
            let n = |i: usize| 1e-4 * (((k * 7 + i * 13) % 11) as f64 - 5.0) / 3.0;
            m.position += Vector3::new(n(0), n(1), n(2));
        }
        let poses: Vec<Pose> = rows.iter().step_by(3).map(|m| m.pose).collect();
        let settings = RunSettings {
            identify_load_kg: load,
            other_load_kg: None,
            choice: Choice::Given(poses[..30].iter().map(|p| p.id).collect()),
            identify: Default::default(),
        };
        let option = ModelOption::ElastoKinematic;
        let together = calibrate_in_arm_frame(&nominal, &rows, option, &settings).unwrap();
        let rig = &together.identified.rig;
        assert_eq!(rig.targets.names(), ["m0", "m30", "m60"]);
        // The tool points' offsets from the first are found to about a mm: they
        // are expressed in the fitted frame 6, which carries the rotation
        // errors positions cannot tell apart (j6.alpha, the tool rotation).
        for t in 1..3 {
            let found = rig.tool_point(t).unwrap() - rig.tool_point(0).unwrap();
            let true_offset = truth.tools[t - 1] - base;
            assert!(
                (found - true_offset).norm() < 2e-3,
                "target {t}: {found} vs {true_offset}"
            );
        }
        let joint = together.validation.as_ref().unwrap().after_per_target(3);
        for (t, name) in ["m0", "m30", "m60"].into_iter().enumerate() {
            let alone_rows: Vec<Measurement> = rows
                .iter()
                .filter(|m| m.target.is_some_and(|n| n.as_str() == name))
                .copied()
                .collect();
            // Alone, a marker is the arm's tool point: its arm file would say where.
            let mut own = nominal;
            own.tool.xyz = truth.tool_point(t).unwrap().into();
            let alone = calibrate_in_arm_frame(&own, &alone_rows, option, &settings).unwrap();
            let alone_after = alone.validation.as_ref().unwrap().after;
            assert_eq!(joint[t].count, alone_after.count);
            assert!(
                joint[t].mean_m <= alone_after.mean_m,
                "{name}: together {:.4} mm, alone {:.4} mm",
                joint[t].mean_m * 1e3,
                alone_after.mean_m * 1e3
            );
            eprintln!(
                "{name}: held-out mean together {:.4} mm, alone {:.4} mm",
                joint[t].mean_m * 1e3,
                alone_after.mean_m * 1e3
            );
        }
    }
}
