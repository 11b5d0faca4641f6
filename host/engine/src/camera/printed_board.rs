//! The board as a page to print: an SVG drawing of the AprilTag grid at its
//! true size (millimetres), each tag's bits from the AprilTag C library, a
//! white margin around the grid, and a caption that says the tag size to
//! check with a ruler and where the board frame is.

use std::fmt::Write as _;

use super::tag_bits::{self, CELLS};
use lrmcal_core::camera::AprilGrid;

/// White around the grid, as a fraction of the tag size: the detector needs
/// a quiet border, and the caption goes below it.
const MARGIN_TAGS: f64 = 0.5;

/// Height of the caption's line, mm.
const CAPTION_MM: f64 = 4.0;

/// The SVG of `board`, in millimetres; `None` when a tag id is not in the
/// family (a board file's check refuses that first).
pub fn svg(board: &AprilGrid) -> Option<String> {
    let mm = |m: f64| m * 1e3;
    let size = mm(board.tag_size_m);
    let pitch = size * (1.0 + board.spacing);
    let margin = size * MARGIN_TAGS;
    let extent = |n: u32| f64::from(n - 1) * pitch + size;
    let (grid_w, grid_h) = (extent(board.cols), extent(board.rows));
    let (width, height) = (
        grid_w + 2.0 * margin,
        grid_h + 2.0 * margin + 3.0 * CAPTION_MM,
    );
    let cell = size / (CELLS - 2) as f64;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width:.3}mm" height="{height:.3}mm" viewBox="0 0 {width:.3} {height:.3}">"#
    );
    let _ = writeln!(
        out,
        r#"<rect x="0" y="0" width="{width:.3}" height="{height:.3}" fill="white"/>"#
    );
    for (index, (id, _)) in board.tags().enumerate() {
        let bits = tag_bits::tag36h11(id)?;
        let (col, row) = (index as u32 % board.cols, index as u32 / board.cols);
        // Row 0 is the bottom one as printed; the drawing's y runs down.
        let left = margin + f64::from(col) * pitch - cell;
        let top = margin + grid_h - f64::from(row) * pitch - size - cell;
        let _ = writeln!(out, "<g><!-- tag {id} -->");
        for (k, bit) in bits.iter().enumerate() {
            if *bit == 0 {
                let (x, y) = (
                    left + (k % CELLS) as f64 * cell,
                    top + (k / CELLS) as f64 * cell,
                );
                let _ = writeln!(
                    out,
                    r#"<rect x="{x:.4}" y="{y:.4}" width="{cell:.4}" height="{cell:.4}" fill="black"/>"#
                );
            }
        }
        let _ = writeln!(out, "</g>");
    }
    let baseline = margin + grid_h + margin + 2.0 * CAPTION_MM;
    let _ = writeln!(
        out,
        r#"<text x="{margin:.3}" y="{baseline:.3}" font-family="sans-serif" font-size="{CAPTION_MM}">tag36h11, ids {}-{}: each black square {size:.2} mm (print at 100 %, check with a ruler). Board frame: origin at the bottom-left corner of tag {}'s black square, x right, y up.</text>"#,
        board.first_id,
        board.first_id + board.tag_count() - 1,
        board.first_id,
    );
    let _ = writeln!(out, "</svg>");
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::testing::board;

    /// The page is the grid's size plus its margins, in millimetres, and
    /// every tag's black cells are drawn, tag 0's at the bottom left.
    #[test]
    fn the_page_is_the_boards_true_size() {
        let board = board();
        let svg = svg(&board).unwrap();
        // 4 × 3 tags of 25 mm every 32.5 mm: 122.5 × 90 mm, 12.5 mm of white around.
        assert!(svg.contains(r#"width="147.500mm""#), "{}", &svg[..200]);
        for id in 0..12 {
            assert!(svg.contains(&format!("<!-- tag {id} -->")));
        }
        let black: usize = (0..12)
            .map(|id| {
                tag_bits::tag36h11(id)
                    .unwrap()
                    .iter()
                    .filter(|b| **b == 0)
                    .count()
            })
            .sum();
        assert_eq!(svg.matches(r#"fill="black""#).count(), black);
        // Tag 0's top-left cell (white border excluded) is at the grid's bottom left.
        let top = 12.5 + 90.0 - 25.0;
        assert!(
            svg.contains(&format!(r#"<rect x="12.5000" y="{top:.4}""#)),
            "tag 0's corner cell"
        );
    }

    /// The printed page, rasterised at 10 px/mm, is read by the detector:
    /// every tag found with its id where the board puts it, so what is
    /// printed is the board the board file describes.
    #[test]
    fn the_detector_reads_the_printed_page() {
        use crate::camera::detect::{Grey, TagDetector};
        const PX_PER_MM: f64 = 10.0;
        let board = board();
        let svg = svg(&board).unwrap();
        let number = |line: &str, key: &str| -> f64 {
            let start = line.find(&format!(" {key}=\"")).unwrap() + key.len() + 3;
            let rest = &line[start..];
            rest[..rest.find('"').unwrap()].parse().unwrap()
        };
        let (width, height) = (1475usize, 1270usize);
        let mut pixels = vec![255u8; width * height];
        for line in svg.lines().filter(|l| l.contains(r#"fill="black""#)) {
            let [x, y, w, h] = ["x", "y", "width", "height"].map(|k| number(line, k) * PX_PER_MM);
            for v in (y.round() as usize)..((y + h).round() as usize) {
                for u in (x.round() as usize)..((x + w).round() as usize) {
                    pixels[v * width + u] = 0;
                }
            }
        }
        let grey = Grey {
            width: width as u32,
            height: height as u32,
            pixels: &pixels,
        };
        let found = TagDetector::new().unwrap().detect(grey, &board).unwrap();
        assert_eq!(found.tags.len(), 12);
        // A tag's top-left corner in the drawing: the board frame's x right,
        // y up from the grid's bottom-left, 12.5 mm of margin.
        for (tag, (id, corners)) in found.tags.iter().zip(board.tags()) {
            assert_eq!(tag.id, id);
            let top_left = corners[0];
            let expected = [
                (12.5 + 1e3 * top_left.x) * PX_PER_MM - 0.5,
                (12.5 + 90.0 - 1e3 * top_left.y) * PX_PER_MM - 0.5,
            ];
            let [u, v] = tag.corners_px[0];
            assert!(
                (u - expected[0]).hypot(v - expected[1]) < 1.5,
                "tag {id}: ({u}, {v}) against {expected:?}"
            );
        }
    }
}
