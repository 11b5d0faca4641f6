//! The board's tag corners in a grey image, found by the AprilTag C library
//! (through the `apriltag` crate) and told in lrmcal's conventions
//! (`lrmcal_core::camera`): each tag's four corners in the board module's
//! order (top-left, top-right, bottom-right, bottom-left as seen upright), in
//! OpenCV's pixel convention (the top-left pixel's centre at (0, 0)).
//!
//! Both conventions were measured on rendered tags whose corners are known
//! (`host/tests/tag_detection.rs`, the board turned by 0°, 90°, 180° and seen
//! tilted): the C library (3.2) gives the corners from the upright tag's
//! bottom-left, counter-clockwise as seen upright (bottom-left, bottom-right,
//! top-right, top-left), and its pixel centres at (0.5, 0.5): shifted by
//! -0.5 px, the corners of a tilted board average within 0.02 px of the
//! truth, and no corner is off by more than 0.3 px.

use apriltag::detector::QuadThresholds;
use apriltag::{Detector, DetectorBuilder, Family, Image};
use lrmcal_core::camera::AprilGrid;
use lrmcal_core::camera::corners::TagCorners;
use measurements::Angle;
use noisy_float::prelude::r32;

/// For each corner of the board's order, the C library's corner that is it.
const FROM_LIBRARY: [usize; 4] = [3, 2, 1, 0];

/// What the C library adds to an OpenCV pixel coordinate.
const LIBRARY_PIXEL_OFFSET: f64 = 0.5;

/// A grey image, one byte a pixel, row by row from the top-left.
#[derive(Clone, Copy, Debug)]
pub struct Grey<'a> {
    /// Pixels in a row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width · height` bytes.
    pub pixels: &'a [u8],
}

/// What one image holds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Found {
    /// The board's tags seen, by id.
    pub tags: Vec<TagCorners>,
    /// Tags found whose id is not on the board (or seen twice: the second).
    pub foreign: usize,
}

/// Why tags could not be looked for.
#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    /// The C library could not make its detector or its image.
    #[error("the AprilTag library: {0}")]
    Library(String),
    /// The pixels do not fill the image's size.
    #[error("{found} bytes of pixels for a {width}x{height} image")]
    Pixels {
        /// Pixels in a row.
        width: u32,
        /// Rows.
        height: u32,
        /// Bytes given.
        found: usize,
    },
}

/// The AprilTag detector for tag36h11, set up for corner accuracy.
pub struct TagDetector(Detector);

/// Least grey-level difference between the brightest and darkest pixel of
/// a 4×4 tile for the tile to be looked at for a tag's edge (the
/// library's `min_white_black_diff`, 5 by default). At 5 a webcam's own
/// noise of a few grey levels makes the quad search follow thousands of
/// edges in flat parts of the image: on the 112 images of `lrmcal demo
/// --camera`, `detect` took 4.6 s at 5 and 0.95 s at 10, and found the same
/// corners to the last digit, also with every image dimmed to 12 % of its
/// brightness (its brightest pixel 29 grey levels) and 2 grey levels of
/// noise added.
const MIN_WHITE_BLACK_DIFF: u8 = 10;

/// The library's quad thresholds, its defaults but for
/// [`MIN_WHITE_BLACK_DIFF`].
fn quad_thresholds() -> QuadThresholds {
    let critical = 10f64.to_radians();
    QuadThresholds {
        min_cluster_pixels: 5,
        max_maxima_number: 10,
        min_angle: Angle::from_radians(critical),
        // The wrapper passes this field on as the library's
        // `cos_critical_rad` unchanged: the cosine of the critical angle.
        min_opposite_angle: Angle::from_radians(critical.cos()),
        max_mse: r32(10.0),
        min_white_black_diff: MIN_WHITE_BLACK_DIFF,
        deglitch: false,
    }
}

impl TagDetector {
    /// A detector of tag36h11 tags correcting up to 2 bits: quads looked
    /// for at 1/1.5 of the resolution, their edges then refined on the full
    /// image. On 200 webcam images `lrmcal simulate --images` rendered (the
    /// board 0.6-1 m away, up to 60° oblique) this found 97 % of the tags,
    /// against 87 % at half resolution (the library's default) and 99.9 % at
    /// full, in a third of full resolution's time; the corners' median error
    /// was 0.075 px at each.
    pub fn new() -> Result<Self, DetectError> {
        let mut detector = DetectorBuilder::new()
            .add_family_bits(Family::tag_36h11(), 2)
            .build()
            .map_err(|e| DetectError::Library(e.to_string()))?;
        detector.set_decimation(1.5);
        detector.set_refine_edges(true);
        detector.set_thresholds(quad_thresholds());
        Ok(Self(detector))
    }

    /// [`TagDetector::detect`] on an image read from a file, turned grey.
    pub fn detect_image(
        &mut self,
        image: &image::GrayImage,
        board: &AprilGrid,
    ) -> Result<Found, DetectError> {
        self.detect(
            Grey {
                width: image.width(),
                height: image.height(),
                pixels: image.as_raw(),
            },
            board,
        )
    }

    /// The tags of `board` in `image`, by id, and how many others were seen.
    pub fn detect(&mut self, image: Grey<'_>, board: &AprilGrid) -> Result<Found, DetectError> {
        let (width, height) = (image.width as usize, image.height as usize);
        if image.pixels.len() != width * height {
            return Err(DetectError::Pixels {
                width: image.width,
                height: image.height,
                found: image.pixels.len(),
            });
        }
        let mut buffer = Image::zeros_with_stride(width, height, width.max(1))
            .map_err(|e| DetectError::Library(e.to_string()))?;
        buffer.as_slice_mut().copy_from_slice(image.pixels);
        let ids = board.first_id..board.first_id + board.tag_count();
        let mut found = Found::default();
        for detection in self.0.detect(&buffer) {
            let id = u32::try_from(detection.id()).ok();
            match id.filter(|id| ids.contains(id) && !found.tags.iter().any(|t| t.id == *id)) {
                Some(id) => {
                    let library = detection.corners();
                    let corners_px = FROM_LIBRARY
                        .map(|k| library[k].map(|coordinate| coordinate - LIBRARY_PIXEL_OFFSET));
                    found.tags.push(TagCorners { id, corners_px });
                }
                None => found.foreign += 1,
            }
        }
        found.tags.sort_by_key(|t| t.id);
        Ok(found)
    }
}
