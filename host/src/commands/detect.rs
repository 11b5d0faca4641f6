//! `lrmcal detect`: the board's tag corners found in a folder of images by
//! the AprilTag C library, written as a detected-corners CSV, or, with the
//! pose list the images were taken at, as a camera measurement file.

use std::path::{Path, PathBuf};

use crate::error::{Error, InputError, Location, Problem};
use crate::progress::Meter;
use lrmcal_core::camera::board::AprilGrid;
use lrmcal_core::camera::corners::{self, ImageCorners};
use lrmcal_core::camera::intrinsics::Intrinsics;
use lrmcal_core::camera::shots::{self, Shot};
use lrmcal_core::camera::views::{self, View};
use lrmcal_core::camera::{board, intrinsics_file};
use lrmcal_engine::camera::detect::{Found, TagDetector};
use rayon::prelude::*;

/// The file name endings of the images read (case aside).
const IMAGE_EXTENSIONS: [&str; 3] = ["png", "jpg", "jpeg"];

/// Find the board's AprilTag corners in image files and write them as a CSV.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Every .png, .jpg and .jpeg file of --images, in name order, is \
read, turned to grey, and searched for tag36h11 tags by the AprilTag C library. Tags whose id \
is not on the board are ignored (their count is printed on stderr); an image where no tag of \
the board is found is named on stderr and the others are still written. With --intrinsics, an \
image of another size than the intrinsics' is refused (intrinsics belong to one resolution).\n\n\
The output has one row per corner, image,tag,corner,u_px,v_px: the image's file name, the \
tag's id, the corner 0 to 3 in the board's order (top-left, top-right, bottom-right, \
bottom-left of the tag seen upright, as OpenCV's ArUco gives them), and its pixel position \
in OpenCV's convention (the top-left pixel's centre at (0, 0), v down). The board file and \
this CSV are described in docs/FORMATS.md.\n\n\
With --poses, a pose list in the order the poses were visited, with a load_kg column and an \
image column naming the file of --images taken at each pose, only the images it names are \
read, in its order (the folder's others are counted on stderr), and the output is a camera \
measurement file: pose,load_kg,q1_deg..qn_deg,tag,corner,u_px,v_px,image, one row per corner, \
the joint columns the list's. A list without load_kg is refused, and so is an image named \
twice or not in the folder, by its line; a pose whose image shows no tag of the board has no rows.\n\n\
Examples:\n  \
lrmcal detect --images shots/ --board board.yaml --out corners.csv\n  \
lrmcal detect --images shots/ --board board.yaml --intrinsics camera_info.yaml --out corners.csv\n  \
lrmcal detect --images shots/ --board board.yaml --poses shots.csv --out views.csv"
)]
pub struct Args {
    /// The folder of images (.png, .jpg, .jpeg).
    #[arg(long, value_name = "DIR")]
    pub images: PathBuf,
    /// The board: Kalibr's aprilgrid YAML.
    #[arg(long, value_name = "FILE")]
    pub board: PathBuf,
    /// The camera's intrinsics (ROS camera_info or OpenCV YAML): every image
    /// must have their size.
    #[arg(long, value_name = "FILE")]
    pub intrinsics: Option<PathBuf>,
    /// The poses the images were taken at: a pose list with `load_kg` and
    /// an `image` column naming each pose's file in --images; the output is
    /// then a camera measurement file.
    #[arg(long, value_name = "FILE")]
    pub poses: Option<PathBuf>,
    /// Where to write the detected corners, or with --poses the camera
    /// measurements (CSV).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
}

/// Runs `lrmcal detect`.
pub fn run(args: &Args) -> Result<(), Error> {
    let board = board::read(&args.board)?;
    let intrinsics = args
        .intrinsics
        .as_deref()
        .map(|path| intrinsics_file::read(path).map(|i| (path, i)))
        .transpose()?;
    let folder = image_files(&args.images)?;
    let shots = args
        .poses
        .as_deref()
        .map(|list| shots::read(list).map(|s| (list, s)))
        .transpose()?;
    let files = match &shots {
        Some((list, shots)) => {
            let files = listed_files(&args.images, list, shots, &folder)?;
            let unlisted = folder.len() - files.len();
            if unlisted > 0 {
                eprintln!(
                    "{unlisted} images of `{}` not named by `{}` were not read",
                    args.images.display(),
                    list.display()
                );
            }
            files
        }
        None => folder,
    };
    let bar = Meter::new("detecting tags", files.len() as u64, "images");
    let mut seen = Vec::new();
    let mut foreign = 0;
    // Images side by side, each thread with its own detector, a batch at a
    // time so the meter moves; the first failing image in the folder's
    // order is the one named.
    let batch = DETECT_BATCH_PER_THREAD * rayon::current_num_threads();
    for files in files.chunks(batch) {
        let found: Vec<Result<Found, Error>> = files
            .par_iter()
            .with_min_len(DETECT_BATCH_PER_THREAD)
            .map_init(TagDetector::new, |detector, (path, _)| {
                let detector = detector.as_mut().map_err(|e| Error::Detect {
                    reason: e.to_string(),
                })?;
                detect_file(detector, path, &board, intrinsics.as_ref())
            })
            .collect();
        for (found, (_, name)) in found.into_iter().zip(files) {
            let found = found?;
            foreign += found.foreign;
            if found.tags.is_empty() {
                bar.println(&format!("{name}: no tag of the board found"));
            }
            seen.push(found.tags);
            bar.inc(1);
        }
    }
    bar.finish();
    let images = seen.len();
    let seen_in = seen.iter().filter(|tags| !tags.is_empty()).count();
    let tags: usize = seen.iter().map(Vec::len).sum();
    match shots {
        Some((_, shots)) => {
            // Every row of a list has the header's joint columns.
            let kinds = shots.first().map(|s| s.units.to_vec()).unwrap_or_default();
            let views: Vec<View> = shots
                .into_iter()
                .zip(seen)
                .map(|(shot, tags)| View::new(shot.pose, shot.load_kg, Some(shot.image), tags))
                .collect();
            views::write(&args.out, &views, &kinds)?;
        }
        None => {
            let images: Vec<ImageCorners> = files
                .into_iter()
                .zip(seen)
                .map(|((_, image), tags)| ImageCorners { image, tags })
                .collect();
            corners::write(&args.out, &images)?;
        }
    }
    if foreign > 0 {
        eprintln!(
            "ignored {foreign} tags whose id is not on the board (or was seen twice in an image)"
        );
    }
    eprintln!(
        "wrote {tags} tags of the board seen in {seen_in} of {images} images to `{}`",
        args.out.display()
    );
    Ok(())
}

/// Images each thread reads between two moves of the meter, with one
/// detector: a detector made per image cost more than the second core
/// gave (the demo's 112 images in 5.7 s, against 4.1 s with this).
const DETECT_BATCH_PER_THREAD: usize = 16;

/// The board's tags in the image file `path`, turned grey; refused when
/// its size is not the intrinsics'.
fn detect_file(
    detector: &mut TagDetector,
    path: &Path,
    board: &AprilGrid,
    intrinsics: Option<&(&Path, Intrinsics)>,
) -> Result<Found, Error> {
    let grey = image::open(path)
        .map_err(|e| Error::Image {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?
        .into_luma8();
    if let Some((file, camera)) = intrinsics
        && grey.dimensions() != (camera.width_px, camera.height_px)
    {
        return Err(Error::ImageSize {
            path: path.to_path_buf(),
            size: grey.dimensions(),
            intrinsics: file.to_path_buf(),
            expected: (camera.width_px, camera.height_px),
        });
    }
    detector
        .detect_image(&grey, board)
        .map_err(|e| Error::Image {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
}

/// The folder's image file each shot names, in the list's order; a name
/// that is none of them is refused at its line of `list`.
fn listed_files(
    dir: &Path,
    list: &Path,
    shots: &[Shot],
    folder: &[(PathBuf, String)],
) -> Result<Vec<(PathBuf, String)>, Error> {
    shots
        .iter()
        .map(|shot| {
            let file = folder.iter().find(|(_, name)| *name == shot.image);
            file.cloned().ok_or_else(|| {
                let message = format!(
                    "`{}` is not an image ({}) of the folder `{}`",
                    shot.image,
                    IMAGE_EXTENSIONS.map(|e| format!(".{e}")).join(", "),
                    dir.display()
                );
                let at = Location::column(shot.line, views::IMAGE_COLUMN);
                InputError::new(at, Problem::Invalid { message })
                    .in_file(list)
                    .into()
            })
        })
        .collect()
}

/// The image files of `dir` by name, each with its name.
fn image_files(dir: &Path) -> Result<Vec<(PathBuf, String)>, Error> {
    let read_error = |source| lrmcal_core::Error::Read {
        path: dir.to_owned(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(read_error)? {
        let path = entry.map_err(read_error)?.path();
        let is_image = path.extension().and_then(|e| e.to_str()).is_some_and(|e| {
            IMAGE_EXTENSIONS
                .iter()
                .any(|known| e.eq_ignore_ascii_case(known))
        });
        if is_image && path.is_file() {
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            files.push((path, name));
        }
    }
    files.sort_by(|a, b| a.1.cmp(&b.1));
    Ok(files)
}
