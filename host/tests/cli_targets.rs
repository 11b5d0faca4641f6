//! Several targets per pose through the CLI: a measurement file with one row
//! per (pose, load, target), sorted by pose then target, exactly as
//! `docs/FORMATS.md` shows it, is read once by `identify` (its joint-limit
//! check included), with or without a pose list, with LF or CRLF line ends;
//! every message names the line it is about.

mod common;

use common::{lrmcal, p, text};

use std::path::{Path, PathBuf};

use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::predictions;

/// The bundled arm's tool point line, and the second target's place (m,
/// flange frame): 3 cm, -1 cm and 2 cm off the first.
const TOOL: &str = "xyz = [0.02, 0.0, 0.05]";
const SECOND_TOOL: &str = "xyz = [0.05, -0.01, 0.07]";

/// Every `STEP`-th candidate of `lrmcal plan` is measured: 41 poses spread
/// over the grid and the random poses.
const STEP: usize = 20;

/// Runs `lrmcal`, failing with what it printed unless it succeeds; its output.
fn ok(args: &[&str]) -> String {
    let run = lrmcal(args);
    assert!(run.status.success(), "lrmcal {args:?}:\n{}", text(&run));
    text(&run)
}

/// Runs `lrmcal` expecting a refusal of the input (exit code 3); its message.
fn refused(args: &[&str]) -> String {
    let run = lrmcal(args);
    assert_eq!(
        run.status.code(),
        Some(3),
        "lrmcal {args:?}:\n{}",
        text(&run)
    );
    String::from_utf8_lossy(&run.stderr).into_owned()
}

/// A simulated arm measured at two targets: `all.csv` (rows sorted by pose
/// then target, LF), the poses in `poses.csv`.
struct Measured {
    dir: tempfile::TempDir,
    /// The file's lines, header first.
    lines: Vec<String>,
}

impl Measured {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name);
        ok(&["plan", "--out", p(&path("candidates.csv"))]);
        let candidates = std::fs::read_to_string(path("candidates.csv")).unwrap();
        let lines: Vec<&str> = candidates.lines().collect();
        let every: Vec<&str> = std::iter::once(lines[0])
            .chain(lines[1..].iter().step_by(STEP).copied())
            .collect();
        std::fs::write(path("poses.csv"), every.join("\n") + "\n").unwrap();

        // The same true arm (same seed: the same drawn errors) seen at two
        // points of its flange.
        let bundled = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/lrm.toml"),
        )
        .unwrap();
        assert!(bundled.contains(TOOL));
        std::fs::write(path("second.toml"), bundled.replacen(TOOL, SECOND_TOOL, 1)).unwrap();
        let simulate = |arm: &str, out: &str| {
            ok(&[
                "simulate",
                "--arm",
                arm,
                "--poses",
                p(&path("poses.csv")),
                "--loads",
                "0",
                "--seed",
                "5",
                "--out",
                p(&path(out)),
            ]);
            std::fs::read_to_string(path(out)).unwrap()
        };
        let first = simulate("lrm", "first.csv");
        let second = simulate(p(&path("second.toml")), "second.csv");
        let (first, second): (Vec<&str>, Vec<&str>) =
            (first.lines().collect(), second.lines().collect());
        assert_eq!(first.len(), second.len());
        let mut out = vec![format!("{},target", first[0])];
        for (a, b) in first[1..].iter().zip(&second[1..]) {
            // The same pose, load and angles: only the positions differ.
            let head = |row: &str| row.split(',').take(8).collect::<Vec<_>>().join(",");
            assert_eq!(head(a), head(b));
            out.push(format!("{a},T1"));
            out.push(format!("{b},T2"));
        }
        let measured = Self { dir, lines: out };
        measured.write("all.csv", &measured.lines, "\n");
        measured
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Writes `lines` to `name` with line ends `ends`; its path.
    fn write(&self, name: &str, lines: &[String], ends: &str) -> PathBuf {
        let path = self.path(name);
        std::fs::write(&path, lines.join(ends) + ends).unwrap();
        path
    }

    /// `identify --option kinematic` on `measurements` with `extra`
    /// arguments, into the folder `out`; what it printed and the calibration.
    fn identify(
        &self,
        measurements: &Path,
        extra: &[&str],
        out: &str,
    ) -> (String, CalibrationFile) {
        let out = self.path(out);
        let mut args = vec![
            "identify",
            "--measurements",
            p(measurements),
            "--option",
            "kinematic",
            "--out",
            p(&out),
        ];
        args.extend_from_slice(extra);
        let printed = ok(&args);
        let cal = CalibrationFile::read(&out.join("calibration-kinematic.json")).unwrap();
        (printed, cal)
    }
}

#[test]
fn a_file_of_several_targets_calibrates_with_and_without_a_pose_list() {
    let m = Measured::new();
    let all = m.path("all.csv");
    assert_eq!(m.lines.len(), 1 + 2 * 41);

    // Every measured pose fitted.
    let (printed, cal) = m.identify(&all, &[], "every");
    let names: Vec<&str> = cal.targets.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["T1", "T2"], "{printed}");
    assert_eq!(cal.poses_used.len(), 41);
    assert!(
        printed.contains("T1") && printed.contains("T2"),
        "{printed}"
    );
    // The second target's place, found by the fit: 3, -1, 2 cm off the
    // first's, as simulated (the drawn tool error moves both alike).
    let offset: Vec<f64> = (0..3)
        .map(|i| cal.targets[1].tool_m[i] - cal.targets[0].tool_m[i])
        .collect();
    for (got, want) in offset.iter().zip([0.03, -0.01, 0.02]) {
        assert!((got - want).abs() < 3e-3, "{offset:?}\n{printed}");
    }

    // The first 30 poses of a plain pose list fitted, the others held out
    // (both targets' rows).
    let poses = std::fs::read_to_string(m.path("poses.csv")).unwrap();
    let train: Vec<&str> = poses.lines().take(31).collect();
    std::fs::write(m.path("train.csv"), train.join("\n") + "\n").unwrap();
    let (printed, cal) = m.identify(&all, &["--poses", p(&m.path("train.csv"))], "train");
    assert_eq!(cal.poses_used.len(), 30, "{printed}");
    let held = cal.validation.as_ref().expect("held-out poses");
    assert_eq!(held.before.count, 2 * 11, "{printed}");
    assert!(cal.targets.iter().all(|t| t.validation_after.is_some()));

    // The file itself as the pose list and as the candidates: its poses, each once.
    let (printed, cal) = m.identify(
        &all,
        &["--poses", p(&all), "--candidates", p(&all)],
        "itself",
    );
    assert_eq!(cal.poses_used.len(), 41, "{printed}");
    ok(&[
        "predict",
        "--poses",
        p(&all),
        "--out",
        p(&m.path("predicted.csv")),
    ]);
    assert_eq!(
        predictions::read(&m.path("predicted.csv")).unwrap().len(),
        41
    );
}

#[test]
fn a_crlf_copy_calibrates_exactly_as_the_lf_file() {
    let m = Measured::new();
    let crlf = m.write("all-crlf.csv", &m.lines, "\r\n");
    let (_, lf) = m.identify(&m.path("all.csv"), &[], "lf");
    let (_, windows) = m.identify(&crlf, &[], "crlf");
    assert_eq!(windows.to_json(), lf.to_json());
}

#[test]
fn rows_of_a_multi_target_file_are_named_by_their_own_line_with_either_line_ends() {
    let m = Measured::new();
    // A comment and an empty line after the header: the rows start on line 4.
    let mut lines = m.lines.clone();
    lines.insert(1, "# laser tracker, session 2".into());
    lines.insert(2, String::new());
    // The two rows of a pose a few rows down whose joint 3 stands at 100°
    // put it at 106°, a degree past its limit (the measured points barely
    // move: the fit uses them with --allow-outside-limits).
    let k = (3..41)
        .find(|k| lines[3 + 2 * k].split(',').nth(4) == Some("100"))
        .expect("a pose with joint 3 at 100°");
    let row = 4 + 2 * k;
    let pose = lines[row - 1].split(',').next().unwrap().to_owned();
    for i in [row - 1, row] {
        let mut cells: Vec<String> = lines[i].split(',').map(str::to_owned).collect();
        assert_eq!(cells[0], pose);
        cells[4] = "106".into();
        lines[i] = cells.join(",");
    }
    let cal = m.path("cal");
    for (name, ends) in [("outside.csv", "\n"), ("outside-crlf.csv", "\r\n")] {
        let file = m.write(name, &lines, ends);
        let args = [
            "identify",
            "--measurements",
            p(&file),
            "--option",
            "kinematic",
            "--out",
            p(&cal),
        ];
        let e = refused(&args);
        assert!(
            e.contains(&format!(
                "`{}`: line {row}, column `q3_deg`: pose {pose}: 106° is outside joint 3's limits",
                file.display()
            )),
            "{name}: {e}"
        );
        // Allowed: both targets' rows counted, the first named.
        let mut allowed = args.to_vec();
        allowed.push("--allow-outside-limits");
        let printed = ok(&allowed);
        assert!(
            printed.contains("warning: 2 of the 82 rows")
                && printed.contains(&format!("line {row}, column `q3_deg`")),
            "{name}: {printed}"
        );
        // predict reads the file as a pose list: the same line.
        let e = refused(&["predict", "--poses", p(&file)]);
        assert!(
            e.contains(&format!("line {row}, column `q3_deg`: pose {pose}: 106°")),
            "{name}: {e}"
        );
    }

    // A target measured twice at one pose: its second row and its first.
    let mut twice = m.lines.clone();
    twice[4] = twice[4].replace(",T2", ",T1");
    let first_pose = twice[3].split(',').next().unwrap().to_owned();
    let x = m.path("x");
    for (name, ends) in [("twice.csv", "\n"), ("twice-crlf.csv", "\r\n")] {
        let file = m.write(name, &twice, ends);
        for command in [
            vec!["identify", "--measurements", p(&file), "--out", p(&x)],
            vec!["predict", "--poses", p(&file)],
        ] {
            let e = refused(&command);
            assert!(
                e.contains(&format!(
                    "line 5, column `pose`: pose {first_pose} with load 0 kg already appears on line 4"
                )),
                "{name} {command:?}: {e}"
            );
        }
    }
}
