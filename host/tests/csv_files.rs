//! Measurement, pose-list and prediction CSV files: what readers accept, the
//! error (file, line, column, what was expected) for each kind of bad input,
//! unit conversion at the boundary, round trips and whole-or-nothing writes.

use std::f64::consts::PI;

use host::error::InputError;
use lrmcal_core::dataset::{Measurement, Pose, PoseRow, Prediction, from_home, visiting_order};
use lrmcal_core::io::{atomic, measurements, pose_list, predictions};
use nalgebra::Vector3;

const HEADER: &str = "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm";

/// The columns a measurement file's errors list: the joint angles as one
/// run, one per joint of the arm.
const EXPECTED: &str = "pose,load_kg,q1_deg..qn_deg (one per joint),x_mm,y_mm,z_mm,target";

/// A measurement file: header on line 1, then rows on lines 2, 3, ...
fn measurement_file(rows: &[&str]) -> String {
    format!("{HEADER}\n{}\n", rows.join("\n"))
}

const ROW_A: &str = "17,0.0663,-100,0,100,0,-100,0,212.41,-35.02,188.77";
const ROW_B: &str = "18,0,10,20,30,40,50,60,1,2,3";

fn measurement_err(text: &str) -> InputError {
    measurements::parse(text).expect_err("must be rejected")
}

/// Asserts the message names `line` and `column`, and contains each of `words`.
fn assert_names(err: &InputError, line: u64, column: Option<&str>, words: &[&str]) {
    let msg = err.to_string();
    assert_eq!(err.location.line, Some(line), "{msg}");
    assert!(msg.contains(&format!("line {line}")), "{msg}");
    if let Some(column) = column {
        assert!(
            msg.contains(&format!("column `{column}`")),
            "no column `{column}` in: {msg}"
        );
    }
    for w in words {
        assert!(msg.contains(w), "no `{w}` in: {msg}");
    }
}

#[test]
fn measurements_parse_in_si_units() {
    let rows = measurements::parse(&measurement_file(&[ROW_A, ROW_B])).unwrap();
    assert_eq!(rows.len(), 2);
    let m = &rows[0];
    assert_eq!(m.pose.id, 17);
    assert_eq!(m.load_kg, 0.0663);
    assert!((m.pose.q[0] + 100.0 * PI / 180.0).abs() < 1e-15);
    assert!((m.pose.q[2] - 100.0 * PI / 180.0).abs() < 1e-15);
    assert!((m.position - Vector3::new(0.21241, -0.03502, 0.18877)).norm() < 1e-15);
}

#[test]
fn readers_accept_comments_any_order_spaces_and_note_columns() {
    let text = "# exported by a tracker\n\
                note_time, z_mm, y_mm, x_mm, q6_deg, q5_deg, q4_deg, q3_deg, q2_deg, q1_deg, load_kg, pose\n\
                # warm-up done\n\
                12:00, 3, 2, 1, 60, 50, 40, 30, 20, 10, 0, 18\n\
                \n\
                12:01, 188.77, -35.02, 212.41, 0, -100, 0, 100, 0, -100, 0.0663, 17\n";
    let shuffled = measurements::parse(text).unwrap();
    let plain = measurements::parse(&measurement_file(&[ROW_B, ROW_A])).unwrap();
    assert_eq!(shuffled, plain);
}

#[test]
fn spreadsheet_exports_with_bom_and_crlf_are_read() {
    let text = format!("\u{feff}{HEADER}\r\n{ROW_A}\r\n{ROW_B}\r\n");
    let plain = measurements::parse(&measurement_file(&[ROW_A, ROW_B])).unwrap();
    assert_eq!(measurements::parse(&text).unwrap(), plain);
}

#[test]
fn line_numbers_count_comment_lines() {
    let text =
        format!("# one\n# two\n{HEADER}\n# three\n{ROW_A}\n17,0.0663,-100,0,abc,0,-100,0,1,2,3\n");
    let err = measurement_err(&text);
    assert_names(&err, 6, Some("q3_deg"), &["abc"]);
}

/// Every line error of a CSV file, with its line ends turned to `ends`.
fn errors_with_line_ends(lf: &str, ends: &str) -> Vec<String> {
    let text = lf.replace('\n', ends);
    let mut out = vec![measurement_err(&text).to_string()];
    out.push(pose_list::parse(&text).unwrap_err().to_string());
    out.push(predictions::parse(&text).unwrap_err().to_string());
    out
}

#[test]
fn crlf_and_lone_cr_line_ends_name_the_same_lines_as_lf() {
    // A comment, a blank line, then errors a few rows down: each reader's
    // message must name the same line (and the line of an earlier row) with
    // every kind of line end.
    let cases = [
        // A cell that is not a number, on line 6.
        format!("# session\n{HEADER}\n\n{ROW_A}\n{ROW_B}\n19,0,1,2,x,4,5,6,1,2,3\n"),
        // A pose repeated under the same load: line 6, first on line 4.
        format!("# session\n{HEADER}\n\n{ROW_A}\n{ROW_B}\n{ROW_A}\n"),
        // A row one cell short, on line 5.
        format!("{HEADER}\n# a\n{ROW_A}\n\n18,0,1,2,3\n"),
    ];
    for lf in &cases {
        let expected = errors_with_line_ends(lf, "\n");
        for ends in ["\r\n", "\r"] {
            assert_eq!(
                errors_with_line_ends(lf, ends),
                expected,
                "line ends {ends:?} of:\n{lf}"
            );
        }
    }
    let m = measurement_err(&cases[1]).to_string();
    assert!(
        m.starts_with("line 6, column `pose`") && m.contains("already appears on line 4"),
        "{m}"
    );
    assert_names(&measurement_err(&cases[0]), 6, Some("q3_deg"), &["`x`"]);
    assert_names(&measurement_err(&cases[2]), 5, None, &[]);
    // The header's line too, after comments and an empty line.
    let header = "# tracker\n\n# export\npose,load_kg\n1,0\n";
    for ends in ["\n", "\r\n"] {
        let e = measurement_err(&header.replace('\n', ends));
        assert_names(&e, 4, Some("q1_deg"), &["missing"]);
    }
}

#[test]
fn missing_column_lists_the_expected_ones() {
    let text =
        "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm\n1,0,0,0,0,0,0,0,1,2\n";
    let err = measurement_err(text);
    assert_names(
        &err,
        1,
        Some("z_mm"),
        &["missing from the header", EXPECTED],
    );
}

#[test]
fn unknown_column_is_rejected_with_the_expected_ones() {
    let text = format!("{HEADER},rms_mm\n{ROW_A},0.02\n");
    let err = measurement_err(&text);
    assert_names(&err, 1, Some("rms_mm"), &["unknown column", EXPECTED]);
    // A pose list ignores other columns, but a misspelt optional column
    // must not silently become load 0.
    let text = "pose,laod_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0.1,0,0,0,0,0,0\n";
    let err = pose_list::parse(text).unwrap_err();
    assert_names(
        &err,
        1,
        Some("laod_kg"),
        &["misspelt `load_kg`", "note_laod_kg"],
    );
}

#[test]
fn duplicate_column_is_rejected() {
    let text = format!("{HEADER},x_mm\n{ROW_A},1\n");
    assert_names(&measurement_err(&text), 1, Some("x_mm"), &["twice"]);
}

#[test]
fn non_numeric_cell_names_line_and_column() {
    let err = measurement_err(&measurement_file(&[
        ROW_B,
        "17,0.0663,-100,0,100,0,-100,0,212.41,n/a,188.77",
    ]));
    assert_names(
        &err,
        3,
        Some("y_mm"),
        &["expected a position in mm", "`n/a`"],
    );

    let err = measurement_err(&measurement_file(&["17.5,0,0,0,0,0,0,0,1,2,3"]));
    assert_names(&err, 2, Some("pose"), &["pose id", "17.5"]);

    let err = measurement_err(&measurement_file(&["17,0,0,0,,0,0,0,1,2,3"]));
    assert_names(&err, 2, Some("q3_deg"), &["joint angle in degrees"]);
}

#[test]
fn nan_and_infinite_cells_are_rejected() {
    let err = measurement_err(&measurement_file(&["17,0,0,NaN,0,0,0,0,1,2,3"]));
    assert_names(&err, 2, Some("q2_deg"), &["finite", "NaN"]);
    let err = measurement_err(&measurement_file(&[ROW_B, "17,0,0,0,0,0,0,0,1,2,-inf"]));
    assert_names(&err, 3, Some("z_mm"), &["finite"]);
}

#[test]
fn negative_load_is_rejected() {
    let err = measurement_err(&measurement_file(&["17,-0.1,0,0,0,0,0,0,1,2,3"]));
    assert_names(&err, 2, Some("load_kg"), &["load >= 0 kg", "-0.1"]);
}

#[test]
fn duplicate_pose_and_load_is_rejected() {
    let same_again = "17,0.0663,-100,0,100,0,-100,0,212.5,-35.0,188.7";
    let err = measurement_err(&measurement_file(&[ROW_A, ROW_B, same_again]));
    assert_names(&err, 4, Some("pose"), &["pose 17", "0.0663 kg", "line 2"]);
    // The same pose under another load is a new measurement.
    let other_load = "17,0,-100,0,100,0,-100,0,212.5,-35.0,188.7";
    assert_eq!(
        measurements::parse(&measurement_file(&[ROW_A, other_load]))
            .unwrap()
            .len(),
        2
    );
}

#[test]
fn one_pose_id_means_one_configuration() {
    let moved = "17,0,-100,0,99,0,-100,0,212.5,-35.0,188.7";
    let err = measurement_err(&measurement_file(&[ROW_A, moved]));
    assert_names(
        &err,
        3,
        Some("pose"),
        &["pose 17", "other joint angles", "line 2"],
    );
}

#[test]
fn wrong_field_count_names_the_line() {
    let err = measurement_err(&measurement_file(&[ROW_A, "18,0,10,20,30,40,50,60,1,2"]));
    assert_names(&err, 3, None, &["expected 11 fields", "found 10"]);
    let err = measurement_err(&measurement_file(&[
        ROW_A,
        "18,0,10,20,30,40,50,60,1,2,3,4",
    ]));
    assert_names(&err, 3, None, &["found 12"]);
}

#[test]
fn header_only_file_is_rejected() {
    let err = measurement_err(&format!("{HEADER}\n"));
    assert_names(&err, 1, None, &["at least one data row"]);
    assert!(measurements::parse("").is_err());
}

#[test]
fn read_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tracker_export.csv");
    std::fs::write(&path, measurement_file(&["17,0,0,x,0,0,0,0,1,2,3"])).unwrap();
    let err = measurements::read(&path).unwrap_err();
    assert!(!err.is_access());
    let msg = err.report();
    assert!(msg.starts_with("error: failed to parse `"), "{msg}");
    assert!(
        msg.contains("tracker_export.csv") && msg.contains("line 2, column `q2_deg`"),
        "{msg}"
    );
}

#[test]
fn pose_lists_have_optional_loads() {
    let without = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n2,90,0,0,0,0,0\n";
    let rows = pose_list::parse(without).unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1].load_kg, None);
    assert!((rows[1].pose.q[0] - PI / 2.0).abs() < 1e-15);

    let with = "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0,0\n1,0.0663,0,0,0,0,0,0\n";
    let rows = pose_list::parse(with).unwrap();
    assert_eq!(rows[1].load_kg, Some(0.0663));

    let twice = "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n1,0,0,0,0,0,0\n";
    let err = pose_list::parse(twice).unwrap_err();
    assert_names(&err, 3, Some("pose"), &["pose 1", "each pose id once"]);
}

#[test]
fn measurement_file_is_a_pose_list() {
    let rows = pose_list::parse(&measurement_file(&[ROW_A, ROW_B])).unwrap();
    let measured = measurements::parse(&measurement_file(&[ROW_A, ROW_B])).unwrap();
    assert_eq!(rows.len(), 2);
    for (row, m) in rows.iter().zip(&measured) {
        assert_eq!((row.pose, row.load_kg), (m.pose, Some(m.load_kg)));
    }
}

#[test]
fn predictions_parse_and_reject_repeated_ids() {
    let rows = predictions::parse("pose,x_mm,y_mm,z_mm\n3,1,2,3\n").unwrap();
    assert_eq!(
        rows,
        vec![Prediction {
            pose: 3,
            position: Vector3::new(0.001, 0.002, 0.003)
        }]
    );
    let err = predictions::parse("pose,x_mm,y_mm,z_mm\n3,1,2,3\n3,1,2,4\n").unwrap_err();
    assert_names(&err, 3, Some("pose"), &["line 2"]);
}

/// 20 rows visited in order (their approaches follow it).
fn sample_measurements() -> Vec<Measurement> {
    let mut rows: Vec<Measurement> = (0..20)
        .map(|i| {
            let f = i as f64;
            Measurement {
                pose: Pose {
                    id: i,
                    q: [0.1 * f, -0.05 * f, 1.2, -1.7, 0.3 + 0.01 * f, -0.123456789].into(),
                },
                load_kg: if i % 2 == 0 { 0.0 } else { 0.0663 },
                position: Vector3::new(0.2 + 0.001 * f, -0.035021, 0.1887654321),
                pixel: None,
                target: None,
                approach: from_home(6),
            }
        })
        .collect();
    visiting_order(&mut rows);
    rows
}

#[test]
fn measurements_round_trip_through_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.csv");
    let rows = sample_measurements();
    measurements::write(&path, &rows, &[model::JointKind::Revolute; 6]).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.lines().next(), Some(HEADER));
    let back = measurements::read(&path).unwrap();
    assert_eq!(back.len(), rows.len());
    for (a, b) in rows.iter().zip(&back) {
        assert_eq!((a.pose.id, a.load_kg), (b.pose.id, b.load_kg));
        // Files carry 1e-9 deg and 1e-6 mm.
        assert!(
            a.pose
                .q
                .iter()
                .zip(&b.pose.q)
                .all(|(x, y)| (x - y).abs() < 1e-10)
        );
        assert!((a.position - b.position).norm() < 1e-9);
        // The reader works out each joint's way in from the rows' order.
        assert_eq!(a.approach, b.approach);
    }
    // Joint 2 falls from pose 1 on; joint 1 rises throughout.
    assert_eq!(back[5].approach[0], model::backlash::Approach::Rising);
    assert_eq!(back[5].approach[1], model::backlash::Approach::Falling);
}

#[test]
fn pose_lists_and_predictions_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let poses: Vec<PoseRow> = sample_measurements()
        .iter()
        .map(|m| PoseRow {
            pose: m.pose,
            load_kg: None,
        })
        .collect();
    let path = dir.path().join("poses.csv");
    pose_list::write(&path, &poses, &[model::JointKind::Revolute; 6]).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        text.lines().next(),
        Some("pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg")
    );
    let back = pose_list::read(&path).unwrap();
    assert!(
        back.iter()
            .zip(&poses)
            .all(|(a, b)| a.pose.id == b.pose.id && a.load_kg.is_none())
    );

    let loaded: Vec<PoseRow> = poses
        .iter()
        .map(|p| PoseRow {
            load_kg: Some(0.0663),
            ..*p
        })
        .collect();
    pose_list::write(&path, &loaded, &[model::JointKind::Revolute; 6]).unwrap();
    assert!(
        std::fs::read_to_string(&path)
            .unwrap()
            .starts_with("pose,load_kg,q1_deg")
    );
    assert!(
        pose_list::read(&path)
            .unwrap()
            .iter()
            .all(|r| r.load_kg == Some(0.0663))
    );

    let preds: Vec<Prediction> = sample_measurements()
        .iter()
        .map(|m| Prediction {
            pose: m.pose.id,
            position: m.position,
        })
        .collect();
    let path = dir.path().join("pred.csv");
    predictions::write(&path, &preds).unwrap();
    assert!(
        std::fs::read_to_string(&path)
            .unwrap()
            .starts_with("pose,x_mm,y_mm,z_mm\n")
    );
    let back = predictions::read(&path).unwrap();
    assert!(
        back.iter()
            .zip(&preds)
            .all(|(a, b)| a.pose == b.pose && (a.position - b.position).norm() < 1e-9)
    );
}

#[test]
fn writers_print_plain_numbers() {
    let mut out = Vec::new();
    let p = Prediction {
        pose: 1,
        position: Vector3::new(-0.02 + 1e-17, 1e-17, 0.54),
    };
    predictions::write_to(&mut out, &[p]).unwrap();
    assert_eq!(
        String::from_utf8(out).unwrap(),
        "pose,x_mm,y_mm,z_mm\n1,-20,0,540\n"
    );
}

#[test]
fn failed_write_leaves_the_old_file_and_no_debris() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.csv");
    std::fs::write(&path, "old content").unwrap();
    let err = atomic::write(&path, |w| {
        w.write_all(b"half of the new")?;
        Err(std::io::Error::other("disk full"))
    })
    .unwrap_err();
    assert!(err.is_access());
    assert!(err.report().contains("out.csv") && err.report().contains("disk full"));
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "old content");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "a temporary file was left behind"
    );

    let nowhere = dir.path().join("no_such_dir").join("out.csv");
    assert!(predictions::write(&nowhere, &[]).is_err());
}

/// Outputs are created like ordinary files (0666 less the umask), not with the
/// temporary file's private 0600: a lab shares its calibrations.
#[cfg(unix)]
#[test]
fn written_files_get_the_mode_of_an_ordinary_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    let ordinary = dir.path().join("ordinary.csv");
    std::fs::write(&ordinary, "x").unwrap();
    let path = dir.path().join("out.csv");
    atomic::write(&path, |w| w.write_all(b"pose,x_mm,y_mm,z_mm\n")).unwrap();
    assert_eq!(mode(&path), mode(&ordinary), "mode {:o}", mode(&path));
}

/// The optional `target` column: rows of one pose per target, the names kept
/// through a round trip; a file without it has one unnamed target and keeps
/// its plain header; a bad name and a repeated (pose, load, target) are
/// refused with the line.
#[test]
fn measurements_name_their_targets_in_an_optional_column() {
    let mut rows = sample_measurements();
    let mut text = Vec::new();
    measurements::write_to(&mut text, &rows, &[model::JointKind::Revolute; 6]).unwrap();
    let text = String::from_utf8(text).unwrap();
    assert!(!text.contains("target"), "{text}");
    for (k, m) in rows.iter_mut().enumerate() {
        m.target = lrmcal_core::dataset::TargetName::from(["m0", "m30"][k % 2]).ok();
    }
    let mut named = Vec::new();
    measurements::write_to(&mut named, &rows, &[model::JointKind::Revolute; 6]).unwrap();
    let named = String::from_utf8(named).unwrap();
    assert!(
        named.lines().next().unwrap().ends_with(",target"),
        "{named}"
    );
    let back = measurements::parse(&named).unwrap();
    assert_eq!(back.len(), rows.len());
    assert_eq!(back[1].target.map(|t| t.to_string()), Some("m30".into()));
    let bad = named.replacen(",m30", ",m 30", 1);
    let e = measurements::parse(&bad).unwrap_err().to_string();
    assert!(e.contains("line 3") && e.contains("target name"), "{e}");
    let repeated = format!("{named}{}\n", named.lines().nth(2).unwrap());
    let e = measurements::parse(&repeated).unwrap_err().to_string();
    assert!(e.contains("pose"), "{e}");
}
