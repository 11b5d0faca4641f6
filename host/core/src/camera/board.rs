//! The board the arm carries: a grid of AprilTag 36h11 tags, Kalibr's
//! `aprilgrid`, and its file.
//!
//! **Board frame** (Kalibr's, `GridCalibrationTargetAprilgrid::createGridPoints`):
//! the origin at the bottom-left corner of the first tag's black square (the
//! tag at column 0, row 0, the grid seen upright, as printed); x along a row
//! (to the right), y along a column (up), z = x × y out of the printed face,
//! towards whoever looks at it; metres. Ids run row by row from the first:
//! the tag at column c, row r is `first_id + r · cols + c`, row 0 the bottom
//! one. Tags follow each other every `tag_size · (1 + spacing)`.
//!
//! **Corner order**: OpenCV ArUco's, which `detectMarkers` returns: clockwise
//! as seen upright from the tag's top-left, i.e. top-left, top-right,
//! bottom-right, bottom-left. Kalibr stores them counter-clockwise from the
//! bottom-left and the AprilTag C library wraps counter-clockwise too: a
//! detector other than ArUco maps its corners to this order.
//!
//! The corners are those of the black square (the tag size); the small black
//! squares Kalibr prints between the tags are not used.

use std::path::Path;

use nalgebra::Point3;
use serde::Deserialize;

use super::yaml::{at, finite, from_value, parse_value};
use crate::error::{Error, InputError, Problem};
use crate::io::read_text;

/// Ids in the tag36h11 family: 0 to 586.
pub const TAG36H11_IDS: u32 = 587;

/// A grid of AprilTag 36h11 tags (Kalibr's `aprilgrid`).
#[derive(Clone, Debug, PartialEq)]
pub struct AprilGrid {
    /// Rows of tags (along y).
    pub rows: u32,
    /// Tags in a row (along x).
    pub cols: u32,
    /// Edge of a tag's black square, m.
    pub tag_size_m: f64,
    /// The gap between two tags over the tag size (Kalibr's `tagSpacing`).
    pub spacing: f64,
    /// The id of the tag at the origin; the others follow row by row.
    pub first_id: u32,
}

impl AprilGrid {
    /// Checks the grid: at least one tag, a finite tag size > 0, a finite
    /// spacing ≥ 0, every id within tag36h11's. Errors name the file's keys.
    pub fn check(&self) -> Result<(), InputError> {
        for (key, n) in [("tagRows", self.rows), ("tagCols", self.cols)] {
            if n == 0 {
                return Err(at(
                    key,
                    Problem::OutOfRange {
                        expected: "at least 1 tag",
                        found: "0".into(),
                    },
                ));
            }
        }
        if finite("tagSize", self.tag_size_m)? <= 0.0 {
            return Err(at(
                "tagSize",
                Problem::OutOfRange {
                    expected: "a tag size > 0 m (the black square's edge)",
                    found: self.tag_size_m.to_string(),
                },
            ));
        }
        if finite("tagSpacing", self.spacing)? < 0.0 {
            return Err(at(
                "tagSpacing",
                Problem::OutOfRange {
                    expected: "a spacing >= 0 (the gap over the tag size)",
                    found: self.spacing.to_string(),
                },
            ));
        }
        let last = u64::from(self.first_id) + u64::from(self.rows) * u64::from(self.cols) - 1;
        if last >= u64::from(TAG36H11_IDS) {
            return Err(at(
                "firstId",
                Problem::Invalid {
                    message: format!(
                        "the {} tags from id {} end at id {last}, past tag36h11's last id, {}",
                        u64::from(self.rows) * u64::from(self.cols),
                        self.first_id,
                        TAG36H11_IDS - 1
                    ),
                },
            ));
        }
        Ok(())
    }

    /// How many tags the grid holds.
    pub fn tag_count(&self) -> u32 {
        self.rows * self.cols
    }

    /// Each tag's id and its four corners in the board frame, m, in the
    /// module's corner order, row by row from the first tag.
    pub fn tags(&self) -> impl Iterator<Item = (u32, [Point3<f64>; 4])> + '_ {
        let s = self.tag_size_m;
        let pitch = s * (1.0 + self.spacing);
        (0..self.tag_count()).map(move |i| {
            let (x, y) = (
                f64::from(i % self.cols) * pitch,
                f64::from(i / self.cols) * pitch,
            );
            let corners = [
                Point3::new(x, y + s, 0.0),
                Point3::new(x + s, y + s, 0.0),
                Point3::new(x + s, y, 0.0),
                Point3::new(x, y, 0.0),
            ];
            (self.first_id + i, corners)
        })
    }

    /// Every tag corner in the board frame, m.
    pub fn corners(&self) -> impl Iterator<Item = Point3<f64>> + '_ {
        self.tags().flat_map(|(_, corners)| corners)
    }

    /// The middle of the grid in the board frame, m.
    pub fn centre(&self) -> Point3<f64> {
        let s = self.tag_size_m;
        let pitch = s * (1.0 + self.spacing);
        let extent = |n: u32| f64::from(n - 1) * pitch + s;
        Point3::new(extent(self.cols) / 2.0, extent(self.rows) / 2.0, 0.0)
    }
}

/// Kalibr's aprilgrid YAML, with two optional keys of lrmcal's.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoard {
    target_type: String,
    #[serde(rename = "tagCols")]
    tag_cols: u32,
    #[serde(rename = "tagRows")]
    tag_rows: u32,
    #[serde(rename = "tagSize")]
    tag_size: f64,
    #[serde(rename = "tagSpacing")]
    tag_spacing: f64,
    #[serde(rename = "firstId", default)]
    first_id: u32,
    #[serde(rename = "tagFamily")]
    tag_family: Option<String>,
}

/// Reads and checks a board file.
pub fn read(path: &Path) -> Result<AprilGrid, Error> {
    let text = read_text(path)?;
    parse(&text).map_err(|e| e.in_file(path))
}

/// Parses and checks the text of a board file (Kalibr's `aprilgrid` YAML).
pub fn parse(text: &str) -> Result<AprilGrid, InputError> {
    let raw: RawBoard = from_value(parse_value(text)?)?;
    if raw.target_type != "aprilgrid" {
        return Err(at(
            "target_type",
            Problem::Invalid {
                message: format!(
                    "expected 'aprilgrid' (a grid of AprilTags), found '{}'",
                    raw.target_type
                ),
            },
        ));
    }
    if let Some(family) = raw.tag_family.filter(|f| f != "tag36h11") {
        return Err(at(
            "tagFamily",
            Problem::Invalid {
                message: format!("expected tag36h11, the only family supported, found {family}"),
            },
        ));
    }
    let board = AprilGrid {
        rows: raw.tag_rows,
        cols: raw.tag_cols,
        tag_size_m: raw.tag_size,
        spacing: raw.tag_spacing,
        first_id: raw.first_id,
    };
    board.check()?;
    Ok(board)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KALIBR: &str = "target_type: 'aprilgrid'\ntagCols: 6\ntagRows: 6\n\
tagSize: 0.088\ntagSpacing: 0.3\n";

    #[test]
    fn a_kalibr_file_reads_with_our_defaults() {
        let board = parse(KALIBR).unwrap();
        assert_eq!(
            board,
            AprilGrid {
                rows: 6,
                cols: 6,
                tag_size_m: 0.088,
                spacing: 0.3,
                first_id: 0
            }
        );
        let text = format!("{KALIBR}firstId: 100\ntagFamily: tag36h11\n");
        assert_eq!(parse(&text).unwrap().first_id, 100);
    }

    #[test]
    fn tags_follow_kalibrs_layout_and_arucos_corner_order() {
        let board = AprilGrid {
            rows: 2,
            cols: 3,
            tag_size_m: 0.1,
            spacing: 0.5,
            first_id: 10,
        };
        let tags: Vec<_> = board.tags().collect();
        assert_eq!(tags.len(), 6);
        // The first tag: its bottom-left corner at the origin; clockwise from
        // the top-left as seen from +z with y up.
        let [tl, tr, br, bl] = tags[0].1;
        assert_eq!(tags[0].0, 10);
        assert_eq!(bl, Point3::origin());
        assert_eq!((tl.x, tl.y), (0.0, 0.1));
        assert_eq!((tr.x, tr.y), (0.1, 0.1));
        assert_eq!((br.x, br.y), (0.1, 0.0));
        // Clockwise seen from +z: the signed area of the polygon is negative.
        let c = tags[0].1;
        let area: f64 = (0..4)
            .map(|i| c[i].x * c[(i + 1) % 4].y - c[(i + 1) % 4].x * c[i].y)
            .sum();
        assert!(area < 0.0);
        // Id 13: column 0 of the second row, one pitch (0.15 m) up.
        let (id, corners) = tags[3];
        assert_eq!(id, 13);
        assert!((corners[3].y - 0.15).abs() < 1e-15 && corners[3].x == 0.0);
        let centre = board.centre();
        assert!((centre.x - 0.2).abs() < 1e-15 && (centre.y - 0.125).abs() < 1e-15);
    }

    #[test]
    fn bad_boards_are_refused_naming_the_key() {
        for (from, to, key) in [
            ("tagSize: 0.088", "tagSize: -0.088", "tagSize"),
            ("tagCols: 6", "tagCols: 0", "tagCols"),
            ("tagSpacing: 0.3", "tagSpacing: .nan", "tagSpacing"),
            ("'aprilgrid'", "'checkerboard'", "target_type"),
            ("tagRows: 6\n", "", "tagRows"),
        ] {
            let e = parse(&KALIBR.replace(from, to)).unwrap_err().to_string();
            assert!(e.contains(key), "{from} -> {to}: {e}");
        }
        let e = parse(&format!("{KALIBR}firstId: 560\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("firstId") && e.contains("595"), "{e}");
        let e = parse(&format!("{KALIBR}tagFamily: tag25h9\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("tagFamily") && e.contains("tag25h9"), "{e}");
    }
}
