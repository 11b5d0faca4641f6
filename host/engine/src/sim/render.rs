//! Images of the board as a webcam takes them: the printed AprilTag grid
//! seen through the camera's lens (its distortion included), lit unevenly,
//! blurred and noisy, so the real detector has something real to read.
//!
//! Each pixel of the board's neighbourhood is the mean of `SUB` × `SUB`
//! samples; each sample's ray comes from undoing the lens
//! ([`Intrinsics::undistort`]) and meets the board's plane, where the
//! printed page says how much light it sends back. Pixel centres sit at
//! integer coordinates (OpenCV's convention), so the corners the lens
//! projects ([`Intrinsics::project`]) are where the rendered corners are.

use image::{ImageBuffer, Luma};
use nalgebra::{IsometryMatrix3, Point2, Point3, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;

use crate::camera::tag_bits::{self, CELLS};
use lrmcal_core::camera::{AprilGrid, Intrinsics};

/// Samples across a pixel, each way.
const SUB: usize = 4;
/// Samples along each edge of the page when bounding its image.
const OUTLINE_SAMPLES: usize = 24;

/// What a webcam adds to the geometry: light, focus, sensor noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    /// Sigma of the Gaussian blur (focus, a little motion), px.
    pub blur_px: f64,
    /// Sigma of the sensor noise on each pixel, grey levels.
    pub noise_grey: f64,
    /// The range the white page's grey level is drawn from, per image.
    pub white: [f64; 2],
    /// The range the black ink's grey level is drawn from, per image.
    pub black: [f64; 2],
    /// How much the light changes across the image, as a fraction of it
    /// (a lamp to one side), in a direction drawn per image.
    pub gradient: f64,
    /// The scene behind the page, as a fraction of the white page's light.
    pub background: f64,
}

impl Look {
    /// A webcam in an ordinary room: soft focus, visible noise, light from
    /// one side, the page never white nor the ink black.
    pub const WEBCAM: Self = Self {
        blur_px: 0.8,
        noise_grey: 2.5,
        white: [170.0, 235.0],
        black: [15.0, 50.0],
        gradient: 0.2,
        background: 0.45,
    };

    /// A perfect camera: sharp, noiseless, black on white, even light.
    pub const IDEAL: Self = Self {
        blur_px: 0.0,
        noise_grey: 0.0,
        white: [255.0, 255.0],
        black: [0.0, 0.0],
        gradient: 0.0,
        background: 0.5,
    };
}

/// The printed page: the grid's tags and the white around them, in the
/// board frame ([`lrmcal_core::camera::board`]).
struct Page<'a> {
    board: &'a AprilGrid,
    /// Each tag's bit image, by grid position.
    bits: Vec<Vec<u8>>,
    /// The white margin around the grid, m.
    margin_m: f64,
}

impl<'a> Page<'a> {
    fn new(board: &'a AprilGrid) -> Self {
        let bits = (0..board.tag_count())
            .map(|i| {
                tag_bits::tag36h11(board.first_id + i).unwrap_or_else(|| vec![255; CELLS * CELLS])
            })
            .collect();
        Self {
            board,
            bits,
            margin_m: board.tag_size_m / 2.0,
        }
    }

    fn pitch(&self) -> f64 {
        self.board.tag_size_m * (1.0 + self.board.spacing)
    }

    /// The page's corners in the board frame: lower left, upper right, m.
    fn extent(&self) -> [[f64; 2]; 2] {
        let size = |n: u32| f64::from(n - 1) * self.pitch() + self.board.tag_size_m;
        [
            [-self.margin_m, -self.margin_m],
            [
                size(self.board.cols) + self.margin_m,
                size(self.board.rows) + self.margin_m,
            ],
        ]
    }

    /// The light the page sends back at board point (x, y), 0 (ink) to 1
    /// (paper); `None` off the page.
    fn reflectance(&self, x: f64, y: f64) -> Option<f64> {
        let [[x0, y0], [x1, y1]] = self.extent();
        if !(x0..=x1).contains(&x) || !(y0..=y1).contains(&y) {
            return None;
        }
        let s = self.board.tag_size_m;
        let pitch = self.pitch();
        let cell = s / (CELLS - 2) as f64;
        let (col, row) = ((x / pitch).floor(), (y / pitch).floor());
        if col < 0.0
            || row < 0.0
            || col >= f64::from(self.board.cols)
            || row >= f64::from(self.board.rows)
        {
            return Some(1.0);
        }
        // Cells of the bit image: the black square from 1 to CELLS − 1, its top row first.
        let tx = 1.0 + (x - col * pitch) / cell;
        let ty = 1.0 + (s - (y - row * pitch)) / cell;
        if !(0.0..CELLS as f64).contains(&tx) || !(0.0..CELLS as f64).contains(&ty) {
            return Some(1.0);
        }
        let tag = &self.bits[(row as u32 * self.board.cols + col as u32) as usize];
        Some(f64::from(tag[ty as usize * CELLS + tx as usize]) / 255.0)
    }
}

/// The grey image (one byte a pixel, row by row from the top-left, the
/// intrinsics' size) the camera of `intrinsics` takes of `board` standing
/// at `camera_from_board`, looking as `look` says; the light, the noise and
/// the light's direction are drawn from `rng`.
pub fn render(
    intrinsics: &Intrinsics,
    board: &AprilGrid,
    camera_from_board: &IsometryMatrix3<f64>,
    look: &Look,
    rng: &mut impl Rng,
) -> Vec<u8> {
    let (width, height) = (intrinsics.width_px as usize, intrinsics.height_px as usize);
    let draw = |rng: &mut dyn rand::RngCore, [lo, hi]: [f64; 2]| {
        if hi > lo {
            rng.random_range(lo..hi)
        } else {
            lo
        }
    };
    let white = draw(rng, look.white);
    let black = draw(rng, look.black);
    let direction = rng.random_range(0.0..std::f64::consts::TAU);
    let (dc, ds) = (direction.cos(), direction.sin());
    let light = |u: f64, v: f64| {
        1.0 + look.gradient * ((u / width as f64 - 0.5) * dc + (v / height as f64 - 0.5) * ds)
    };
    let grey = |reflectance: f64| black + (white - black) * reflectance;

    let mut pixels: Vec<f32> = (0..width * height)
        .map(|k| (grey(look.background) * light((k % width) as f64, (k / width) as f64)) as f32)
        .collect();

    let page = Page::new(board);
    if let Some([u0, v0, u1, v1]) =
        page_bounds(intrinsics, &page, camera_from_board, look, width, height)
    {
        // The board plane in the camera frame: a point on it and its normal.
        let origin = camera_from_board.translation.vector;
        let normal = camera_from_board.rotation * Vector3::z();
        let board_from_camera = camera_from_board.inverse();
        // The rays through the pixels' corners (the lattice of half-integer
        // coordinates), undistorted once each; a sample's ray is blended from
        // its pixel's four, the lens being smooth over a pixel.
        let lattice_width = u1 - u0 + 1;
        let rays: Vec<Option<Vector3<f64>>> = (0..lattice_width * (v1 - v0 + 1))
            .map(|k| {
                let corner = Point2::new(
                    (u0 + k % lattice_width) as f64 - 0.5,
                    (v0 + k / lattice_width) as f64 - 0.5,
                );
                intrinsics
                    .undistort(&corner)
                    .map(|ray| Vector3::new(ray.x, ray.y, 1.0))
            })
            .collect();
        let on_page = |ray: Vector3<f64>| -> Option<f64> {
            let facing = normal.dot(&ray);
            if facing.abs() < 1e-12 {
                return None;
            }
            let depth = normal.dot(&origin) / facing;
            if depth <= 0.0 {
                return None;
            }
            let on_board = board_from_camera * Point3::from(ray * depth);
            page.reflectance(on_board.x, on_board.y)
        };
        for v in v0..v1 {
            for u in u0..u1 {
                let at = (v - v0) * lattice_width + (u - u0);
                let corners = [
                    rays[at],
                    rays[at + 1],
                    rays[at + lattice_width],
                    rays[at + lattice_width + 1],
                ];
                let mut sum = 0.0;
                for a in 0..SUB {
                    for b in 0..SUB {
                        let (x, y) = ((a as f64 + 0.5) / SUB as f64, (b as f64 + 0.5) / SUB as f64);
                        let ray = match corners {
                            [Some(r00), Some(r10), Some(r01), Some(r11)] => Some(
                                r00 * ((1.0 - x) * (1.0 - y))
                                    + r10 * (x * (1.0 - y))
                                    + r01 * ((1.0 - x) * y)
                                    + r11 * (x * y),
                            ),
                            _ => None,
                        };
                        sum += ray.and_then(on_page).unwrap_or(look.background);
                    }
                }
                let reflectance = sum / (SUB * SUB) as f64;
                pixels[v * width + u] = (grey(reflectance) * light(u as f64, v as f64)) as f32;
            }
        }
        if look.blur_px > 0.0 {
            blur_region(&mut pixels, width, [u0, v0, u1, v1], look.blur_px);
        }
    }

    pixels
        .iter()
        .map(|&p| {
            let noise = look.noise_grey * rng.sample::<f64, _>(StandardNormal);
            (f64::from(p) + noise).round().clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// The pixels `[u0, v0, u1, v1)` the page covers, with room for the blur;
/// `None` when no part of its outline is in front of the camera.
fn page_bounds(
    intrinsics: &Intrinsics,
    page: &Page<'_>,
    camera_from_board: &IsometryMatrix3<f64>,
    look: &Look,
    width: usize,
    height: usize,
) -> Option<[usize; 4]> {
    let [[x0, y0], [x1, y1]] = page.extent();
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for k in 0..=OUTLINE_SAMPLES {
        let t = k as f64 / OUTLINE_SAMPLES as f64;
        let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
        for point in [[x, y0], [x, y1], [x0, y], [x1, y]] {
            let seen = camera_from_board * Point3::new(point[0], point[1], 0.0);
            if let Some(pixel) = intrinsics.project(&seen) {
                lo = [lo[0].min(pixel.x), lo[1].min(pixel.y)];
                hi = [hi[0].max(pixel.x), hi[1].max(pixel.y)];
            }
        }
    }
    if !lo[0].is_finite() {
        return None;
    }
    let pad = 3.0 * look.blur_px + 2.0;
    let clip = |c: f64, size: usize| c.clamp(0.0, size as f64) as usize;
    let bounds = [
        clip((lo[0] - pad).floor(), width),
        clip((lo[1] - pad).floor(), height),
        clip((hi[0] + pad).ceil() + 1.0, width),
        clip((hi[1] + pad).ceil() + 1.0, height),
    ];
    (bounds[0] < bounds[2] && bounds[1] < bounds[3]).then_some(bounds)
}

/// Blurs the pixels `[u0, v0, u1, v1)` of the image by a Gaussian of sigma
/// `sigma_px` (the rest of the image is smooth light, which blur keeps).
fn blur_region(pixels: &mut [f32], width: usize, [u0, v0, u1, v1]: [usize; 4], sigma_px: f64) {
    let (w, h) = (u1 - u0, v1 - v0);
    let region: ImageBuffer<Luma<f32>, Vec<f32>> =
        ImageBuffer::from_fn(w as u32, h as u32, |x, y| {
            // The library's float pixels run from 0 to 1 (it clamps to that).
            Luma([pixels[(v0 + y as usize) * width + u0 + x as usize] / f32::from(u8::MAX)])
        });
    let blurred = image::imageops::blur(&region, sigma_px as f32);
    for (x, y, p) in blurred.enumerate_pixels() {
        pixels[(v0 + y as usize) * width + u0 + x as usize] = p.0[0] * f32::from(u8::MAX);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::detect::{Grey, TagDetector};
    use crate::camera::testing::{board, webcam};
    use nalgebra::{Rotation3, Translation3};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The board 0.8 m in front of the test webcam, its centre off the
    /// optical axis where the lens bends, tilted by `tilt_deg` and turned
    /// by `roll_deg`.
    fn placed(roll_deg: f64, tilt_deg: f64) -> IsometryMatrix3<f64> {
        let board = board();
        // Facing the camera upright: board x along the camera's x, board y up (against the camera's y).
        let facing = Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_diagonal(
            &Vector3::new(1.0, -1.0, -1.0),
        ));
        let turn = Rotation3::from_axis_angle(&Vector3::x_axis(), tilt_deg.to_radians())
            * Rotation3::from_axis_angle(&Vector3::z_axis(), -roll_deg.to_radians());
        let rotation = turn * facing;
        let centre = Vector3::new(0.25, -0.12, 0.8);
        IsometryMatrix3::from_parts(
            Translation3::from(centre - rotation * board.centre().coords),
            rotation,
        )
    }

    /// Each detected corner less where the lens projects it, px, over the
    /// views; every tag of the board found in every view.
    fn corner_errors(look: &Look) -> Vec<f64> {
        let (intrinsics, board) = (webcam(), board());
        let mut detector = TagDetector::new().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut errors = Vec::new();
        for (roll, tilt) in [(0.0, 0.0), (90.0, 20.0), (180.0, -35.0), (25.0, 45.0)] {
            let pose = placed(roll, tilt);
            let pixels = render(&intrinsics, &board, &pose, look, &mut rng);
            let grey = Grey {
                width: intrinsics.width_px,
                height: intrinsics.height_px,
                pixels: &pixels,
            };
            let found = detector.detect(grey, &board).unwrap();
            assert_eq!(
                found.tags.len() as u32,
                board.tag_count(),
                "roll {roll}, tilt {tilt}"
            );
            for (tag, (id, corners)) in found.tags.iter().zip(board.tags()) {
                assert_eq!(tag.id, id);
                for (seen, corner) in tag.corners_px.iter().zip(corners) {
                    let truth = intrinsics.project(&(pose * corner)).unwrap();
                    errors.push((seen[0] - truth.x).hypot(seen[1] - truth.y));
                }
            }
        }
        errors.sort_by(f64::total_cmp);
        eprintln!(
            "{look:?}: median {:.3} px, worst {:.3} px over {} corners",
            errors[errors.len() / 2],
            errors[errors.len() - 1],
            errors.len()
        );
        errors
    }

    /// Through the lens, sharp and clean, the detector puts the corners
    /// within a tenth of a pixel or so of the lens's projection (the
    /// sampling of the edges leaves the rest): the image is where the
    /// geometry says.
    #[test]
    fn an_ideal_image_puts_every_corner_where_the_lens_projects_it() {
        let errors = corner_errors(&Look::IDEAL);
        let (median, worst) = (errors[errors.len() / 2], errors[errors.len() - 1]);
        assert!(
            median < 0.15 && worst < 0.4,
            "median {median} px, worst {worst} px"
        );
    }

    /// A webcam's blur, noise and uneven light move the corners by a few
    /// tenths of a pixel, no tag lost.
    #[test]
    fn a_webcam_image_keeps_the_corners_within_a_pixel() {
        let errors = corner_errors(&Look::WEBCAM);
        let (median, worst) = (errors[errors.len() / 2], errors[errors.len() - 1]);
        assert!(
            median < 0.4 && worst < 1.0,
            "median {median} px, worst {worst} px"
        );
    }

    /// A dim room: the page and the ink 20 to 30 grey levels apart, light
    /// from one side, the webcam's noise. Every tag is still found (the
    /// detector skips only tiles flatter than its contrast floor), its
    /// corners within a pixel.
    #[test]
    fn a_dim_webcam_image_still_shows_every_tag() {
        let dim = Look {
            white: [35.0, 45.0],
            black: [12.0, 18.0],
            ..Look::WEBCAM
        };
        let errors = corner_errors(&dim);
        let (median, worst) = (errors[errors.len() / 2], errors[errors.len() - 1]);
        assert!(
            median < 0.6 && worst < 1.5,
            "median {median} px, worst {worst} px"
        );
    }
}
