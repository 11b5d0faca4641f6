//! The images taken at a pose list's poses (`docs/FORMATS.md`, "Camera
//! measurements (CSV)"): a pose list with a `load_kg` and an `image`
//! column, one row an image, naming the file taken at the pose under the
//! load; what `detect --poses` turns into a camera measurement file.
//!
//! The poses are read by the pose list's own reader
//! ([`pose_list::parse_listed`]), which ignores other columns; the images
//! by a second pass over the same text, paired with the poses by line.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use model::{JointKind, PerJoint};

use super::views::IMAGE_COLUMN;
use crate::dataset::Pose;
use crate::error::{Error, InputError, Problem};
use crate::io::csv_table::{Extra, Schema, for_each_row, format_joint, pose_columns, q_column};
use crate::io::{atomic, pose_list, read_text};

/// The columns the images' pass needs: the pose list's, with `load_kg`
/// and `image` required; other columns are the pose list's to judge.
const SCHEMA: Schema = Schema {
    columns: &pose_columns!(IMAGE_COLUMN),
    optional: &[],
    extra: Extra::Ignore,
};

/// One image of the list: the pose it was taken at, under which load.
#[derive(Clone, Debug, PartialEq)]
pub struct Shot {
    /// 1-based line of its row in the list.
    pub line: u64,
    /// The commanded pose.
    pub pose: Pose,
    /// Payload mass at the tool, kg.
    pub load_kg: f64,
    /// The image's file name, as the list writes it.
    pub image: String,
    /// How the list gives each joint: `qi_deg` revolute, `qi_mm` prismatic.
    pub units: PerJoint<JointKind>,
}

/// Reads a pose list of images, in the list's order.
pub fn read(path: &Path) -> Result<Vec<Shot>, Error> {
    parse(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Parses a pose list of images (joint units converted to rad and m):
/// refuses a list without `load_kg` or `image`, an empty image cell and an
/// image named twice, each by line and column.
pub fn parse(text: &str) -> Result<Vec<Shot>, InputError> {
    let mut poses = pose_list::parse_listed(text)?.into_iter().peekable();
    let mut shots = Vec::new();
    let mut named: HashMap<String, u64> = HashMap::new();
    for_each_row(text, &SCHEMA, |row| {
        let invalid = |column: &str, message: String| row.error(column, Problem::Invalid { message });
        let image = row.text(IMAGE_COLUMN).unwrap_or_default();
        if image.is_empty() {
            return Err(invalid(
                IMAGE_COLUMN,
                "empty: each pose names the image taken at it".to_owned(),
            ));
        }
        if let Some(first) = named.insert(image.to_owned(), row.line) {
            return Err(invalid(
                IMAGE_COLUMN,
                format!("`{image}` is named on line {first} too: an image is taken at one pose under one load"),
            ));
        }
        // The pose list gives a measurement file's further targets' rows no
        // pose of their own: such a row would name a second image of a pose.
        let listed = poses.next_if(|p| p.line == row.line).ok_or_else(|| {
            invalid(
                "pose",
                "repeats an earlier row's pose and load for another `target`: one row an image"
                    .to_owned(),
            )
        })?;
        shots.push(Shot {
            line: row.line,
            pose: listed.row.pose,
            load_kg: listed.row.load_kg.expect("the schema requires `load_kg`"),
            image: image.to_owned(),
            units: listed.units,
        });
        Ok(())
    })
    .map_err(why_needed)?;
    Ok(shots)
}

/// Writes a pose list of images atomically, in the order given:
/// `pose,load_kg,q1_deg..,image`; `kinds` are the arm's joints' (a
/// revolute joint's column is `qi_deg`, a prismatic one's `qi_mm`). The
/// shots' lines and units are the file's to give when it is read.
pub fn write(path: &Path, shots: &[Shot], kinds: &[JointKind]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, shots, kinds))
}

/// Writes a pose list of images to any writer (see [`write`]).
pub fn write_to(w: &mut dyn Write, shots: &[Shot], kinds: &[JointKind]) -> std::io::Result<()> {
    let mut columns = vec!["pose", "load_kg"];
    columns.extend(kinds.iter().enumerate().map(|(i, &k)| q_column(i, k)));
    columns.push(IMAGE_COLUMN);
    let mut csv = csv::Writer::from_writer(w);
    csv.write_record(&columns)?;
    for shot in shots {
        let mut record = vec![shot.pose.id.to_string(), shot.load_kg.to_string()];
        record.extend(
            kinds
                .iter()
                .zip(&shot.pose.q)
                .map(|(&k, &q)| format_joint(k, q)),
        );
        record.push(shot.image.clone());
        csv.write_record(&record)?;
    }
    csv.flush()
}

/// A missing `load_kg` or `image` column's error, saying why it is needed.
fn why_needed(error: InputError) -> InputError {
    let why = match error.problem {
        Problem::MissingColumn {
            column: "load_kg", ..
        } => {
            "each image's load is needed (0 for none): the camera measurements give every view its load"
        }
        Problem::MissingColumn {
            column: IMAGE_COLUMN,
            ..
        } => "each pose names the image taken at it (its file name)",
        _ => return error,
    };
    InputError::new(
        error.location,
        Problem::Invalid {
            message: format!("missing from the header: {why}"),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "pose,load_kg,q1_deg,q2_mm,image,note_t\n";

    fn error_of(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    /// The rows in order, each with its line, pose, load, image and the
    /// list's joint units; comments and other columns are the pose list's.
    #[test]
    fn each_row_is_an_image_of_a_pose_under_a_load() {
        let text = format!(
            "# session 3\n{HEADER}7,0,10,250,b.png,1\n7,0.5,10,250,a.png,2\n\n3,0,-5,0,\"c, d.jpg\",3\n"
        );
        let shots = parse(&text).unwrap();
        let summary: Vec<(u64, u32, f64, &str)> = shots
            .iter()
            .map(|s| (s.line, s.pose.id, s.load_kg, s.image.as_str()))
            .collect();
        assert_eq!(
            summary,
            [
                (3, 7, 0.0, "b.png"),
                (4, 7, 0.5, "a.png"),
                (6, 3, 0.0, "c, d.jpg")
            ]
        );
        assert_eq!(shots[2].pose.q[..], [-5f64.to_radians(), 0.0]);
        assert_eq!(
            shots[0].units[..],
            [JointKind::Revolute, JointKind::Prismatic]
        );
    }

    /// What is written reads back: the same poses, loads, images and
    /// order, the joints in the arm's units.
    #[test]
    fn a_written_list_reads_back() {
        let text = format!(
            "{HEADER}7,0,10.5,250,b.png,1\n7,0.5,10.5,250,\"a, 2.png\",2\n3,0,-5,0,c.jpg,3\n"
        );
        let shots = parse(&text).unwrap();
        let kinds = [JointKind::Revolute, JointKind::Prismatic];
        let mut written = Vec::new();
        write_to(&mut written, &shots, &kinds).unwrap();
        let again = parse(std::str::from_utf8(&written).unwrap()).unwrap();
        let strip = |s: &[Shot]| -> Vec<(Pose, f64, String)> {
            s.iter()
                .map(|s| (s.pose, s.load_kg, s.image.clone()))
                .collect()
        };
        assert_eq!(strip(&again), strip(&shots));
        assert_eq!(again[0].units, shots[0].units);
    }

    #[test]
    fn a_list_without_loads_or_images_is_refused_saying_why() {
        let e = error_of("pose,q1_deg,image\n1,0,a.png\n");
        assert!(
            e.contains("line 1, column `load_kg`") && e.contains("each image's load is needed"),
            "{e}"
        );
        let e = error_of("pose,load_kg,q1_deg\n1,0,0\n");
        assert!(
            e.contains("line 1, column `image`") && e.contains("names the image"),
            "{e}"
        );
    }

    #[test]
    fn an_empty_or_repeated_image_is_refused_by_line() {
        let e = error_of(&format!("{HEADER}1,0,0,0,a.png,\n2,0,0,0,,\n"));
        assert!(e.contains("line 3, column `image`: empty"), "{e}");
        let e = error_of(&format!(
            "{HEADER}1,0,0,0,a.png,\n2,0,0,0,b.png,\n3,0,0,0,a.png,\n"
        ));
        assert!(
            e.contains("line 4, column `image`") && e.contains("`a.png` is named on line 2"),
            "{e}"
        );
    }

    #[test]
    fn the_pose_lists_rules_hold() {
        let e = error_of(&format!("{HEADER}1,0,0,0,a.png,\n1,0,0,0,b.png,\n"));
        assert!(e.contains("line 3, column `pose`"), "{e}");
        let e = error_of(&format!("{HEADER}1,-1,0,0,a.png,\n"));
        assert!(e.contains("line 2, column `load_kg`"), "{e}");
        let e = error_of("pose,load_kg,q1_deg,image,target\n1,0,0,a.png,T1\n1,0,0,b.png,T2\n");
        assert!(
            e.contains("line 3, column `pose`") && e.contains("one row an image"),
            "{e}"
        );
    }
}
