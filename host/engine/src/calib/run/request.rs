//! What a calibration run is asked: the nominal arm, the measurements, the
//! options, how poses are chosen and how the arm is placed, built from
//! [`Request::new`] by its setters.

use model::{Arm, Frame};
use nalgebra::{IsometryMatrix3, Point3, Vector3};

use crate::calib::ModelOption;
use crate::calib::fit::identify::IdentifyOptions;
use crate::calib::fit::registration::Gravity;
use crate::calib::parameters::camera::RigCamera;
use crate::calib::parameters::option::DEFAULT;
use crate::camera::corner_measurements::corner_target;
use lrmcal_core::camera::{CameraSetup, Intrinsics, Mount};
use lrmcal_core::dataset::{Measurement, Pose, TargetName};

/// Which measured poses the fit uses.
#[derive(Clone, Debug, PartialEq)]
pub enum PoseChoice {
    /// `n` poses chosen by DETMAX (D-optimal for each option).
    Detmax {
        /// How many poses.
        n: usize,
        /// Random starts.
        starts: usize,
    },
    /// The poses of a list, named `file` in messages.
    Listed {
        /// Pose ids.
        ids: Vec<u32>,
        /// The list's file, for messages.
        file: String,
    },
    /// Every measured pose.
    All,
}

/// Where the arm stands in the measurement frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Placement {
    /// Found from the measurements ([`register`]).
    Register(Gravity),
    /// The arm file's base: the measurements are in its world frame.
    Keep(Gravity),
}

/// A camera as the instrument: the measurements are the corners of a
/// board seen at their pixels (`calib::parameters::camera`), the board on
/// the flange or the camera there.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraInput {
    /// The camera's lens.
    pub intrinsics: Intrinsics,
    /// Each corner target's place in the board frame, m.
    pub corners: Vec<(TargetName, Vector3<f64>)>,
    /// Which of the two the arm carries.
    pub mount: Mount,
    /// The frame of what the arm carries (the board eye-to-hand, the
    /// camera eye-in-hand) in its last frame, as the camera setup tells it:
    /// the arm's tool frame in the fit.
    pub on_flange: Frame<f64>,
    /// Whether the fit refines the lens with the arm (`calib::parameters::camera`);
    /// otherwise it is held as `intrinsics` tell it.
    pub refine_lens: bool,
}

impl CameraInput {
    /// The camera of `setup` with every corner of its board a target
    /// (`tag7.c2`), in the board's order: what planning for it sees.
    pub fn of_setup(setup: &CameraSetup) -> Self {
        Self {
            intrinsics: setup.intrinsics.clone(),
            corners: setup
                .board
                .tags()
                .flat_map(|(id, corners)| {
                    corners
                        .into_iter()
                        .enumerate()
                        .map(move |(k, corner)| (corner_target(id, k), corner.coords))
                })
                .collect(),
            mount: setup.mount,
            on_flange: match setup.mount {
                Mount::EyeToHand => setup.board_pose,
                Mount::EyeInHand => setup.camera,
            },
            refine_lens: false,
        }
    }

    /// The board's corners where the fit has them and the camera that sees
    /// them, `still_from_world` taking the arm's world frame to the frame of
    /// what stands still (the camera eye-to-hand, the board eye-in-hand):
    /// eye-to-hand the corners `on_board` ride the tool frame and the camera
    /// stands there; eye-in-hand the corners lie in the world where the
    /// board stands, and the camera rides the tool frame. Its lens is held.
    pub fn seen_by(
        &self,
        on_board: impl Iterator<Item = Vector3<f64>>,
        still_from_world: IsometryMatrix3<f64>,
    ) -> (Vec<Vector3<f64>>, RigCamera) {
        match self.mount {
            Mount::EyeToHand => (
                on_board.collect(),
                RigCamera::fixed(self.intrinsics.clone(), still_from_world),
            ),
            Mount::EyeInHand => {
                let board_in_world = still_from_world.inverse();
                (
                    on_board
                        .map(|c| (board_in_world * Point3::from(c)).coords)
                        .collect(),
                    RigCamera::on_flange(self.intrinsics.clone()),
                )
            }
        }
    }

    /// `arm` as the camera's fit starts from it: its tool frame moved to
    /// what it carries ([`CameraInput::on_flange`]), its payload's centre
    /// of mass kept where it is.
    pub fn nominal_arm(&self, arm: &Arm<f64>) -> Arm<f64> {
        let carried = self.on_flange;
        let com = arm.tool.isometry() * Point3::from(arm.payload_com);
        Arm {
            tool: carried,
            payload_com: (carried.isometry().inverse() * com).coords.into(),
            ..*arm
        }
    }

    /// The place of the corner target `name` in the board frame, if it is one.
    pub fn corner(&self, name: Option<TargetName>) -> Option<Vector3<f64>> {
        self.corners
            .iter()
            .find(|(n, _)| Some(*n) == name)
            .map(|(_, c)| *c)
    }
}

/// What to calibrate, from what.
#[derive(Clone, Debug)]
pub struct Request<'a> {
    /// The nominal arm, as its file describes it.
    pub nominal: &'a Arm<f64>,
    /// Where the nominal arm came from, for the report.
    pub arm_origin: String,
    /// Every measurement read, every target and load.
    pub measurements: &'a [Measurement],
    /// The measurement file, for messages and the report.
    pub measurements_file: String,
    /// The load to fit, kg; `None`: the file's only load.
    pub load_kg: Option<f64>,
    /// Candidate poses every measured pose must be one of, if given.
    pub candidates: Option<&'a [Pose]>,
    /// How the poses to fit are chosen.
    pub poses: PoseChoice,
    /// The model options, in order.
    pub options: Vec<ModelOption>,
    /// Where the arm stands.
    pub placement: Placement,
    /// How the fit runs.
    pub identify: IdentifyOptions,
    /// The camera, when one measured (the nominal arm's tool frame is then
    /// what the arm carries: [`CameraInput::on_flange`]).
    pub camera: Option<CameraInput>,
}

impl<'a> Request<'a> {
    /// Calibrating `nominal` from `measurements` taken in its file's world
    /// frame (a simulation's): the default option fitted to every pose
    /// measured under the file's only load, the arm kept where its file
    /// stands it, gravity as the file says.
    pub fn new(nominal: &'a Arm<f64>, measurements: &'a [Measurement]) -> Self {
        Self {
            nominal,
            arm_origin: "the nominal arm".into(),
            measurements,
            measurements_file: "the measurements".into(),
            load_kg: None,
            candidates: None,
            poses: PoseChoice::All,
            options: vec![DEFAULT],
            placement: Placement::Keep(Gravity::Measured(nominal.gravity_vector())),
            identify: IdentifyOptions::default(),
            camera: None,
        }
    }

    /// Names the arm and the measurements in the report and in messages.
    pub fn named(
        self,
        arm_origin: impl Into<String>,
        measurements_file: impl Into<String>,
    ) -> Self {
        Self {
            arm_origin: arm_origin.into(),
            measurements_file: measurements_file.into(),
            ..self
        }
    }

    /// Fits under the load `load_kg`.
    pub fn load(self, load_kg: f64) -> Self {
        Self {
            load_kg: Some(load_kg),
            ..self
        }
    }

    /// Every measured pose must be one of `candidates`.
    pub fn candidates(self, candidates: &'a [Pose]) -> Self {
        Self {
            candidates: Some(candidates),
            ..self
        }
    }

    /// Fits `options`, in order.
    pub fn options(self, options: Vec<ModelOption>) -> Self {
        Self { options, ..self }
    }

    /// Chooses the poses to fit as `poses` says.
    pub fn poses(self, poses: PoseChoice) -> Self {
        Self { poses, ..self }
    }

    /// Places the arm as `placement` says.
    pub fn placement(self, placement: Placement) -> Self {
        Self { placement, ..self }
    }

    /// The measurements are `camera`'s.
    pub fn camera(self, camera: CameraInput) -> Self {
        Self {
            camera: Some(camera),
            ..self
        }
    }

    /// Runs the fits as `identify` says.
    pub fn identify(self, identify: IdentifyOptions) -> Self {
        Self { identify, ..self }
    }
}
