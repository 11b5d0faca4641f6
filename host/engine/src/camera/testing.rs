//! The camera the engine's tests share: the webcam and the board of the
//! core's test data (a 1280 × 720 webcam with a little distortion, a 4 × 3
//! board of 25 mm tags), read from their files as a user's would be.

use std::path::{Path, PathBuf};

use lrmcal_core::camera::{AprilGrid, Intrinsics, board, intrinsics_file};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../core/arms/lrm-webcam")
        .join(name)
}

/// The test webcam.
pub(crate) fn webcam() -> Intrinsics {
    intrinsics_file::read(&data("camera_info.yaml")).expect("the test webcam reads")
}

/// The test board.
pub(crate) fn board() -> AprilGrid {
    board::read(&data("board.yaml")).expect("the test board reads")
}
