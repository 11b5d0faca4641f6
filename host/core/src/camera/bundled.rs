//! The bundled arm's webcam setup: a 1280 × 720 webcam with a little barrel
//! distortion 0.8 m in front of the arm, looking back at it, and a 4 × 3
//! board of 25 mm tag36h11 tags on the flange. `lrmcal demo --camera` writes
//! these files into its folder and works from them, as a user would from
//! their own.

use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::io::atomic;

/// The setup file's name among [`FILES`].
pub const SETUP_FILE: &str = "setup.toml";

/// The setup's files by name: the setup, the intrinsics and the board it names.
pub const FILES: [(&str, &str); 3] = [
    (SETUP_FILE, include_str!("../../arms/lrm-webcam/setup.toml")),
    (
        "camera_info.yaml",
        include_str!("../../arms/lrm-webcam/camera_info.yaml"),
    ),
    (
        "board.yaml",
        include_str!("../../arms/lrm-webcam/board.yaml"),
    ),
];

/// Writes the setup's files into `folder` (which must exist); returns the
/// setup file's path.
pub fn write(folder: &Path) -> Result<PathBuf, Error> {
    for (name, text) in FILES {
        atomic::write(&folder.join(name), |w| w.write_all(text.as_bytes()))?;
    }
    Ok(folder.join(SETUP_FILE))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The written files read back as a setup: the bundled webcam and board.
    #[test]
    fn the_written_setup_reads_back() {
        let folder = tempfile::tempdir().unwrap();
        let setup = super::super::setup::read(&write(folder.path()).unwrap()).unwrap();
        assert_eq!(
            (setup.intrinsics.width_px, setup.intrinsics.height_px),
            (1280, 720)
        );
        assert_eq!(setup.board.tag_count(), 12);
    }
}
