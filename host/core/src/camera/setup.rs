//! The camera setup file (TOML): which intrinsics and board, how the camera
//! is mounted, and where the camera and the board are, each pose told
//! roughly: eye-to-hand, the camera stands in the arm's world frame and the
//! board sits on the arm's last frame (the flange); eye-in-hand, the camera
//! sits on the flange and the board lies in the world.
//!
//! Poses are written like the arm file's `[base]`: `Trans(xyz) · Rz(yaw) ·
//! Ry(pitch) · Rx(roll)`, here in mm and degrees (`model::Frame`'s
//! convention). Paths are relative to the setup file's folder.

use std::path::Path;

use model::Frame;
use nalgebra::IsometryMatrix3;
use serde::Deserialize;

use super::visibility::{self, Unseen, ViewLimits};
use super::{AprilGrid, Intrinsics, board, intrinsics_file};
use crate::error::{Error, InputError, Location, Problem};
use crate::io::arm_toml::{LineIndex, toml_error};
use crate::io::read_text;

/// How the camera and the board are carried.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mount {
    /// The camera stands still in the world; the arm carries the board.
    EyeToHand,
    /// The arm carries the camera; the board lies still in the world.
    EyeInHand,
}

impl Mount {
    /// The board's pose in the camera frame when the arm's last frame
    /// stands at `flange` in the world, the camera at `camera` and the
    /// board at `board` (each in the world or on the flange, as mounted).
    pub fn camera_from_board(
        self,
        camera: &Frame<f64>,
        board: &Frame<f64>,
        flange: &IsometryMatrix3<f64>,
    ) -> IsometryMatrix3<f64> {
        match self {
            Self::EyeToHand => camera.isometry().inverse() * flange * board.isometry(),
            Self::EyeInHand => (flange * camera.isometry()).inverse() * board.isometry(),
        }
    }
}

/// A camera setup, read and checked: the camera, the board and their poses.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraSetup {
    /// The camera's intrinsics.
    pub intrinsics: Intrinsics,
    /// The board the arm carries.
    pub board: AprilGrid,
    /// How they are carried.
    pub mount: Mount,
    /// The camera frame, m and rad: eye-to-hand in the arm's world frame
    /// (the frame the arm file's `[base]` is given in), eye-in-hand in the
    /// arm's last frame (frame n of its DH chain, the flange, the frame its
    /// `[tool]` is given in).
    pub camera: Frame<f64>,
    /// The board frame, m and rad: eye-to-hand in the arm's last frame,
    /// eye-in-hand in the arm's world frame.
    pub board_pose: Frame<f64>,
    /// How far from the image's edges and how obliquely the board may be
    /// seen at a planned pose ([`ViewLimits::PLANNING`] as read: room for the
    /// camera and the board standing off where the setup says).
    pub limits: ViewLimits,
}

impl CameraSetup {
    /// Whether the camera sees the board when the arm's last frame stands at
    /// `flange` in the world (see [`visibility::check`]).
    pub fn sees_board(&self, flange: &IsometryMatrix3<f64>) -> Result<(), Unseen> {
        let camera_from_board =
            self.mount
                .camera_from_board(&self.camera, &self.board_pose, flange);
        visibility::check(
            &self.intrinsics,
            &self.board,
            &camera_from_board,
            &self.limits,
        )
    }
}

/// The file's keys. The board's file is `board_file`, not `board`: TOML
/// cannot hold both a `board` key and the `[board]` table of its pose.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSetup {
    intrinsics: String,
    board_file: String,
    mount: String,
    camera: RawPose,
    board: RawPose,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPose {
    xyz_mm: [f64; 3],
    rpy_deg: [f64; 3],
}

impl RawPose {
    fn frame(&self, key: &str) -> Result<Frame<f64>, InputError> {
        let finite = |field: &str, v: [f64; 3]| match v.iter().find(|x| !x.is_finite()) {
            Some(x) => Err(InputError::new(
                Location::key(None, format!("{key}.{field}")),
                Problem::NotFinite {
                    found: x.to_string(),
                },
            )),
            None => Ok(v),
        };
        Ok(Frame {
            xyz: finite("xyz_mm", self.xyz_mm)?.map(|v| v * 1e-3),
            rpy: finite("rpy_deg", self.rpy_deg)?.map(f64::to_radians),
        })
    }
}

/// The setup file as written, before its two files are read.
#[derive(Clone, Debug, PartialEq)]
pub struct SetupFile {
    /// The intrinsics file, as written (relative to the setup file's folder).
    pub intrinsics: String,
    /// The board file, likewise.
    pub board: String,
    /// How the camera and the board are carried.
    pub mount: Mount,
    /// See [`CameraSetup::camera`].
    pub camera: Frame<f64>,
    /// See [`CameraSetup::board_pose`].
    pub board_pose: Frame<f64>,
}

/// Parses and checks the text of a camera setup file (its two files unread).
pub fn parse(text: &str) -> Result<SetupFile, InputError> {
    let lines = LineIndex::new(text);
    let deserializer = toml::Deserializer::parse(text).map_err(|e| toml_error(&lines, e, None))?;
    let raw: RawSetup = serde_path_to_error::deserialize(deserializer).map_err(|e| {
        let path = crate::io::key_path(e.path());
        toml_error(&lines, e.into_inner(), Some(path))
    })?;
    let mount = match raw.mount.as_str() {
        "eye-to-hand" => Mount::EyeToHand,
        "eye-in-hand" => Mount::EyeInHand,
        other => {
            return Err(InputError::new(
                Location::key(None, "mount"),
                Problem::Invalid {
                    message: format!(
                        "expected \"eye-to-hand\" (the camera still, the arm carrying the \
                         board) or \"eye-in-hand\" (the arm carrying the camera), found \"{other}\""
                    ),
                },
            ));
        }
    };
    Ok(SetupFile {
        intrinsics: raw.intrinsics,
        board: raw.board_file,
        mount,
        camera: raw.camera.frame("camera")?,
        board_pose: raw.board.frame("board")?,
    })
}

/// Reads a camera setup file and the intrinsics and board files it names
/// (relative to its folder); every error names its file and key.
pub fn read(path: &Path) -> Result<CameraSetup, Error> {
    let text = read_text(path)?;
    let file = parse(&text).map_err(|e| e.in_file(path))?;
    let folder = path.parent().unwrap_or(Path::new(""));
    Ok(CameraSetup {
        intrinsics: intrinsics_file::read(&folder.join(&file.intrinsics))?,
        board: board::read(&folder.join(&file.board))?,
        mount: file.mount,
        camera: file.camera,
        board_pose: file.board_pose,
        limits: ViewLimits::PLANNING,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SETUP: &str = r#"
intrinsics = "camera_info.yaml"
board_file = "board.yaml"
mount = "eye-to-hand"

[camera]
xyz_mm = [900.0, 0.0, 300.0]
rpy_deg = [-90.0, 0.0, 90.0]

[board]
xyz_mm = [0.0, 0.0, 10.0]
rpy_deg = [0.0, 0.0, 180.0]
"#;

    #[test]
    fn a_setup_reads_in_metres_and_radians() {
        let file = parse(SETUP).unwrap();
        assert_eq!(file.intrinsics, "camera_info.yaml");
        assert_eq!(file.board, "board.yaml");
        assert_eq!(file.camera.xyz, [0.9, 0.0, 0.3]);
        assert_eq!(file.camera.rpy[0], -std::f64::consts::FRAC_PI_2);
        assert_eq!(file.board_pose.xyz, [0.0, 0.0, 0.01]);
    }

    /// The same board seen from a camera standing still and from one the
    /// arm carries: each mount's geometry puts it where the other does
    /// when the poses describe one scene.
    #[test]
    fn both_mounts_see_one_scene_alike() {
        let file = parse(&SETUP.replace("\"eye-to-hand\"", "\"eye-in-hand\"")).unwrap();
        assert_eq!(file.mount, Mount::EyeInHand);
        let flange = Frame {
            xyz: [0.3, -0.1, 0.4],
            rpy: [0.2, -0.4, 1.1],
        }
        .isometry();
        let (camera, board) = (file.camera, file.board_pose);
        let seen = Mount::EyeInHand.camera_from_board(&camera, &board, &flange);
        // The scene written eye-to-hand: the camera in the world where the
        // flange carries it, the board on the flange where the world has it.
        let camera_in_world = flange * camera.isometry();
        let board_on_flange = flange.inverse() * board.isometry();
        let frame = |iso: IsometryMatrix3<f64>| {
            let (r, p, y) = iso.rotation.euler_angles();
            Frame {
                xyz: iso.translation.vector.into(),
                rpy: [r, p, y],
            }
        };
        let same = Mount::EyeToHand.camera_from_board(
            &frame(camera_in_world),
            &frame(board_on_flange),
            &flange,
        );
        assert!((seen.translation.vector - same.translation.vector).norm() < 1e-12);
        assert!((seen.rotation.matrix() - same.rotation.matrix()).norm() < 1e-12);
    }

    #[test]
    fn a_bad_setup_names_the_key() {
        let e = parse(&SETUP.replace("\"eye-to-hand\"", "\"tripod\""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("mount") && e.contains("tripod"), "{e}");
        let e = parse(&SETUP.replace("rpy_deg = [0.0, 0.0, 180.0]\n", ""))
            .unwrap_err()
            .to_string();
        assert!(e.contains("board") && e.contains("rpy_deg"), "{e}");
        let e = parse(&SETUP.replace("board_file", "board_path"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("board_path"), "{e}");
    }
}
