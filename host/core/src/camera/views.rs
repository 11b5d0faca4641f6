//! Camera measurements (`docs/FORMATS.md`, "Camera measurements (CSV)"):
//! the board's tag corners a camera saw at each commanded pose and load,
//! `pose,load_kg,q1_deg..qn_deg,tag,corner,u_px,v_px[,image]`, one row a
//! corner. A camera's measurement file, as a tracker's is the measurements
//! file: what `detect --poses` and `simulate --camera` write.
//!
//! The rows of one pose under one load (a *view*) are together, and the
//! views are in the order the poses were visited, as a tracker's rows are:
//! that order gives each joint its way in ([`crate::dataset::approaches`]).
//! Each tag seen has its four corners, in the board's order.

use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

use model::backlash::Approach;
use model::{JointKind, PerJoint};

use super::corners::TagCorners;
use crate::dataset::{Pose, approaches, from_home};
use crate::error::{Error, InputError, Location, Problem};
use crate::io::csv_table::{
    Extra, PoseBook, Row, Schema, for_each_row, format_fixed, format_joint, pose_columns, q_column,
};
use crate::io::{atomic, read_text};

/// The optional column naming the image a view was seen in.
pub const IMAGE_COLUMN: &str = "image";

/// The columns of a camera measurement file, in the order they are written
/// ([`IMAGE_COLUMN`] last, when the views name their images).
pub const COLUMNS: [&str; 17] = pose_columns!("tag", "corner", "u_px", "v_px", IMAGE_COLUMN);

const SCHEMA: Schema = Schema {
    columns: &COLUMNS,
    optional: &[IMAGE_COLUMN],
    extra: Extra::Refuse,
};

/// Decimals of the pixel columns: a thousandth of a pixel, far below what a
/// detector resolves.
const PIXEL_DECIMALS: usize = 3;

/// What the camera saw at one commanded pose under one load.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    /// The commanded pose.
    pub pose: Pose,
    /// Payload mass at the tool, kg.
    pub load_kg: f64,
    /// The image the tags were found in, when the file names it.
    pub image: Option<String>,
    /// The tags seen, each with its four corners, in the file's order.
    pub tags: Vec<TagCorners>,
    /// The way each joint arrived at the pose, from the views' order; not a
    /// column of the file.
    pub approach: PerJoint<Approach>,
    /// The line of the view's first row in the file it was read from (for
    /// messages about its pose); 0 for a view not read from a file.
    pub line: u64,
}

impl View {
    /// A view of `pose` under `load_kg` of `tags`, its approach from home
    /// until [`visiting_order`] sets it.
    pub fn new(pose: Pose, load_kg: f64, image: Option<String>, tags: Vec<TagCorners>) -> Self {
        Self {
            approach: from_home(pose.q.len()),
            pose,
            load_kg,
            image,
            tags,
            line: 0,
        }
    }
}

/// Sets every view's approach from the views' order, the visiting order.
pub fn visiting_order(views: &mut [View]) {
    let ways = approaches(views.iter().map(|v| &v.pose.q));
    for (v, way) in views.iter_mut().zip(ways) {
        v.approach = way;
    }
}

/// Reads a camera measurement file.
pub fn read(path: &Path) -> Result<Vec<View>, Error> {
    parse(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Parses camera measurement CSV text (joint units converted to rad and m).
pub fn parse(text: &str) -> Result<Vec<View>, InputError> {
    let mut reader = ViewReader::default();
    for_each_row(text, &SCHEMA, |row| reader.row(row))?;
    reader.finish()
}

/// One tag's corners as they arrive, row by row.
struct PartTag {
    id: u32,
    line: u64,
    corners: [Option<[f64; 2]>; 4],
}

/// The views being read: the current one's rows until another (pose, load)
/// begins.
#[derive(Default)]
struct ViewReader {
    views: Vec<View>,
    /// The tags of the last view, as far as read.
    tags: Vec<PartTag>,
    /// The line each (pose, load) began on.
    began: HashMap<(u32, u64), u64>,
    book: PoseBook,
}

impl ViewReader {
    fn row(&mut self, row: &Row<'_>) -> Result<(), InputError> {
        let id = row.pose_id()?;
        let load_kg = row.non_negative("load_kg", "a load >= 0 kg")?;
        let q = row.joint_angles_rad()?;
        // An empty cell: the view has no image (written so beside views that have one).
        let image = row
            .text(IMAGE_COLUMN)
            .filter(|name| !name.is_empty())
            .map(str::to_owned);
        let tag = tag_id(row)?;
        let corner = corner_index(row)?;
        let pixel = [
            row.number("u_px", "a pixel coordinate")?,
            row.number("v_px", "a pixel coordinate")?,
        ];
        let key = (id, load_kg.to_bits());
        let same_view = self
            .views
            .last()
            .is_some_and(|v| v.pose.id == id && v.load_kg.to_bits() == key.1);
        if same_view {
            let view = self.views.last().expect("checked above");
            if view
                .pose
                .q
                .iter()
                .zip(&q)
                .any(|(a, b)| (a - b).abs() > 1e-9)
            {
                return Err(row.error(
                    "pose",
                    Problem::InconsistentPose {
                        pose: id,
                        first_line: self.began[&key],
                    },
                ));
            }
            if view.image != image {
                return Err(row.error(
                    IMAGE_COLUMN,
                    invalid(format!(
                        "pose {id} under {load_kg} kg was seen in `{}` on line {}: a view is one image",
                        view.image.as_deref().unwrap_or_default(),
                        self.began[&key]
                    )),
                ));
            }
        } else {
            self.close_view()?;
            if let Some(&first_line) = self.began.get(&key) {
                return Err(row.error(
                    "pose",
                    invalid(format!(
                        "pose {id} under {load_kg} kg again: its rows began on line {first_line} \
                         and another pose's came between; the rows of a pose and load are \
                         together, in the order the poses were visited"
                    )),
                ));
            }
            self.book.record(row, id, &q, Some(load_kg), None)?;
            self.began.insert(key, row.line);
            self.views.push(View {
                line: row.line,
                ..View::new(Pose { id, q }, load_kg, image, Vec::new())
            });
        }
        self.corner(row, tag, corner, pixel)
    }

    /// Records one corner of the current view's tag `tag`.
    fn corner(
        &mut self,
        row: &Row<'_>,
        tag: u32,
        corner: usize,
        pixel: [f64; 2],
    ) -> Result<(), InputError> {
        let part = match self.tags.iter_mut().position(|t| t.id == tag) {
            Some(i) => &mut self.tags[i],
            None => {
                self.tags.push(PartTag {
                    id: tag,
                    line: row.line,
                    corners: [None; 4],
                });
                self.tags.last_mut().expect("just pushed")
            }
        };
        if part.corners[corner].is_some() {
            return Err(row.error(
                "corner",
                invalid(format!(
                    "corner {corner} of tag {tag} is given twice for this pose and load"
                )),
            ));
        }
        part.corners[corner] = Some(pixel);
        Ok(())
    }

    /// Ends the current view: every tag with its four corners.
    fn close_view(&mut self) -> Result<(), InputError> {
        let Some(view) = self.views.last_mut() else {
            return Ok(());
        };
        for part in self.tags.drain(..) {
            let mut corners = [[0.0; 2]; 4];
            for (k, c) in part.corners.iter().enumerate() {
                corners[k] = c.ok_or_else(|| {
                    InputError::new(
                        Location::column(part.line, "corner"),
                        invalid(format!(
                            "tag {} of pose {} under {} kg lacks its corner {k}: a tag seen has \
                             its four corners (0 to 3)",
                            part.id, view.pose.id, view.load_kg
                        )),
                    )
                })?;
            }
            view.tags.push(TagCorners {
                id: part.id,
                corners_px: corners,
            });
        }
        Ok(())
    }

    fn finish(mut self) -> Result<Vec<View>, InputError> {
        self.close_view()?;
        visiting_order(&mut self.views);
        Ok(self.views)
    }
}

fn invalid(message: String) -> Problem {
    Problem::Invalid { message }
}

/// The `tag` cell: a tag id, an integer from 0.
fn tag_id(row: &Row<'_>) -> Result<u32, InputError> {
    let text = row.text("tag").unwrap_or_default();
    text.parse().map_err(|_| {
        row.error(
            "tag",
            Problem::NotANumber {
                expected: "a tag id (integer from 0)",
                found: text.to_owned(),
            },
        )
    })
}

/// The `corner` cell: 0 to 3.
fn corner_index(row: &Row<'_>) -> Result<usize, InputError> {
    let text = row.text("corner").unwrap_or_default();
    match text.parse::<usize>() {
        Ok(k) if k < 4 => Ok(k),
        _ => Err(row.error(
            "corner",
            Problem::OutOfRange {
                expected: "a corner 0 to 3 (top-left, top-right, bottom-right, bottom-left)",
                found: text.to_owned(),
            },
        )),
    }
}

/// Writes a camera measurement file atomically; `kinds` are the arm's
/// joints' (a revolute joint's column is `qi_deg`, a prismatic one's `qi_mm`).
pub fn write(path: &Path, views: &[View], kinds: &[JointKind]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, views, kinds))
}

/// Writes camera measurement CSV to any writer; the `image` column only when
/// a view names its image.
pub fn write_to(w: &mut dyn Write, views: &[View], kinds: &[JointKind]) -> std::io::Result<()> {
    let named = views.iter().any(|v| v.image.is_some());
    let mut columns = vec!["pose", "load_kg"];
    columns.extend(kinds.iter().enumerate().map(|(i, &k)| q_column(i, k)));
    columns.extend(["tag", "corner", "u_px", "v_px"]);
    if named {
        columns.push(IMAGE_COLUMN);
    }
    let mut csv = csv::Writer::from_writer(w);
    csv.write_record(&columns)?;
    for view in views {
        let mut pose = vec![view.pose.id.to_string(), view.load_kg.to_string()];
        pose.extend(
            kinds
                .iter()
                .zip(&view.pose.q)
                .map(|(&k, &q)| format_joint(k, q)),
        );
        for tag in &view.tags {
            for (k, [u, v]) in tag.corners_px.iter().enumerate() {
                let mut record = pose.clone();
                record.extend([
                    tag.id.to_string(),
                    k.to_string(),
                    format_fixed(*u, PIXEL_DECIMALS),
                    format_fixed(*v, PIXEL_DECIMALS),
                ]);
                if named {
                    record.push(view.image.clone().unwrap_or_default());
                }
                csv.write_record(&record)?;
            }
        }
    }
    csv.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "pose,load_kg,q1_deg,q2_deg,tag,corner,u_px,v_px";

    fn tag_rows(pose: &str, tag: u32) -> String {
        (0..4)
            .map(|k| format!("{pose},{tag},{k},{}.5,{}.25\n", 100 + k, 200 + k))
            .collect()
    }

    fn file(views: &[(&str, u32)]) -> String {
        let mut text = format!("{HEADER}\n");
        for (pose, tag) in views {
            text.push_str(&tag_rows(pose, *tag));
        }
        text
    }

    fn error_of(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    /// What is written is read back the same, views in order with their
    /// approaches, the image column only when views name images.
    #[test]
    fn a_written_file_reads_back_the_same() {
        let tag = |id, d: f64| TagCorners {
            id,
            corners_px: [[1.0 + d, 2.0], [3.0, 2.5], [3.125, 4.0], [1.0, 4.0 - d]],
        };
        let q = |a: f64, b: f64| PerJoint::from_slice(&[a, b]).unwrap();
        let mut views = vec![
            View::new(
                Pose {
                    id: 4,
                    q: q(30f64.to_radians(), -0.25),
                },
                0.0,
                None,
                vec![tag(3, 0.0), tag(1, 0.5)],
            ),
            View::new(
                Pose {
                    id: 4,
                    q: q(30f64.to_radians(), -0.25),
                },
                0.0663,
                None,
                vec![tag(3, 0.25)],
            ),
            View::new(
                Pose {
                    id: 9,
                    q: q(-12.5f64.to_radians(), 0.25),
                },
                0.0,
                None,
                vec![tag(0, 0.125)],
            ),
        ];
        visiting_order(&mut views);
        let kinds = [JointKind::Revolute, JointKind::Prismatic];
        let mut out = Vec::new();
        write_to(&mut out, &views, &kinds).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("pose,load_kg,q1_deg,q2_mm,tag,corner,u_px,v_px\n"));
        // Each view read knows the line its rows begin on.
        let lines = |read: Vec<View>| -> (Vec<u64>, Vec<View>) {
            let lines = read.iter().map(|v| v.line).collect();
            (
                lines,
                read.into_iter().map(|v| View { line: 0, ..v }).collect(),
            )
        };
        assert_eq!(
            lines(parse(&text).unwrap()),
            (vec![2, 10, 14], views.clone())
        );

        views[0].image = Some("shot 1.png".into());
        views[1].image = Some("shot 2.png".into());
        let mut out = Vec::new();
        write_to(&mut out, &views, &kinds).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.lines().next().unwrap().ends_with(",image"));
        assert_eq!(lines(parse(&text).unwrap()).1, views);
    }

    #[test]
    fn a_view_split_by_another_pose_is_refused_naming_both_lines() {
        let text = file(&[("1,0,10,20", 0), ("2,0,10,30", 0), ("1,0,10,20", 1)]);
        let e = error_of(&text);
        assert!(e.contains("line 10"), "{e}");
        assert!(e.contains("began on line 2"), "{e}");
    }

    #[test]
    fn a_tag_without_its_four_corners_is_refused() {
        let mut text = file(&[("1,0,10,20", 0)]);
        text.push_str("1,0,10,20,5,0,1,1\n1,0,10,20,5,2,1,1\n1,0,10,20,5,3,1,1\n");
        let e = error_of(&text);
        assert!(e.contains("line 6"), "{e}");
        assert!(e.contains("tag 5") && e.contains("corner 1"), "{e}");
    }

    #[test]
    fn a_corner_given_twice_is_refused() {
        let mut text = file(&[("1,0,10,20", 0)]);
        text.push_str("1,0,10,20,0,2,1,1\n");
        let e = error_of(&text);
        assert!(e.contains("line 6") && e.contains("twice"), "{e}");
    }

    #[test]
    fn bad_cells_are_refused_by_line_and_column() {
        let bad = |cells: &str, column: &str| {
            let text = format!("{HEADER}\n{cells}\n");
            let e = error_of(&text);
            assert!(e.contains("line 2") && e.contains(column), "{cells}: {e}");
        };
        bad("1,0,10,20,0,4,1,1", "corner");
        bad("1,0,10,20,-1,0,1,1", "tag");
        bad("1,0,10,20,0,0,nan,1", "u_px");
        bad("1,-1,10,20,0,0,1,1", "load_kg");
        let missing = "pose,load_kg,q1_deg,tag,corner,u_px\n1,0,10,0,0,1\n";
        assert!(error_of(missing).contains("v_px"));
        let extra = format!("{HEADER},x_mm\n1,0,10,20,0,0,1,1,5\n");
        assert!(error_of(&extra).contains("x_mm"));
    }

    #[test]
    fn one_pose_id_is_one_configuration() {
        let text = file(&[("1,0,10,20", 0), ("1,0.1,10,21", 0)]);
        let e = error_of(&text);
        assert!(e.contains("line 6") && e.contains("pose 1"), "{e}");
    }

    #[test]
    fn a_view_is_seen_in_one_image() {
        let text = "pose,load_kg,q1_deg,tag,corner,u_px,v_px,image\n\
                    1,0,10,0,0,1,1,a.png\n1,0,10,0,1,1,1,b.png\n";
        let e = error_of(text);
        assert!(e.contains("line 3") && e.contains("a.png"), "{e}");
    }
}
