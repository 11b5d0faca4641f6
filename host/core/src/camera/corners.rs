//! Detected corners (`docs/FORMATS.md`, "Detected corners (CSV)"): the
//! board's tag corners found in images, `image,tag,corner,u_px,v_px`, one
//! row a corner, in the board's corner order ([`super::board`]) and OpenCV's
//! pixel convention (the top-left pixel's centre at (0, 0)).

use std::io::Write;
use std::path::Path;

use crate::error::Error;
use crate::io::atomic;

/// The columns of a detected-corners file, in order.
pub const COLUMNS: [&str; 5] = ["image", "tag", "corner", "u_px", "v_px"];

/// One tag of the board seen in an image.
#[derive(Clone, Debug, PartialEq)]
pub struct TagCorners {
    /// The tag's id.
    pub id: u32,
    /// Its corners in the board's order, (u, v) in OpenCV pixels.
    pub corners_px: [[f64; 2]; 4],
}

/// The tags of the board seen in one image file.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageCorners {
    /// The image's file name.
    pub image: String,
    /// Its tags, by id.
    pub tags: Vec<TagCorners>,
}

/// Writes a detected-corners file atomically.
pub fn write(path: &Path, images: &[ImageCorners]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, images))
}

/// Writes detected-corners CSV to any writer (see [`write`]).
pub fn write_to(w: &mut dyn Write, images: &[ImageCorners]) -> std::io::Result<()> {
    let mut csv = csv::Writer::from_writer(w);
    csv.write_record(COLUMNS)?;
    for image in images {
        for tag in &image.tags {
            for (k, [u, v]) in tag.corners_px.iter().enumerate() {
                csv.write_record([
                    image.image.clone(),
                    tag.id.to_string(),
                    k.to_string(),
                    format!("{u:.3}"),
                    format!("{v:.3}"),
                ])?;
            }
        }
    }
    csv.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_row_a_corner_in_the_boards_order() {
        let images = [ImageCorners {
            image: "a, b.png".into(),
            tags: vec![TagCorners {
                id: 7,
                corners_px: [[1.0, 2.0], [3.0, 2.0], [3.0, 4.0], [1.0, 4.25]],
            }],
        }];
        let mut out = Vec::new();
        write_to(&mut out, &images).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(
            text,
            "image,tag,corner,u_px,v_px\n\
             \"a, b.png\",7,0,1.000,2.000\n\
             \"a, b.png\",7,1,3.000,2.000\n\
             \"a, b.png\",7,2,3.000,4.000\n\
             \"a, b.png\",7,3,1.000,4.250\n"
        );
    }
}
