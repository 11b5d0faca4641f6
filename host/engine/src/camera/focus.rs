//! How sharp a camera frame is, and how much the scene changed between two
//! frames: what `measure --capture` picks a webcam frame by.
//!
//! Sharpness is the variance of the frame's Laplacian, the focus measure of
//! Pech-Pacheco et al. ("Diatom autofocusing in brightfield microscopy: a
//! comparative study", ICPR 2000), OpenCV's `Laplacian(grey).var()`: the
//! Laplacian is large only across sharp edges, so defocus or motion blur,
//! which spreads the edges, leaves it near zero everywhere and its variance
//! small. Its value depends on the scene (how much of the frame the board
//! fills, the light), so it ranks frames of one scene, or flags a frame far
//! below others of a similar one; it says nothing on its own.
//!
//! Both measures look at pixel blocks' mean grey levels rather than at single
//! pixels, because a webcam's pixel noise would otherwise drown what they
//! look for: the board may fill a fiftieth of the frame, and noise of σ grey
//! levels alone gives the full-resolution Laplacian a variance of 20σ² (on
//! the simulated webcam's frames the background, without an edge, has 128
//! where the whole frame has 141).

use image::GrayImage;

/// Side of the pixel squares averaged into one before the Laplacian, px:
/// averaging 2x2 pixels quarters the noise's variance and keeps the board's
/// edges. On the simulated webcam's frames a defocus of 1.5 px, applied
/// before the noise, then halves the Laplacian's variance, where at full
/// resolution it takes off an eighth.
pub const SHARPNESS_BIN_PX: usize = 2;

/// Side of the blocks whose mean grey levels [`scene_change`] compares, px:
/// averaging 64 pixels takes the noise down 8 times, and a board a few
/// dozen pixels across still spans many blocks.
pub const CHANGE_BLOCK_PX: usize = 8;

/// [`scene_change`] is the change exceeded by one block in this many: the
/// board's edges, where a moving scene changes, cover far more of the frame
/// (a 1280x720 frame has 14 400 blocks), while a few odd blocks (a
/// flickering light, a hot pixel) cannot decide alone.
pub const CHANGED_BLOCKS_PER: usize = 1000;

/// A grey frame's means over squares of `side` px, row by row; the pixels
/// of a last partial row or column of squares are left out.
struct Binned {
    /// Squares in a row.
    width: usize,
    /// Rows of squares.
    height: usize,
    /// The squares' mean grey levels.
    means: Vec<f64>,
}

impl Binned {
    fn of(grey: &GrayImage, side: usize) -> Self {
        let columns = grey.width() as usize;
        let (width, height) = (columns / side, grey.height() as usize / side);
        let mut sums = vec![0u32; width * height];
        for (y, row) in grey
            .as_raw()
            .chunks_exact(columns.max(1))
            .take(height * side)
            .enumerate()
        {
            let sums = &mut sums[y / side * width..][..width];
            for (x, &pixel) in row[..width * side].iter().enumerate() {
                sums[x / side] += u32::from(pixel);
            }
        }
        let area = (side * side) as f64;
        Self {
            width,
            height,
            means: sums.into_iter().map(|s| f64::from(s) / area).collect(),
        }
    }
}

/// The variance of the 4-neighbour Laplacian (the kernel
/// `[0 1 0; 1 -4 1; 0 1 0]`, OpenCV's `ksize = 1`) of the frame averaged
/// over squares of [`SHARPNESS_BIN_PX`], over the squares that have all four
/// neighbours, in grey levels squared; 0 for a frame too small to have one.
pub fn sharpness(grey: &GrayImage) -> f64 {
    let binned = Binned::of(grey, SHARPNESS_BIN_PX);
    let (width, height) = (binned.width, binned.height);
    if width < 3 || height < 3 {
        return 0.0;
    }
    let at = |i: usize| binned.means[i];
    let (mut sum, mut squares) = (0.0, 0.0);
    for y in 1..height - 1 {
        for x in 1..width - 1 {
            let i = y * width + x;
            let laplacian = at(i - width) + at(i + width) + at(i - 1) + at(i + 1) - 4.0 * at(i);
            sum += laplacian;
            squares += laplacian * laplacian;
        }
    }
    let count = ((width - 2) * (height - 2)) as f64;
    let mean = sum / count;
    squares / count - mean * mean
}

/// How much the scene changed between two frames of one camera, in grey
/// levels (0 to 255): of the absolute differences of their
/// [`CHANGE_BLOCK_PX`] blocks' mean grey levels, the one exceeded by one
/// block in [`CHANGED_BLOCKS_PER`]; 0 for frames smaller than a block,
/// `None` when their sizes differ.
pub fn scene_change(a: &GrayImage, b: &GrayImage) -> Option<f64> {
    if a.dimensions() != b.dimensions() {
        return None;
    }
    let (a, b) = (
        Binned::of(a, CHANGE_BLOCK_PX),
        Binned::of(b, CHANGE_BLOCK_PX),
    );
    let mut changes: Vec<f64> = a
        .means
        .iter()
        .zip(&b.means)
        .map(|(x, y)| (x - y).abs())
        .collect();
    if changes.is_empty() {
        return Some(0.0);
    }
    let rank = changes.len() - 1 - changes.len() / CHANGED_BLOCKS_PER;
    let (_, change, _) = changes.select_nth_unstable_by(rank, f64::total_cmp);
    Some(*change)
}
