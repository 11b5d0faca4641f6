//! `measure --capture` and `--webcam`: a webcam instead of a tracker. At
//! each pose, once the arm stands, [`FRAMES`] frames are taken by default:
//! from the webcam read directly (`--webcam`, [`super::webcam`]), or by
//! the user's capture command (`ffmpeg` or `fswebcam` reading the webcam,
//! or any command that writes an image), run once a frame, each into a
//! name of its own beside the pose's image (`pose7-0kg.frame2.png`).
//!
//! An arm that has arrived may still sway: two frames in a row whose pixel
//! blocks' mean grey levels differ by more than [`MOVED_GREY_LEVELS`] say
//! the scene moved, which is printed, and the frames before it are dropped
//! from the choice, so that the frames to choose from held still in a row.
//! Frames are taken until there are as many such as asked for, or
//! [`FRAME_ALLOWANCE`] times as many frames in all (then with a warning).
//! The sharpest of them (the variance of its Laplacian,
//! `lrmcal_engine::camera::focus`) becomes the pose's image
//! (`pose7-0kg.png`: the command's file, or the webcam's frame in grey)
//! and the other frames are deleted, also when a frame fails: no frame
//! file outlives its pose.
//!
//! A kept image far less sharp than this run's others (under
//! [`BLURRED_FRACTION`] of their median, once [`MEDIAN_AFTER`] poses are
//! taken) is kept with a warning naming the pose and the image. With
//! `--board` the kept image is also searched for the board's tags at once,
//! which judges the first poses too, and the pose is taken again, up to
//! [`TRIES`] times, while fewer than half of them are found (a blurred or
//! badly lit frame). After every pose the pose list naming the images
//! (`load_kg` and `image` columns, what `detect --poses` reads) is written
//! whole, so an interrupted run resumes where it stopped.

use std::path::{Path, PathBuf};
use std::process::Command;

use image::GrayImage;

use super::mover::Mover;
use crate::error::Error;
use crate::progress::Meter;
use lrmcal_core::camera::AprilGrid;
use lrmcal_core::camera::shots::{self, Shot};
use lrmcal_core::dataset::Pose;
use lrmcal_engine::calib::results::experiments::median;
use lrmcal_engine::camera::detect::TagDetector;
use lrmcal_engine::camera::focus;
use model::{JointKind, PerJoint};

/// Images taken at a pose before the last is kept as it is.
pub const TRIES: usize = 3;

/// Still frames taken at a pose by default, the sharpest kept: with three,
/// one frame blurred by a shake or a refocusing webcam is passed over, for
/// about three times one frame's time (a webcam opened by `ffmpeg` takes
/// 0.5-1 s a frame).
pub const FRAMES: u32 = 3;

/// Frames a pose may take in all, as a multiple of the still frames asked
/// for: an arm that sways through the first frames gets as many again to
/// settle in, and a scene that never holds still (someone walking through
/// the view) still ends.
const FRAME_ALLOWANCE: usize = 2;

/// The change between two frames in a row (`focus::scene_change`: the
/// absolute difference of 8x8 px blocks' mean grey levels that one block in
/// a thousand exceeds), grey levels, above which the scene moved between
/// them. On the simulated webcam's 1280x720 frames, two frames of the still
/// scene with pixel noise of σ 3 or 6 levels differ by 2 or 4, the frame and
/// itself blurred by 1 px by 5-6, by 1.5 px by 9-13, the light 5 % brighter
/// by 10-12; the board moved by 1 px by 16-22, by 2 px by 30-40. The mean
/// difference over the whole frame would not do: the board fills a
/// fiftieth of it, and the noise alone gives 3.4 or 6.8 where the board
/// moved by 8 px adds 2.
const MOVED_GREY_LEVELS: f64 = 10.0;

/// A kept image whose sharpness is under this fraction of the median of
/// this run's poses is blurred. On the simulated webcam's frames a defocus
/// of 1.5 px halves the sharpness, and a blur of 1 px over the frame (its
/// noise too) takes off two thirds, while three planned poses, the board of
/// much the same size and tilt in each, lie within 0.9-1.6 times their
/// median.
const BLURRED_FRACTION: f64 = 0.5;

/// Poses taken in this run before their median judges the next: three is
/// the fewest whose median one blurred pose cannot drag down. Before, only
/// the board's tags (with `--board`) judge an image.
const MEDIAN_AFTER: usize = 3;

/// What `{image}` in the capture command stands for.
const IMAGE: &str = "{image}";

/// Where the frames come from.
pub(super) enum Source {
    /// The user's shell command that writes one frame into `{image}` (and
    /// `{pose}`, `{load_kg}` in it).
    Command(String),
    /// A webcam read directly, streaming for the whole run.
    #[cfg(target_os = "linux")]
    Webcam(super::webcam::Webcam),
}

/// How images are taken and checked.
pub(super) struct Capture {
    /// Where the frames come from.
    pub source: Source,
    /// Where the images go.
    pub folder: PathBuf,
    /// Still frames taken at a pose, the sharpest kept (at least 1).
    pub frames: u32,
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
    if let Source::Command(command) = &capture.source
        && !command.contains(IMAGE)
    {
        return Err(Error::Usage(format!(
            "--capture `{command}`: the command must write the image to `{IMAGE}` (the file measure names)"
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
    // The kept images' sharpness, of the poses taken in this run.
    let mut sharpness = Vec::new();
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
        let stem = format!("pose{}-{load_kg}kg", pose.id);
        let name = format!("{stem}.png");
        let path = capture.folder.join(&name);
        let mut kept_sharpness = 0.0;
        for attempt in 1..=TRIES {
            let kept = capture.take_still(pose.id, load_kg, &stem, &path, &bar)?;
            kept_sharpness = kept.sharpness;
            let Some(found) = capture.tags_found(&kept.grey, &path)? else {
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
        if sharpness.len() >= MEDIAN_AFTER {
            let median = median(sharpness.clone());
            if kept_sharpness < BLURRED_FRACTION * median {
                bar.println(&format!(
                    "pose {}: {} is blurred: its sharpness (the variance of its Laplacian) is \
                     {kept_sharpness:.0}, under {:.0} % of this run's median, {median:.0}; kept: \
                     check the focus, and that nothing shakes the camera or the arm",
                    pose.id,
                    path.display(),
                    BLURRED_FRACTION * 100.0
                ));
            }
        }
        sharpness.push(kept_sharpness);
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

/// The frame kept as a pose's image.
struct Kept {
    /// Its grey pixels.
    grey: GrayImage,
    /// The variance of its Laplacian, grey levels squared.
    sharpness: f64,
}

impl Kept {
    /// The frame `grey`, its sharpness measured.
    fn of(grey: GrayImage) -> Self {
        Self {
            sharpness: focus::sharpness(&grey),
            grey,
        }
    }
}

/// A pose's frame files, deleted when dropped (the kept one is renamed to
/// the pose's image first), so that none outlives the pose, even when a
/// frame fails.
struct Frames(Vec<PathBuf>);

impl Drop for Frames {
    fn drop(&mut self) {
        for path in &self.0 {
            let _ = std::fs::remove_file(path);
        }
    }
}

impl Capture {
    /// Takes frames of pose `pose` under `load_kg` (a command's into frame
    /// names from `stem`) until `self.frames` in a row held still (or
    /// [`FRAME_ALLOWANCE`] times as many are taken), and keeps the sharpest
    /// of those as the image `path`.
    fn take_still(
        &mut self,
        pose: u32,
        load_kg: f64,
        stem: &str,
        path: &Path,
        bar: &Meter,
    ) -> Result<Kept, Error> {
        let most = self.frames as usize * FRAME_ALLOWANCE;
        let mut files = Frames(Vec::new());
        let mut previous = self.frame(&mut files, 1, pose, load_kg, stem)?;
        let mut taken = 1;
        // The sharpest frame since the scene last moved (by its number from
        // 0), and how many frames have held still since.
        let mut sharpest = (0, Kept::of(previous.clone()));
        let mut still = 1;
        while still < self.frames && taken < most {
            taken += 1;
            let grey = self.frame(&mut files, taken, pose, load_kg, stem)?;
            let index = taken - 1;
            let moved = focus::scene_change(&previous, &grey).ok_or_else(|| Error::Image {
                path: files
                    .0
                    .get(index)
                    .cloned()
                    .unwrap_or_else(|| path.to_owned()),
                reason: format!(
                    "it is {}x{} px, the frame before it {}x{} px",
                    grey.width(),
                    grey.height(),
                    previous.width(),
                    previous.height()
                ),
            })?;
            let kept = Kept::of(grey.clone());
            if moved > MOVED_GREY_LEVELS {
                bar.println(&format!(
                    "pose {pose}: the arm was still moving (frame {taken} differs from the one before \
                     by {moved:.0} grey levels, over {MOVED_GREY_LEVELS}){}",
                    if taken < most {
                        ", taking another frame"
                    } else {
                        ""
                    }
                ));
                still = 1;
                sharpest = (index, kept);
            } else {
                still += 1;
                if kept.sharpness > sharpest.1.sharpness {
                    sharpest = (index, kept);
                }
            }
            previous = grey;
        }
        if still < self.frames {
            bar.println(&format!(
                "pose {pose}: the arm was still moving after {most} frames; kept the sharpest of \
                 the last {still} as {}: let it settle longer (--settle-ms)",
                path.display()
            ));
        }
        let (index, kept) = sharpest;
        let written = match files.0.get(index) {
            Some(file) => std::fs::rename(file, path),
            None => self.write_png(&kept.grey, path),
        };
        written.map_err(|source| lrmcal_core::Error::Write {
            path: path.to_owned(),
            source,
        })?;
        Ok(kept)
    }

    /// Writes `grey` as the PNG image `path`, whole or not at all.
    fn write_png(&self, grey: &GrayImage, path: &Path) -> std::io::Result<()> {
        let mut file = tempfile::Builder::new()
            .suffix(".png")
            .tempfile_in(&self.folder)?;
        grey.write_to(file.as_file_mut(), image::ImageOutputFormat::Png)
            .map_err(std::io::Error::other)?;
        file.persist(path).map(|_| ()).map_err(|e| e.error)
    }

    /// Takes frame `number` (from 1) of pose `pose` under `load_kg`, grey;
    /// a command writes it into the frame name from `stem` and `number`,
    /// counted in `files`.
    fn frame(
        &mut self,
        files: &mut Frames,
        number: usize,
        pose: u32,
        load_kg: f64,
        stem: &str,
    ) -> Result<GrayImage, Error> {
        match &mut self.source {
            Source::Command(command) => {
                let path = self.folder.join(format!("{stem}.frame{number}.png"));
                // Counted before it is taken, so that a half-written frame goes too.
                files.0.push(path.clone());
                take(command, &path, pose, load_kg)?;
                read_grey(&path)
            }
            #[cfg(target_os = "linux")]
            Source::Webcam(webcam) => webcam.grab(),
        }
    }

    /// How many of the board's tags the image `grey` (read from `path`)
    /// shows; `None` without a board to look for.
    fn tags_found(&mut self, grey: &GrayImage, path: &Path) -> Result<Option<usize>, Error> {
        let Some((board, detector)) = &mut self.board else {
            return Ok(None);
        };
        let found = detector
            .detect_image(grey, board)
            .map_err(|e| Error::Image {
                path: path.to_owned(),
                reason: e.to_string(),
            })?;
        Ok(Some(found.tags.len()))
    }
}

/// The image at `path`, turned grey.
fn read_grey(path: &Path) -> Result<GrayImage, Error> {
    let unreadable = |reason: String| Error::Image {
        path: path.to_owned(),
        reason,
    };
    Ok(image::io::Reader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| unreadable(e.to_string()))?
        .decode()
        .map_err(|e| unreadable(e.to_string()))?
        .into_luma8())
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
