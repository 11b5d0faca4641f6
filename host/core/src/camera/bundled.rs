//! The bundled arm's webcam setups: a 1280 × 720 webcam with a little
//! barrel distortion 0.8 m in front of the arm, looking back at it, and a
//! 4 × 3 board of 25 mm tag36h11 tags on the flange; or the same webcam on
//! the flange and the board standing before the arm (eye-in-hand).
//! `lrmcal demo --camera` writes these files into its folder and works
//! from them, as a user would from their own.

use std::path::{Path, PathBuf};

use super::Mount;
use crate::error::Error;
use crate::io::atomic;

/// The setup file's name among [`FILES`].
pub const SETUP_FILE: &str = "setup.toml";

/// The eye-in-hand setup file's name among [`FILES`].
pub const EYE_IN_HAND_FILE: &str = "setup-eye-in-hand.toml";

/// The setups' files by name: the two setups, the intrinsics and the board
/// they name.
pub const FILES: [(&str, &str); 4] = [
    (SETUP_FILE, include_str!("../../arms/lrm-webcam/setup.toml")),
    (
        EYE_IN_HAND_FILE,
        include_str!("../../arms/lrm-webcam/setup-eye-in-hand.toml"),
    ),
    (
        "camera_info.yaml",
        include_str!("../../arms/lrm-webcam/camera_info.yaml"),
    ),
    (
        "board.yaml",
        include_str!("../../arms/lrm-webcam/board.yaml"),
    ),
];

/// Writes the setups' files into `folder` (which must exist); returns the
/// path of the setup file of `mount`.
pub fn write(folder: &Path, mount: Mount) -> Result<PathBuf, Error> {
    for (name, text) in FILES {
        atomic::write(&folder.join(name), |w| w.write_all(text.as_bytes()))?;
    }
    Ok(folder.join(match mount {
        Mount::EyeToHand => SETUP_FILE,
        Mount::EyeInHand => EYE_IN_HAND_FILE,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The written files read back as a setup: the bundled webcam and board.
    #[test]
    fn the_written_setup_reads_back() {
        let folder = tempfile::tempdir().unwrap();
        for mount in [Mount::EyeToHand, Mount::EyeInHand] {
            let setup = super::super::setup::read(&write(folder.path(), mount).unwrap()).unwrap();
            assert_eq!(
                (setup.intrinsics.width_px, setup.intrinsics.height_px),
                (1280, 720)
            );
            assert_eq!(setup.board.tag_count(), 12);
            assert_eq!(setup.mount, mount);
        }
    }
}
