//! A simulated webcam watching the true arm: the board's tag corners it
//! sees at each pose, with pixel noise, as `detect` would find them.
//!
//! The camera and the board stand where a camera setup tells them, off by
//! errors drawn from the seed: a setup is told roughly (its camera within a
//! few centimetres and degrees, its board within a few millimetres and a
//! degree), and the calibration must find where they really are. A pose is
//! seen when the camera sees the whole board, facing it
//! ([`lrmcal_core::camera::visibility`]), at the true arm's deflected
//! flange; each corner is projected through the camera's lens and moved by
//! Gaussian noise on each pixel axis.

use nalgebra::{IsometryMatrix3, Point2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::Serialize;

use super::render::{Look, render};
use super::{Pass, SimError, TrueArm};
use lrmcal_core::camera::corners::TagCorners;
use lrmcal_core::camera::views::View;
use lrmcal_core::camera::visibility::{self, ViewLimits};
use lrmcal_core::camera::{AprilGrid, CameraSetup, Intrinsics, Mount};
use lrmcal_core::dataset::approaches;
use model::Frame;

/// RNG stream of the webcam's placement (the arm's draw and the tracker
/// noise have streams of their own, so adding a camera changes neither).
const PLACEMENT_STREAM: u64 = 2;
/// RNG stream of the pixel noise.
const PIXEL_NOISE_STREAM: u64 = 3;
/// RNG stream of the first image's light and sensor noise; the next
/// image's is the next stream.
const IMAGE_STREAMS: u64 = 1 << 32;

/// Sigma of the camera's position error against its setup, per axis, m.
pub const CAMERA_XYZ_SIGMA_M: f64 = 0.02;
/// Sigma of the camera's orientation error against its setup, per angle, rad.
pub const CAMERA_RPY_SIGMA_RAD: f64 = 2.0 * std::f64::consts::PI / 180.0;
/// Sigma of the board's position error on the flange, per axis, m.
pub const BOARD_XYZ_SIGMA_M: f64 = 0.002;
/// Sigma of the board's orientation error on the flange, per angle, rad.
pub const BOARD_RPY_SIGMA_RAD: f64 = std::f64::consts::PI / 180.0;

/// The corner noise of a webcam with a sub-pixel detector, px per axis.
pub const DEFAULT_PIXEL_NOISE_PX: f64 = 0.3;

/// The simulated webcam: its lens, the board, and where both really are.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Webcam {
    /// The camera's intrinsics (the setup's: the lens is as calibrated).
    #[serde(skip)]
    pub intrinsics: Intrinsics,
    /// The board the arm carries.
    #[serde(skip)]
    pub board: AprilGrid,
    /// How far from the image's edges and how obliquely the board must be
    /// for the camera to see it: what detection needs, not the planner's margin.
    #[serde(skip)]
    pub limits: ViewLimits,
    /// How the camera and the board are carried.
    pub mount: Mount,
    /// The camera frame where it really is, m and rad: in the arm's world
    /// frame (eye-to-hand) or its last frame (eye-in-hand).
    pub camera: Frame<f64>,
    /// The board frame where it really is, m and rad: in the arm's last
    /// frame (eye-to-hand) or its world frame (eye-in-hand).
    #[serde(rename = "board")]
    pub board_pose: Frame<f64>,
    /// Sigma of the corners' noise on each pixel axis, px.
    pub pixel_noise_px: f64,
    /// The seed of the placement and the noise.
    pub seed: u64,
}

/// What the webcam saw.
#[derive(Clone, Debug, PartialEq)]
pub struct Watched {
    /// The views of the poses it saw the board at, with pixel noise, in the
    /// order they were visited.
    pub views: Vec<View>,
    /// The same views without pixel noise.
    pub noise_free: Vec<View>,
    /// The true arm's last frame in the world at each view.
    pub flanges: Vec<IsometryMatrix3<f64>>,
    /// How many commanded poses (under their loads) it did not see the board at.
    pub unseen: usize,
}

impl Webcam {
    /// The webcam of `setup`, its camera and board placed off the setup's
    /// poses by errors drawn from `seed`, its corners noisy by `pixel_noise_px`.
    pub fn draw(setup: &CameraSetup, seed: u64, pixel_noise_px: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(PLACEMENT_STREAM);
        let mut off = |frame: &Frame<f64>, xyz_sigma: f64, rpy_sigma: f64| {
            let mut normal = || rng.sample::<f64, _>(StandardNormal);
            Frame {
                xyz: frame.xyz.map(|v| v + xyz_sigma * normal()),
                rpy: frame.rpy.map(|v| v + rpy_sigma * normal()),
            }
        };
        // What stands in the world is told to centimetres, what sits on
        // the flange to millimetres.
        let (camera, board_pose) = match setup.mount {
            Mount::EyeToHand => {
                let camera = off(&setup.camera, CAMERA_XYZ_SIGMA_M, CAMERA_RPY_SIGMA_RAD);
                (
                    camera,
                    off(&setup.board_pose, BOARD_XYZ_SIGMA_M, BOARD_RPY_SIGMA_RAD),
                )
            }
            Mount::EyeInHand => {
                let camera = off(&setup.camera, BOARD_XYZ_SIGMA_M, BOARD_RPY_SIGMA_RAD);
                (
                    camera,
                    off(&setup.board_pose, CAMERA_XYZ_SIGMA_M, CAMERA_RPY_SIGMA_RAD),
                )
            }
        };
        Self {
            intrinsics: setup.intrinsics.clone(),
            board: setup.board.clone(),
            limits: ViewLimits::default(),
            mount: setup.mount,
            camera,
            board_pose,
            pixel_noise_px,
            seed,
        }
    }

    /// The webcam exactly where `setup` tells it, without noise: what a
    /// calibration starts from.
    pub fn as_told(setup: &CameraSetup) -> Self {
        Self {
            intrinsics: setup.intrinsics.clone(),
            board: setup.board.clone(),
            limits: ViewLimits::default(),
            mount: setup.mount,
            camera: setup.camera,
            board_pose: setup.board_pose,
            pixel_noise_px: 0.0,
            seed: 0,
        }
    }

    /// The board's corners in the image, without noise, with the arm's last
    /// frame at `flange` in the world; `None` when the camera does not see
    /// the whole board facing it.
    pub fn corners(&self, flange: &IsometryMatrix3<f64>) -> Option<Vec<TagCorners>> {
        visibility::check(
            &self.intrinsics,
            &self.board,
            &self.camera_from_board(flange),
            &self.limits,
        )
        .ok()?;
        self.project_board(flange)
    }

    /// Where every corner of the board projects with the arm's last frame
    /// at `flange`, seen or not; `None` if one does not project (behind
    /// the camera, past its lens's field).
    pub fn project_board(&self, flange: &IsometryMatrix3<f64>) -> Option<Vec<TagCorners>> {
        let camera_from_board = self.camera_from_board(flange);
        self.board
            .tags()
            .map(|(id, corners)| {
                let mut corners_px = [[0.0; 2]; 4];
                for (px, corner) in corners_px.iter_mut().zip(corners) {
                    let p: Point2<f64> = self.intrinsics.project(&(camera_from_board * corner))?;
                    *px = [p.x, p.y];
                }
                Some(TagCorners { id, corners_px })
            })
            .collect()
    }

    /// The image the webcam takes of the board, grey, with the arm's last
    /// frame at `flange` in the world, looking as `look` says; its light
    /// and noise drawn from the webcam's seed and `index` (the view's place
    /// in the session), so images can be taken in any order, or at once.
    pub fn image(&self, index: u32, flange: &IsometryMatrix3<f64>, look: &Look) -> Vec<u8> {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(IMAGE_STREAMS + u64::from(index));
        render(
            &self.intrinsics,
            &self.board,
            &self.camera_from_board(flange),
            look,
            &mut rng,
        )
    }

    /// The board's pose in the camera frame with the arm's last frame at `flange`.
    fn camera_from_board(&self, flange: &IsometryMatrix3<f64>) -> IsometryMatrix3<f64> {
        self.mount
            .camera_from_board(&self.camera, &self.board_pose, flange)
    }
}

impl TrueArm {
    /// What `webcam` sees of the board on the true arm, the passes visited
    /// in order from home ([`TrueArm::simulate_passes`]'s effects: servo
    /// error, play, springs).
    ///
    /// The poses the camera does not see the board at are left out before
    /// the arm moves, as a camera session measures only the poses planned
    /// for it: the rest are visited in order, so the views' order is the
    /// visiting order the file says. Whether a pose is seen is judged with
    /// the play it then has; one the play turns out of view is left out too
    /// (counted as unseen).
    pub fn watch(&self, webcam: &Webcam, passes: &[Pass<'_>]) -> Result<Watched, SimError> {
        let all: Vec<_> = passes
            .iter()
            .flat_map(|p| p.poses.iter().map(move |pose| (p.load_kg, *pose)))
            .collect();
        let ways = approaches(all.iter().map(|(_, pose)| &pose.q));
        let mut seen = Vec::new();
        for ((load_kg, pose), approach) in all.iter().zip(ways) {
            if webcam
                .corners(&self.flange(pose, *load_kg, &approach)?)
                .is_some()
            {
                seen.push((*load_kg, *pose));
            }
        }
        let ways = approaches(seen.iter().map(|(_, pose)| &pose.q));
        let mut rng = ChaCha8Rng::seed_from_u64(webcam.seed);
        rng.set_stream(PIXEL_NOISE_STREAM);
        let (mut views, mut noise_free, mut flanges) = (Vec::new(), Vec::new(), Vec::new());
        for ((load_kg, pose), approach) in seen.iter().zip(ways) {
            let flange = self.flange(pose, *load_kg, &approach)?;
            let Some(tags) = webcam.corners(&flange) else {
                continue;
            };
            flanges.push(flange);
            let noisy = tags
                .iter()
                .map(|t| TagCorners {
                    id: t.id,
                    corners_px: t.corners_px.map(|px| {
                        px.map(|v| v + webcam.pixel_noise_px * rng.sample::<f64, _>(StandardNormal))
                    }),
                })
                .collect();
            let mut view = View::new(*pose, *load_kg, None, tags);
            view.approach = approach;
            noise_free.push(view.clone());
            views.push(View {
                tags: noisy,
                ..view
            });
        }
        Ok(Watched {
            unseen: all.len() - views.len(),
            views,
            noise_free,
            flanges,
        })
    }

    /// The true arm's last frame in the world at `pose` under `load_kg`,
    /// arrived the way `approach` says.
    fn flange(
        &self,
        pose: &lrmcal_core::dataset::Pose,
        load_kg: f64,
        approach: &[model::backlash::Approach],
    ) -> Result<IsometryMatrix3<f64>, SimError> {
        let driven = self.driven_angles(&pose.q, approach);
        let deflection = self
            .deflection(&driven, load_kg)
            .map_err(|reason| SimError::Model {
                pose: pose.id,
                load_kg,
                reason,
            })?;
        Ok(deflection.frames.frames.last_value())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::SimConfig;
    use crate::sim::test_support::bundled_arm;
    use lrmcal_core::camera::setup;
    use lrmcal_core::dataset::Pose;

    fn setup() -> CameraSetup {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../core/arms/lrm-webcam/setup.toml");
        setup::read(&path).unwrap()
    }

    /// The planner's poses whose board the setup's camera sees (the grid and
    /// 100 random ones).
    fn poses(setup: &CameraSetup) -> Vec<Pose> {
        let loaded = lrmcal_core::io::arm_source::ArmSource::Bundled("lrm")
            .load()
            .unwrap();
        let config = crate::plan::PlanConfig {
            camera: Some(setup.clone()),
            random: 100,
            ..crate::plan::PlanConfig::for_loaded(&loaded).unwrap()
        };
        crate::plan::candidates(&loaded.arm, &config).unwrap().kept
    }

    /// The webcam stands off its setup by the drawn errors, sees some poses
    /// and not others, and its noise-free corners are the projections of
    /// the board at the true flange: the noisy ones scatter about them by
    /// the configured sigma.
    #[test]
    fn the_webcam_sees_the_true_board_through_its_lens() {
        let setup = setup();
        let webcam = Webcam::draw(&setup, 3, 0.3);
        assert_ne!(webcam.camera, setup.camera);
        let shift = (nalgebra::Vector3::from(webcam.camera.xyz)
            - nalgebra::Vector3::from(setup.camera.xyz))
        .norm();
        assert!(shift < 6.0 * CAMERA_XYZ_SIGMA_M, "{shift}");

        let arm = TrueArm::draw(&bundled_arm(), 3, &SimConfig::default()).unwrap();
        let poses = poses(&setup);
        let passes = [Pass {
            load_kg: 0.0,
            poses: &poses,
        }];
        let watched = arm.watch(&webcam, &passes).unwrap();
        assert!(
            !watched.views.is_empty() && watched.unseen > 0,
            "{}",
            watched.unseen
        );
        assert_eq!(watched.views.len() + watched.unseen, poses.len());

        let tags = webcam.board.tag_count() as usize;
        let mut sum_sq = 0.0;
        let mut count = 0.0;
        for (noisy, exact) in watched.views.iter().zip(&watched.noise_free) {
            assert_eq!(noisy.tags.len(), tags);
            assert_eq!(noisy.approach, exact.approach);
            let flange = arm
                .flange(&exact.pose, exact.load_kg, &exact.approach)
                .unwrap();
            assert_eq!(webcam.corners(&flange).unwrap(), exact.tags);
            for (a, b) in noisy.tags.iter().zip(&exact.tags) {
                for (p, q) in a.corners_px.iter().zip(&b.corners_px) {
                    sum_sq += (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2);
                    count += 2.0;
                }
            }
        }
        let sigma = (sum_sq / count).sqrt();
        assert!((sigma - 0.3).abs() < 0.03, "{sigma}");
    }
}
