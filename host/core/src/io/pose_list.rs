//! Pose lists (`docs/FORMATS.md`, "Pose lists"): candidates and selections,
//! `pose[,load_kg],q1_deg..q6_deg[,role]`, and the check of their angles
//! against an arm's joint limits.
//!
//! Any CSV with the pose columns is a pose list: a measurement file, a
//! prediction joined with its poses, a spreadsheet. Other columns are
//! ignored, except one that looks like a misspelt `load_kg`, and `role`:
//! what a selection's pose is for, `fit` or `validate` ([`PoseRole`]; a
//! list without the column is all `fit`, as lists were before it).
//!
//! The file is long for its tests: the reader whole and as a stream, the
//! roles and the writer are one set of rules, pinned side by side.

use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};

use model::{Arm, JointKind, PerJoint};

use crate::dataset::{Pose, PoseRow, TargetName};
use crate::error::{Error, InputError, Location, Problem};
use crate::io::csv_table::{
    Extra, LineRows, PoseBook, Q_COLUMNS, ReadError, Row, Schema, for_each_row, format_joint,
    pose_columns, q_column,
};
use crate::io::measurements::{ListedMeasurement, TARGET_COLUMN};
use crate::io::{atomic, read_text};

/// The columns of a pose list, in the order they are written (`load_kg` only if any row has one).
pub const COLUMNS: [&str; 12] = pose_columns!();

const SCHEMA: Schema = Schema {
    columns: &COLUMNS,
    optional: &["load_kg"],
    extra: Extra::Ignore,
};

/// The column that says what a selection's pose is for.
pub const ROLE_COLUMN: &str = "role";

/// What a listed pose is for: `lrmcal select` sets a few poses aside for
/// validation, which `identify --poses` then holds out of the fit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PoseRole {
    /// Fitted (every pose of a list without a `role` column).
    #[default]
    Fit,
    /// Measured like the others but held out of the fit, to validate it.
    Validate,
}

impl PoseRole {
    /// How the `role` column writes it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Fit => "fit",
            Self::Validate => "validate",
        }
    }

    /// The role a `role` cell names (case and surrounding spaces aside).
    pub fn from_name(text: &str) -> Option<Self> {
        [Self::Fit, Self::Validate]
            .into_iter()
            .find(|r| r.name().eq_ignore_ascii_case(text.trim()))
    }
}

impl std::fmt::Display for PoseRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A pose-list row and the line of the file it was read from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ListedPose {
    /// 1-based line in the file.
    pub line: u64,
    /// The row.
    pub row: PoseRow,
    /// How the file gives each joint: `qi_deg` revolute, `qi_mm` prismatic.
    pub units: PerJoint<JointKind>,
    /// What the pose is for (`fit` when the file has no `role` column).
    pub role: PoseRole,
}

/// The ids of `rows` whose role is `role`, each once, in file order.
pub fn ids_with_role(rows: &[ListedPose], role: PoseRole) -> Vec<u32> {
    let mut ids: Vec<u32> = Vec::new();
    for r in rows.iter().filter(|r| r.role == role) {
        if !ids.contains(&r.row.pose.id) {
            ids.push(r.row.pose.id);
        }
    }
    ids
}

/// Reads a pose list.
pub fn read(path: &Path) -> Result<Vec<PoseRow>, Error> {
    parse(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Reads a pose list, keeping each row's line for later messages.
pub fn read_listed(path: &Path) -> Result<Vec<ListedPose>, Error> {
    parse_listed(&read_text(path)?).map_err(|e| e.in_file(path))
}

/// Parses pose-list CSV text (angles converted to rad).
pub fn parse(text: &str) -> Result<Vec<PoseRow>, InputError> {
    Ok(parse_listed(text)?.into_iter().map(|l| l.row).collect())
}

/// Parses pose-list CSV text (angles converted to rad), with each row's line.
///
/// Without `load_kg` each pose id appears once; with it each (pose, load)
/// pair; an id always has the same angles.
pub fn parse_listed(text: &str) -> Result<Vec<ListedPose>, InputError> {
    let mut out = Vec::new();
    let mut book = Book::default();
    for_each_row(text, &SCHEMA, |row| {
        out.extend(book.pose(row)?);
        Ok(())
    })?;
    Ok(out)
}

/// What a pose list's reader remembers across rows.
#[derive(Default)]
struct Book {
    poses: PoseBook,
    /// (pose, load) pairs already listed from a file of several targets.
    listed: std::collections::HashSet<(u32, Option<u64>)>,
    /// Each pose id's role and the line that first gave it.
    roles: std::collections::HashMap<u32, (PoseRole, u64)>,
}

impl Book {
    /// The pose of `row`, or `None` for a further target's row of a pose
    /// already listed.
    fn pose(&mut self, row: &Row<'_>) -> Result<Option<ListedPose>, InputError> {
        let id = row.pose_id()?;
        let load_kg = if row.has("load_kg") {
            Some(row.non_negative("load_kg", "a load >= 0 kg")?)
        } else {
            None
        };
        let q = row.joint_angles_rad()?;
        // A measurement file of several targets lists each pose once per
        // target: as a pose list it is its poses, each once.
        let target = row
            .ignored_text(TARGET_COLUMN)
            .and_then(|t| TargetName::from(t).ok());
        self.poses.record(row, id, &q, load_kg, target)?;
        let role = self.role(row, id)?;
        if target.is_some() && !self.listed.insert((id, load_kg.map(f64::to_bits))) {
            return Ok(None);
        }
        Ok(Some(ListedPose {
            line: row.line,
            row: PoseRow {
                pose: Pose { id, q },
                load_kg,
            },
            units: row.joint_units(),
            role,
        }))
    }

    /// The role `row` gives pose `id`: its `role` cell, `fit` without the
    /// column; one role per pose id.
    fn role(&mut self, row: &Row<'_>, id: u32) -> Result<PoseRole, InputError> {
        let Some(text) = row.ignored_text(ROLE_COLUMN) else {
            return Ok(PoseRole::Fit);
        };
        let invalid = |message: String| {
            InputError::new(
                Location::column(row.line, ROLE_COLUMN),
                Problem::Invalid { message },
            )
        };
        let role = PoseRole::from_name(text).ok_or_else(|| {
            invalid(format!(
                "expected `fit` or `validate` (what the pose is for), found `{text}`"
            ))
        })?;
        match self.roles.get(&id) {
            Some(&(first, line)) if first != role => Err(invalid(format!(
                "pose {id} is `{role}` here and `{first}` on line {line}: a pose is either fitted or held out"
            ))),
            Some(_) => Ok(role),
            None => {
                self.roles.insert(id, (role, row.line));
                Ok(role)
            }
        }
    }
}

/// A pose list read record by record as it arrives (joint angles an arm's
/// own controller writes as it reaches each pose), with the rules of
/// [`parse_listed`]: each pose handed over as soon as its line is complete.
pub struct PoseStream<R> {
    rows: LineRows<R>,
    book: Book,
    name: PathBuf,
}

impl<R: BufRead> PoseStream<R> {
    /// The poses of `reader`, called `name` in errors (a path, or
    /// `<stdin>`).
    pub fn new(reader: R, name: impl Into<PathBuf>) -> Self {
        Self {
            rows: LineRows::new(reader, &SCHEMA),
            book: Book::default(),
            name: name.into(),
        }
    }

    /// What errors call the input.
    pub fn name(&self) -> &Path {
        &self.name
    }

    /// The next pose, blocking until its line arrives; `None` at the end
    /// (an error if the input had no poses).
    pub fn next_pose(&mut self) -> Result<Option<ListedPose>, Error> {
        loop {
            let book = &mut self.book;
            match self.rows.next_row(|row| book.pose(row)) {
                Ok(Some(Some(pose))) => return Ok(Some(pose)),
                Ok(Some(None)) => continue,
                Ok(None) => return Ok(None),
                Err(ReadError::Input(e)) => return Err(e.in_file(&self.name)),
                Err(ReadError::Read(source)) => {
                    return Err(Error::Read {
                        path: self.name.clone(),
                        source,
                    });
                }
            }
        }
    }
}

/// How far past a limit an angle may read and still be on it, rad: files
/// carry 9 decimals of degrees, so a pose planned on a limit reads back
/// within 1e-11 rad of it.
const LIMIT_TOLERANCE_RAD: f64 = 1e-9;

/// The rows of `rows` with an angle outside `arm`'s joint limits, as errors
/// naming the line, the joint's column, the angle and the limits in degrees.
pub fn outside_limits(arm: &Arm<f64>, rows: &[ListedPose]) -> Vec<InputError> {
    // Degrees (mm) to 1e-6 for people: 105, not 105.00000000000001.
    let people = |kind: JointKind, x: f64| match kind {
        JointKind::Revolute => (x.to_degrees() * 1e6).round() / 1e6,
        JointKind::Prismatic => (x * 1e9).round() / 1e6,
    };
    rows.iter()
        .filter_map(|listed| {
            let pose = &listed.row.pose;
            if pose.q.len() != arm.joints.len() {
                return Some(joint_count_error(
                    listed.line,
                    pose.q.len(),
                    arm.joints.len(),
                ));
            }
            let (i, (joint, &q)) =
                arm.joints
                    .iter()
                    .zip(&pose.q)
                    .enumerate()
                    .find(|(_, (j, q))| {
                        **q < j.limits[0] - LIMIT_TOLERANCE_RAD
                            || **q > j.limits[1] + LIMIT_TOLERANCE_RAD
                    })?;
            Some(InputError::new(
                Location::column(listed.line, q_column(i, joint.kind)),
                Problem::OutsideLimits {
                    pose: pose.id,
                    joint: i as u32 + 1,
                    angle_deg: people(joint.kind, q),
                    limits_deg: joint.limits.map(|l| people(joint.kind, l)),
                    kind: joint.kind,
                },
            ))
        })
        .collect()
}

/// The error of a row whose joint column is in the other unit than its
/// joint moves in: degrees for a prismatic joint, mm for a revolute one.
fn unit_error(arm: &Arm<f64>, listed: &ListedPose) -> Option<InputError> {
    let (i, (joint, &unit)) = arm
        .joints
        .iter()
        .zip(&listed.units)
        .enumerate()
        .find(|(_, (j, u))| j.kind != **u)?;
    let (how, want) = match joint.kind {
        JointKind::Revolute => ("turns", "an angle in degrees"),
        JointKind::Prismatic => ("slides", "a position in mm"),
    };
    Some(InputError::new(
        Location::column(listed.line, q_column(i, unit)),
        Problem::Invalid {
            message: format!(
                "joint {} of the arm {how}: its column is `{}`, {want}",
                i + 1,
                q_column(i, joint.kind)
            ),
        },
    ))
}

/// The error of a row of `found` joint angles for an arm of `joints` joints.
fn joint_count_error(line: u64, found: usize, joints: usize) -> InputError {
    let column = Q_COLUMNS[found.min(joints)];
    InputError::new(
        Location::column(line, column),
        Problem::Invalid {
            message: format!(
                "the file has {found} joint-angle columns (q1_deg..q{found}_deg) where the arm \
                 has {joints} joints: one column per joint"
            ),
        },
    )
}

/// Checks the poses read from `path` against `arm`'s joint limits.
///
/// A pose outside them is an error naming the file, line, joint, angle and
/// limits (degrees), unless `allow`: then the poses are used, and the
/// returned text (`None` if all are inside) is a warning for the user.
pub fn check_within_limits(
    arm: &Arm<f64>,
    path: &Path,
    rows: &[ListedPose],
    allow: bool,
) -> Result<Option<String>, Error> {
    // A row of another arm is never "used anyway".
    if let Some(listed) = rows.iter().find(|l| l.row.pose.q.len() != arm.joints.len()) {
        let error = joint_count_error(listed.line, listed.row.pose.q.len(), arm.joints.len());
        return Err(error.in_file(path));
    }
    if let Some(error) = rows.iter().find_map(|l| unit_error(arm, l)) {
        return Err(error.in_file(path));
    }
    let outside = outside_limits(arm, rows);
    match outside.first() {
        None => Ok(None),
        Some(first) if !allow => Err(first.clone().in_file(path)),
        Some(first) => Ok(Some(format!(
            "{} of the {} rows of `{}` lie outside the joint limits, used anyway \
             (--allow-outside-limits); the first: {first}",
            outside.len(),
            rows.len(),
            path.display()
        ))),
    }
}

/// The rows of a measurement file as pose-list rows, one per measurement
/// (every target's row, with its line), for [`check_within_limits`]: a
/// command checks the measurements it has read, never the file again.
pub fn of_measurements(rows: &[ListedMeasurement]) -> Vec<ListedPose> {
    rows.iter()
        .map(|l| ListedPose {
            units: l.units,
            line: l.line,
            role: PoseRole::Fit,
            row: PoseRow {
                pose: l.measurement.pose,
                load_kg: Some(l.measurement.load_kg),
            },
        })
        .collect()
}

/// Writes a pose list atomically; the `load_kg` column is written when any row has a load.
///
/// A row without a load in a list that has the column is written with load 0.
/// `kinds` are the arm's joints': a revolute joint's column is `qi_deg`, a
/// prismatic one's `qi_mm`.
pub fn write(path: &Path, rows: &[PoseRow], kinds: &[JointKind]) -> Result<(), Error> {
    atomic::write(path, |w| write_to(w, rows, kinds))
}

/// Writes a pose list with a `role` column atomically: each row of `rows`
/// with the role of the same place in `roles` (see [`write`]).
pub fn write_with_roles(
    path: &Path,
    rows: &[PoseRow],
    roles: &[PoseRole],
    kinds: &[JointKind],
) -> Result<(), Error> {
    atomic::write(path, |w| write_rows(w, rows, Some(roles), kinds))
}

/// Writes pose-list CSV to any writer (see [`write`]).
pub fn write_to(w: &mut dyn Write, rows: &[PoseRow], kinds: &[JointKind]) -> std::io::Result<()> {
    write_rows(w, rows, None, kinds)
}

/// Writes pose-list CSV, with a `role` column when `roles` are given.
fn write_rows(
    w: &mut dyn Write,
    rows: &[PoseRow],
    roles: Option<&[PoseRole]>,
    kinds: &[JointKind],
) -> std::io::Result<()> {
    let with_load = rows.iter().any(|r| r.load_kg.is_some());
    let mut csv = csv::Writer::from_writer(w);
    let mut columns = vec!["pose"];
    if with_load {
        columns.push("load_kg");
    }
    columns.extend(kinds.iter().enumerate().map(|(i, &k)| q_column(i, k)));
    if roles.is_some() {
        columns.push(ROLE_COLUMN);
    }
    csv.write_record(&columns)?;
    for (k, r) in rows.iter().enumerate() {
        let mut record = vec![r.pose.id.to_string()];
        if with_load {
            record.push(r.load_kg.unwrap_or(0.0).to_string());
        }
        record.extend(
            kinds
                .iter()
                .zip(&r.pose.q)
                .map(|(&k, &q)| format_joint(k, q)),
        );
        if let Some(roles) = roles {
            record.push(roles.get(k).copied().unwrap_or_default().name().into());
        }
        csv.write_record(&record)?;
    }
    csv.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bundled_arm() -> model::Arm<f64> {
        crate::io::arm_source::bundled("lrm").unwrap().arm
    }

    const HEADER: &str = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n";

    #[test]
    fn measurement_files_and_other_csv_are_pose_lists() {
        let measured = "# tracker\npose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n\
                        17,0,-100,0,100,0,-100,0,212.41,-35.02,188.77\n\
                        17,0.0663,-100,0,100,0,-100,0,212.9,-35.31,186.02\n";
        let rows = parse_listed(measured).unwrap();
        assert_eq!(rows.iter().map(|r| r.line).collect::<Vec<_>>(), [3, 4]);
        assert_eq!(rows[1].row.load_kg, Some(0.0663));
        assert_eq!(rows[0].row.pose, rows[1].row.pose);
        let predicted = "pose,x_mm,y_mm,z_mm,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,operator\n\
                         5,1,2,3,0,10,20,30,40,50,ann\n";
        let rows = parse(predicted).unwrap();
        assert_eq!(rows[0].pose.q[5], 50f64.to_radians());
        assert_eq!(rows[0].load_kg, None);
    }

    #[test]
    fn duplicates_missing_columns_and_a_misspelt_load_are_refused() {
        let e = parse(&format!("{HEADER}1,0,0,0,0,0,0\n1,0,0,0,0,0,0\n")).unwrap_err();
        assert!(
            e.to_string().contains("pose 1 already appears on line 2"),
            "{e}"
        );
        let e = parse("pose,x_mm,y_mm,z_mm\n1,2,3,4\n").unwrap_err();
        assert!(e.to_string().contains("`q1_deg`"), "{e}");
        for column in ["load", "Load_g", "payload_kg"] {
            let text = format!(
                "pose,{column},q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0.5,0,0,0,0,0,0\n"
            );
            let e = parse(&text).unwrap_err().to_string();
            assert!(
                e.contains(&format!("column `{column}`")) && e.contains("misspelt `load_kg`"),
                "{e}"
            );
        }
    }

    #[test]
    fn angles_outside_the_limits_name_line_joint_and_limit() {
        let arm = bundled_arm();
        let text =
            format!("{HEADER}# comment\n1,0,0,0,0,0,0\n2,0,0,105,0,0,0\n3,0,0,-120.5,0,0,0\n");
        let rows = parse_listed(&text).unwrap();
        let outside = outside_limits(&arm, &rows);
        // 105° is the limit itself (inclusive); -120.5° is past -105°.
        assert_eq!(outside.len(), 1);
        let message = outside[0].to_string();
        assert_eq!(
            message,
            "line 5, column `q3_deg`: pose 3: -120.5° is outside joint 3's limits [-105°, 105°] \
             (pass --allow-outside-limits to use it anyway)"
        );
        let path = Path::new("poses.csv");
        let e = check_within_limits(&arm, path, &rows, false).unwrap_err();
        assert!(
            e.report().contains("`poses.csv`: line 5, column `q3_deg`"),
            "{}",
            e.report()
        );
        let warning = check_within_limits(&arm, path, &rows, true)
            .unwrap()
            .unwrap();
        assert!(
            warning.starts_with("1 of the 3 rows of `poses.csv`") && warning.contains("line 5"),
            "{warning}"
        );
        assert_eq!(
            check_within_limits(&arm, path, &rows[..2], false).unwrap(),
            None
        );
    }

    #[test]
    fn a_measurement_file_is_checked_too() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("measured.csv");
        std::fs::write(
            &path,
            "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n\
             1,0,0,0,0,0,0,0,1,2,3\n2,0,0,0,0,0,0,200,1,2,3\n",
        )
        .unwrap();
        let rows = of_measurements(&crate::io::measurements::read_listed(&path).unwrap());
        let e = check_within_limits(&bundled_arm(), &path, &rows, false).unwrap_err();
        let msg = e.report();
        assert!(
            msg.contains("measured.csv")
                && msg.contains("line 3, column `q6_deg`")
                && msg.contains("200°"),
            "{msg}"
        );
    }

    /// A selection with validation poses writes a `role` column and reads
    /// back row for row with its roles; a list without the column is all
    /// `fit`; a role other than the two, or two roles for one pose, is
    /// refused naming the line and the column.
    #[test]
    fn roles_round_trip_and_old_lists_are_all_fit() {
        let q = |d: f64| PerJoint::splat(6, d.to_radians());
        let rows: Vec<PoseRow> = [(3, 10.0), (8, -20.0), (5, 0.0)]
            .iter()
            .map(|&(id, d)| PoseRow {
                pose: Pose { id, q: q(d) },
                load_kg: None,
            })
            .collect();
        let roles = [PoseRole::Fit, PoseRole::Validate, PoseRole::Fit];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("selected.csv");
        write_with_roles(&path, &rows, &roles, &[JointKind::Revolute; 6]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,role\n")
                && text.contains("\n8,-20,-20,-20,-20,-20,-20,validate\n"),
            "{text}"
        );
        let listed = read_listed(&path).unwrap();
        assert_eq!(
            listed.iter().map(|l| (l.row, l.role)).collect::<Vec<_>>(),
            rows.iter().copied().zip(roles).collect::<Vec<_>>()
        );
        assert_eq!(ids_with_role(&listed, PoseRole::Fit), [3, 5]);
        assert_eq!(ids_with_role(&listed, PoseRole::Validate), [8]);
        // The plain reader still gives every pose.
        assert_eq!(read(&path).unwrap(), rows);
        // Without the column (an older list): every pose is fitted.
        let old = parse_listed(&format!("{HEADER}1,0,0,0,0,0,0\n2,5,0,0,0,0,0\n")).unwrap();
        assert!(old.iter().all(|l| l.role == PoseRole::Fit));
        // Spelt in capitals with spaces around: still read.
        let loose = format!("{}, role\n1,0,0,0,0,0,0, Validate \n", HEADER.trim_end());
        assert_eq!(parse_listed(&loose).unwrap()[0].role, PoseRole::Validate);
        let e = parse(&format!("{},role\n1,0,0,0,0,0,0,test\n", HEADER.trim_end()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2, column `role`") && e.contains("found `test`"),
            "{e}"
        );
        let both = "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,role\n\
                    1,0,0,0,0,0,0,0,fit\n1,0.5,0,0,0,0,0,0,validate\n";
        let e = parse(both).unwrap_err().to_string();
        assert!(
            e.contains("line 3, column `role`") && e.contains("`fit` on line 2"),
            "{e}"
        );
    }

    /// Several targets per pose: one row per (pose, load, target), sorted by
    /// pose then target, as `docs/FORMATS.md` shows it.
    const TARGETS: &str = "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm,target\n\
                           0,0,0,0,0,0,0,0,1,2,3,T1\n\
                           0,0,0,0,0,0,0,0,4,5,6,T2\n\
                           1,0,0,0,0,0,0,200,1,2,3,T1\n\
                           1,0,0,0,0,0,0,200,4,5,6,T2\n";

    #[test]
    fn a_measurement_file_of_several_targets_is_a_pose_list_of_its_poses() {
        let rows = parse_listed(TARGETS).unwrap();
        let listed: Vec<(u32, u64)> = rows.iter().map(|r| (r.row.pose.id, r.line)).collect();
        assert_eq!(listed, [(0, 2), (1, 4)]);
        // The same pose under one target twice is still refused.
        let twice = TARGETS.replace(",T2\n1,", ",T1\n1,");
        let e = parse(&twice).unwrap_err().to_string();
        assert!(
            e.contains("line 3") && e.contains("already appears on line 2"),
            "{e}"
        );
    }

    #[test]
    fn measurements_of_several_targets_are_checked_row_by_row() {
        let listed = crate::io::measurements::parse_listed(TARGETS).unwrap();
        let rows = of_measurements(&listed);
        assert_eq!(rows.len(), 4);
        let path = Path::new("all.csv");
        let e = check_within_limits(&bundled_arm(), path, &rows, false).unwrap_err();
        assert!(
            e.report()
                .contains("`all.csv`: line 4, column `q6_deg`: pose 1: 200°"),
            "{}",
            e.report()
        );
        let warning = check_within_limits(&bundled_arm(), path, &rows, true)
            .unwrap()
            .unwrap();
        assert!(warning.starts_with("2 of the 4 rows"), "{warning}");
    }
}

#[cfg(test)]
mod stream_tests {
    use std::cell::RefCell;
    use std::collections::VecDeque;
    use std::io::{BufReader, Read};
    use std::rc::Rc;

    use super::*;

    /// A reader handing out one chunk per read, as a pipe hands out what a
    /// writer wrote so far; counts what is still unread.
    struct Chunks(Rc<RefCell<VecDeque<Vec<u8>>>>);

    impl Read for Chunks {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let Some(chunk) = self.0.borrow_mut().pop_front() else {
                return Ok(0);
            };
            buf[..chunk.len()].copy_from_slice(&chunk);
            Ok(chunk.len())
        }
    }

    fn chunks(chunks: &[&[u8]]) -> Chunks {
        Chunks(Rc::new(RefCell::new(
            chunks.iter().map(|c| c.to_vec()).collect(),
        )))
    }

    fn stream(texts: &[&str]) -> PoseStream<BufReader<Chunks>> {
        let bytes: Vec<&[u8]> = texts.iter().map(|t| t.as_bytes()).collect();
        PoseStream::new(BufReader::new(chunks(&bytes)), "<stdin>")
    }

    fn all(mut s: PoseStream<impl BufRead>) -> Result<Vec<ListedPose>, Error> {
        let mut out = Vec::new();
        while let Some(p) = s.next_pose()? {
            out.push(p);
        }
        Ok(out)
    }

    #[test]
    fn each_pose_is_handed_over_once_its_line_has_arrived() {
        let texts: [&[u8]; 3] = [
            b"pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n",
            b"1,10,0,0,0,0,0\n",
            b"2,0,20,0,0,0,0\n",
        ];
        let input = chunks(&texts);
        let unread = Rc::clone(&input.0);
        let mut s = PoseStream::new(BufReader::new(input), "<stdin>");
        let first = s.next_pose().unwrap().unwrap();
        assert_eq!((first.line, first.row.pose.id), (2, 1));
        // The second record has not been read: a controller that has not
        // yet written it does not hold the first one up.
        assert_eq!(unread.borrow().len(), 1);
        let second = s.next_pose().unwrap().unwrap();
        assert_eq!(second.row.pose.q[1], 20f64.to_radians());
        assert!(s.next_pose().unwrap().is_none());
    }

    #[test]
    fn a_stream_reads_as_the_same_text_read_whole() {
        let text = "\u{feff}# controller log\r\npose,note_t,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\r\n\
                    \r\n4, 0.5 ,0,10,20,30,40,50,60\r\n# moving\r\n9,1.0,0.5,-10,0,15.5,0,-20,5\r\n";
        let whole = parse_listed(text).unwrap();
        // Split anywhere, even inside a line or the byte order mark.
        for cut in [1, 2, 30, 75, text.len() - 1] {
            let (a, b) = text.as_bytes().split_at(cut);
            let streamed = all(PoseStream::new(BufReader::new(chunks(&[a, b])), "x")).unwrap();
            assert_eq!(streamed, whole, "cut at {cut}");
        }
        assert_eq!(whole.iter().map(|p| p.line).collect::<Vec<_>>(), [4, 6]);
        // A line of spaces is no blank line to either.
        let spaces = text.replace("\r\n\r\n", "\r\n  \r\n");
        let e = all(stream(&[&spaces])).unwrap_err().report();
        let whole = parse_listed(&spaces).unwrap_err().to_string();
        assert!(
            e.ends_with(&whole) && whole.starts_with("line 3:"),
            "{e}\n{whole}"
        );
    }

    #[test]
    fn a_bad_record_names_the_stream_line_and_column() {
        let e = all(stream(&[
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n",
            "1,0,0,0,0,0,0\n",
            "2,0,0,abc,0,0,0\n",
        ]))
        .unwrap_err()
        .report();
        assert_eq!(
            e,
            "error: failed to parse `<stdin>`: line 3, column `q3_deg`: expected a joint \
             angle in degrees, found `abc`"
        );
        let e = all(stream(&[
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n",
            "1,0,0\n",
        ]))
        .unwrap_err()
        .report();
        assert!(e.contains("`<stdin>`: line 2") && e.contains("3"), "{e}");
        let e = all(stream(&["pose,q1_deg,q3_deg\n"])).unwrap_err().report();
        assert!(e.contains("line 1, column `q2_deg`"), "{e}");
        let e = all(stream(&[
            "# nothing yet\n",
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n",
        ]))
        .unwrap_err()
        .report();
        assert!(
            e.contains("line 2") && e.contains("at least one data row"),
            "{e}"
        );
        let e = all(stream(&[])).unwrap_err().report();
        assert!(e.contains("column `pose`"), "{e}");
        let e = all(stream(&[
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\r1,0,0,0,0,0,0\r1,5,0,0,0,0,0\r",
        ]))
        .unwrap_err()
        .report();
        assert!(e.contains("line 3, column `pose`"), "{e}");
        let e = all(stream(&[
            "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n",
            "1,0,0,0,0,0,\"42\n",
            "2,0,0,0,0,0,0\n",
        ]))
        .unwrap_err()
        .report();
        assert!(
            e.contains("line 2: a quoted cell is not closed on its line"),
            "{e}"
        );
    }
}
