//! The camera as the instrument: what it is, what it looks at, and whether it
//! sees it.
//!
//! ```text
//! camera_info / FileStorage YAML --intrinsics_file::read--> Intrinsics (pixels of camera-frame points)
//! Kalibr aprilgrid YAML --board::read--> AprilGrid (tag corners in the board frame)
//! camera setup TOML --setup::read--> CameraSetup (both, and where the camera and the board are)
//! calibrated Intrinsics --intrinsics_file::to_camera_info--> camera_info YAML (for ROS)
//! Intrinsics + AprilGrid + board pose in the camera frame --visibility::check--> seen, or why not
//! tags found in images --corners::write--> detected corners CSV
//! tags seen at each commanded pose and load <--views::read/write--> camera measurement CSV
//! pose list naming each pose's image --shots::read--> the images to turn into views
//! ```
//!
//! | module | what it holds |
//! |---|---|
//! | [`intrinsics`] | the pinhole camera with OpenCV's radial-tangential distortion, and its projection |
//! | [`intrinsics_file`] | the intrinsics files read (ROS `camera_info`, OpenCV FileStorage) |
//! | [`board`] | the AprilTag grid the arm carries, its frame and corner order, and its file (Kalibr's `aprilgrid`) |
//! | [`visibility`] | whether the camera sees the whole board, facing it |
//! | [`corners`] | the board's tag corners found in images, and their CSV file |
//! | [`views`] | the tags seen at each commanded pose and load (a camera's measurements), and their CSV file |
//! | [`shots`] | the images taken at a pose list's poses, each under its load |
//! | [`static_transform`] | the camera's pose for ROS: `static_transform_publisher`'s arguments and a launch file |
//! | [`setup`] | the camera setup file: the files above and the two poses that place them |
//! | [`bundled`] | the bundled arm's webcam setup, for the demo |
//! | `yaml` | the YAML reading the files above share |
//!
//! Conventions (OpenCV's, which ROS shares): the camera frame has x right,
//! y down, z forward along the optical axis, in metres; pixel centres sit at
//! integer coordinates, the top-left pixel's centre at (0, 0).

pub mod board;
pub mod bundled;
pub mod corners;
pub mod intrinsics;
pub mod intrinsics_file;
pub mod setup;
pub mod shots;
pub mod static_transform;
pub mod views;
pub mod visibility;
mod yaml;

pub use board::AprilGrid;
pub use intrinsics::Intrinsics;
pub use setup::{CameraSetup, Mount};
