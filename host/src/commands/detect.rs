//! `lrmcal detect`: the board's tag corners found in a folder of images by
//! the AprilTag C library, written as a detected-corners CSV.

use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::progress::Meter;
use lrmcal_core::camera::corners::{self, ImageCorners};
use lrmcal_core::camera::{board, intrinsics_file};
use lrmcal_engine::camera::detect::{Grey, TagDetector};

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
Examples:\n  \
lrmcal detect --images shots/ --board board.yaml --out corners.csv\n  \
lrmcal detect --images shots/ --board board.yaml --intrinsics camera_info.yaml --out corners.csv"
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
    /// Where to write the detected corners (CSV).
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
    let files = image_files(&args.images)?;
    let mut detector = TagDetector::new().map_err(|e| Error::Detect {
        reason: e.to_string(),
    })?;
    let bar = Meter::new("detecting tags", files.len() as u64, "images");
    let mut images = Vec::new();
    let mut foreign = 0;
    for (path, name) in &files {
        let grey = image::open(path)
            .map_err(|e| Error::Image {
                path: path.clone(),
                reason: e.to_string(),
            })?
            .into_luma8();
        if let Some((file, camera)) = &intrinsics
            && grey.dimensions() != (camera.width_px, camera.height_px)
        {
            return Err(Error::ImageSize {
                path: path.clone(),
                size: grey.dimensions(),
                intrinsics: file.to_path_buf(),
                expected: (camera.width_px, camera.height_px),
            });
        }
        let found = detector
            .detect(
                Grey {
                    width: grey.width(),
                    height: grey.height(),
                    pixels: grey.as_raw(),
                },
                &board,
            )
            .map_err(|e| Error::Image {
                path: path.clone(),
                reason: e.to_string(),
            })?;
        foreign += found.foreign;
        if found.tags.is_empty() {
            bar.println(&format!("{name}: no tag of the board found"));
        }
        images.push(ImageCorners {
            image: name.clone(),
            tags: found.tags,
        });
        bar.inc(1);
    }
    bar.finish();
    corners::write(&args.out, &images)?;
    if foreign > 0 {
        eprintln!(
            "ignored {foreign} tags whose id is not on the board (or was seen twice in an image)"
        );
    }
    let seen = images.iter().filter(|i| !i.tags.is_empty()).count();
    let tags: usize = images.iter().map(|i| i.tags.len()).sum();
    eprintln!(
        "wrote {tags} tags of the board seen in {seen} of {} images to `{}`",
        images.len(),
        args.out.display()
    );
    Ok(())
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
