//! `measure --capture`: a webcam instead of a tracker. At each pose, once
//! the arm stands, the user's capture command grabs an image into the
//! images folder (the frame source: `ffmpeg` or `fswebcam` reading the
//! webcam, or any command that writes an image); with `--board` the image
//! is searched for the board's tags at once and taken again, up to
//! [`TRIES`] times, while fewer than half of them are found (a blurred or
//! badly lit frame). After every pose the pose list naming the images
//! (`load_kg` and `image` columns, what `detect --poses` reads) is written
//! whole, so an interrupted run resumes where it stopped.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::mover::Mover;
use crate::error::Error;
use crate::progress::Meter;
use lrmcal_core::camera::AprilGrid;
use lrmcal_core::camera::shots::{self, Shot};
use lrmcal_core::dataset::Pose;
use lrmcal_engine::camera::detect::TagDetector;
use model::{JointKind, PerJoint};

/// Images taken at a pose before the last is kept as it is.
pub const TRIES: usize = 3;

/// What `{image}` in the capture command stands for.
const IMAGE: &str = "{image}";

/// How images are taken and checked.
pub(super) struct Capture {
    /// The shell command, `{image}` (and `{pose}`, `{load_kg}`) in it.
    pub command: String,
    /// Where the images go.
    pub folder: PathBuf,
    /// The board whose tags each image must show, and the detector.
    pub board: Option<(AprilGrid, TagDetector)>,
}

/// Takes an image at each of `poses` not yet in the pose list `out`,
/// brought there by `mover`; writes the list after every pose.
pub(super) fn run(
    capture: &mut Capture,
    poses: &[(Pose, f64)],
    units: PerJoint<JointKind>,
    out: &Path,
    mover: &mut Mover,
    settle_ms: u64,
) -> Result<(), Error> {
    if !capture.command.contains(IMAGE) {
        return Err(Error::Usage(format!(
            "--capture `{}`: the command must write the image to `{IMAGE}` (the file measure names)",
            capture.command
        )));
    }
    std::fs::create_dir_all(&capture.folder).map_err(|source| lrmcal_core::Error::Write {
        path: capture.folder.clone(),
        source,
    })?;
    let mut taken = if out.exists() {
        shots::read(out)?
    } else {
        Vec::new()
    };
    let bar = Meter::new("taking images", poses.len() as u64, "poses");
    for &(pose, load_kg) in poses {
        if taken
            .iter()
            .any(|s| s.pose.id == pose.id && s.load_kg == load_kg)
        {
            bar.inc(1);
            continue;
        }
        bar.set_label(&format!("pose {}", pose.id));
        mover.arrive(pose, load_kg, settle_ms, true, &bar)?;
        let name = format!("pose{}-{load_kg}kg.png", pose.id);
        let path = capture.folder.join(&name);
        for attempt in 1..=TRIES {
            take(&capture.command, &path, pose.id, load_kg)?;
            let Some(found) = capture.tags_found(&path)? else {
                break;
            };
            let wanted = capture
                .board
                .as_ref()
                .map_or(0, |(b, _)| b.tag_count() as usize);
            if 2 * found >= wanted {
                break;
            }
            bar.println(&format!(
                "pose {}: {found} of the board's {wanted} tags in {} (try {attempt} of {TRIES}){}",
                pose.id,
                path.display(),
                if attempt < TRIES {
                    ", taking it again"
                } else {
                    ", kept: check the focus and the light"
                }
            ));
            std::thread::sleep(std::time::Duration::from_millis(settle_ms));
        }
        taken.push(Shot {
            line: 0,
            pose,
            load_kg,
            image: name,
            units,
        });
        shots::write(out, &taken, &units)?;
        bar.inc(1);
    }
    bar.finish();
    println!(
        "{} images named in {} (find their tags with `lrmcal detect --images {} --board BOARD --poses {}`)",
        taken.len(),
        out.display(),
        capture.folder.display(),
        out.display()
    );
    Ok(())
}

impl Capture {
    /// How many of the board's tags the image at `path` shows; `None`
    /// without a board to look for.
    fn tags_found(&mut self, path: &Path) -> Result<Option<usize>, Error> {
        let Some((board, detector)) = &mut self.board else {
            return Ok(None);
        };
        let unreadable = |reason: String| Error::Image {
            path: path.to_owned(),
            reason,
        };
        let grey = image::io::Reader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| unreadable(e.to_string()))?
            .decode()
            .map_err(|e| unreadable(e.to_string()))?
            .into_luma8();
        let found = detector
            .detect_image(&grey, board)
            .map_err(|e| unreadable(e.to_string()))?;
        Ok(Some(found.tags.len()))
    }
}

/// Runs the capture `command` for the image `path` of `pose` under
/// `load_kg`; refuses a command that fails or writes no file.
fn take(command: &str, path: &Path, pose: u32, load_kg: f64) -> Result<(), Error> {
    let line = command
        .replace(IMAGE, &path.display().to_string())
        .replace("{pose}", &pose.to_string())
        .replace("{load_kg}", &load_kg.to_string());
    let _ = std::fs::remove_file(path);
    let status = shell(&line).status().map_err(|e| Error::DeviceInput {
        what: format!("take the image of pose {pose}"),
        reason: format!("`{line}` did not start: {e}"),
    })?;
    if !status.success() || !path.is_file() {
        return Err(Error::DeviceInput {
            what: format!("take the image of pose {pose}"),
            reason: format!(
                "`{line}` {}",
                if status.success() {
                    format!("wrote no {}", path.display())
                } else {
                    format!("failed ({status})")
                }
            ),
        });
    }
    Ok(())
}

/// The platform's shell running `line`.
fn shell(line: &str) -> Command {
    if cfg!(windows) {
        let mut c = Command::new("cmd");
        c.args(["/C", line]);
        c
    } else {
        let mut c = Command::new("sh");
        c.args(["-c", line]);
        c
    }
}
