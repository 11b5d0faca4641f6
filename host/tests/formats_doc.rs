//! The examples of `docs/FORMATS.md` marked `<!-- checked: KIND -->` are valid
//! files of that kind, so a user who copies one gets a file `lrmcal` reads:
//! each parses as its kind, and goes through every command that reads its
//! kind of file (the built binary, as a user runs it), with the options its
//! marker names for that command (`<!-- checked: KIND; COMMAND: OPTIONS; … -->`).
//! Every other code block of the page is marked abridged or as messages, so
//! none is left out unnoticed.

mod common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use common::{lrmcal, p, text};
use lrmcal_core::camera::{board, intrinsics_file, setup, views};
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::{arm_toml, measurements, pose_list, predictions};
use lrmcal_engine::plan::{PlanConfig, candidates};
use lrmcal_engine::tracker::{dtrack, motive};

const FORMATS: &str = include_str!("../../docs/FORMATS.md");

/// A `checked` example: its kind, the options its marker gives per command,
/// and its text.
struct Example {
    kind: &'static str,
    options: HashMap<&'static str, Vec<&'static str>>,
    text: String,
}

/// The marker before a code block: `checked`, with the example's kind and
/// options, or one of the marks of a block that is no file to check.
enum Marker {
    Checked(&'static str, HashMap<&'static str, Vec<&'static str>>),
    Abridged(&'static str),
    Messages,
}

/// The marker of a line, if it is one.
fn marker(line: &'static str) -> Option<Marker> {
    let inner = line.trim().strip_prefix("<!-- ")?.strip_suffix(" -->")?;
    if inner == "messages" {
        return Some(Marker::Messages);
    }
    if let Some(kind) = inner.strip_prefix("abridged: ") {
        return Some(Marker::Abridged(kind));
    }
    let mut parts = inner.strip_prefix("checked: ")?.split("; ");
    let kind = parts.next().unwrap_or_default();
    let options = parts
        .map(|part| {
            let (command, options) = part
                .split_once(": ")
                .unwrap_or_else(|| panic!("`{part}` in `{line}`: expected `COMMAND: OPTIONS`"));
            (command, options.split_whitespace().collect())
        })
        .collect();
    Some(Marker::Checked(kind, options))
}

/// Every code block of the page with its marker; a block without one fails.
fn blocks() -> Vec<(Marker, String)> {
    let mut out = Vec::new();
    let mut previous: Option<&'static str> = None;
    let mut lines = FORMATS.lines();
    while let Some(line) = lines.next() {
        if line.starts_with("```") {
            let mark = previous.and_then(marker).unwrap_or_else(|| {
                panic!(
                    "the code block `{line}` after `{}` in docs/FORMATS.md has no \
                     `<!-- checked: KIND -->`, `<!-- abridged: KIND -->` or `<!-- messages -->` \
                     marker on the line before it",
                    previous.unwrap_or_default()
                )
            });
            let body: Vec<&str> = lines.by_ref().take_while(|l| *l != "```").collect();
            out.push((mark, body.join("\n") + "\n"));
            previous = None;
            continue;
        }
        previous = Some(line);
    }
    out
}

/// The checked examples, in the page's order.
fn examples() -> Vec<Example> {
    blocks()
        .into_iter()
        .filter_map(|(mark, text)| match mark {
            Marker::Checked(kind, options) => Some(Example {
                kind,
                options,
                text,
            }),
            _ => None,
        })
        .collect()
}

/// The fenced block following each `<!-- checked: KIND -->` marker, as (kind, text).
fn checked_examples() -> Vec<(&'static str, String)> {
    examples().into_iter().map(|e| (e.kind, e.text)).collect()
}

#[test]
fn every_code_block_is_checked_or_marked_abridged_or_messages() {
    let marks: Vec<String> = blocks()
        .iter()
        .map(|(mark, _)| match mark {
            Marker::Checked(kind, _) => format!("checked {kind}"),
            Marker::Abridged(kind) => format!("abridged {kind}"),
            Marker::Messages => "messages".into(),
        })
        .collect();
    assert_eq!(
        marks,
        [
            "checked arm",
            "checked arm bodies",
            "checked measurements",
            "checked measurements",
            "checked pose list",
            "checked pose list",
            "checked joint stream",
            "checked predictions",
            "checked dtrack datagram",
            "messages",
            "messages",
            "checked motive take",
            "checked camera setup",
            "checked camera intrinsics",
            "checked board",
            "abridged detected corners",
            "checked camera measurements",
            "abridged calibration",
            "checked calibration",
            "abridged report",
            "abridged urdf",
        ],
        "the blocks the page is expected to carry"
    );
    // An abridged kind that a command reads has a complete example too.
    let kinds: Vec<&str> = examples().iter().map(|e| e.kind).collect();
    assert!(kinds.contains(&"calibration"));
}

#[test]
fn every_checked_example_parses_as_its_kind() {
    for Example { kind, text, .. } in &examples() {
        let result = match *kind {
            "arm" => arm_toml::parse(text).map(|_| ()),
            "arm bodies" => arm_toml::parse(&format!("{}\n{text}", example("arm"))).map(|_| ()),
            "measurements" => measurements::parse(text).map(|_| ()),
            "pose list" => pose_list::parse(text).map(|_| ()),
            "joint stream" => {
                // Read record by record, as `measure --joints -` reads it,
                // it is the same poses as the whole text.
                let mut stream = pose_list::PoseStream::new(text.as_bytes(), "<stdin>");
                let mut streamed = Vec::new();
                while let Some(pose) = stream.next_pose().unwrap_or_else(|e| {
                    panic!(
                        "the joint stream example is refused: {}\n{text}",
                        e.report()
                    )
                }) {
                    streamed.push(pose);
                }
                pose_list::parse_listed(text).map(|whole| assert_eq!(streamed, whole))
            }
            "predictions" => predictions::parse(text).map(|_| ()),
            "calibration" => CalibrationFile::parse(text).map(|_| ()),
            "camera setup" => setup::parse(text).map(|_| ()),
            "camera intrinsics" => intrinsics_file::parse(text).map(|_| ()),
            "board" => board::parse(text).map(|_| ()),
            "camera measurements" => views::parse(text).map(|_| ()),
            "dtrack datagram" => {
                let frame = dtrack::parse(text).unwrap_or_else(|e| {
                    panic!("the DTrack example of docs/FORMATS.md is refused: {e}\n{text}")
                });
                assert_eq!((frame.bodies.len(), frame.markers.len()), (1, 1));
                Ok(())
            }
            "motive take" => {
                let take = motive::parse(text, motive::Asset::RigidBody("Tool"));
                if let Err(e) = take {
                    panic!("the Motive example of docs/FORMATS.md is refused: {e}\n{text}");
                }
                Ok(())
            }
            other => panic!("unknown example kind `{other}`"),
        };
        if let Err(e) = result {
            panic!("the `{kind}` example of docs/FORMATS.md is refused: {e}\n{text}");
        }
    }
}

/// The text of the example of `kind`.
fn example(kind: &str) -> String {
    checked_examples()
        .into_iter()
        .find(|(k, _)| *k == kind)
        .map(|(_, text)| text)
        .unwrap_or_else(|| panic!("no `{kind}` example"))
}

#[test]
fn the_bodies_example_plans_like_the_skeleton() {
    let with = arm_toml::parse(&format!("{}\n{}", example("arm"), example("arm bodies"))).unwrap();
    assert_eq!(with.collision.bodies.len(), 5);
    let kept = |d: &arm_toml::ArmDescription| {
        let config = PlanConfig::for_arm(&d.arm, &d.collision).unwrap();
        candidates(&d.arm, &config).unwrap().kept
    };
    let without = arm_toml::parse(&example("arm")).unwrap();
    assert_eq!(kept(&with).len(), 405);
    assert_eq!(kept(&with), kept(&without));
}

#[test]
fn the_arm_example_is_the_bundled_arm() {
    let (_, text) = checked_examples()
        .into_iter()
        .find(|(k, _)| *k == "arm")
        .expect("an arm example");
    let example = arm_toml::parse(&text).unwrap();
    let bundled = lrmcal_core::io::arm_source::bundled("lrm").unwrap();
    assert_eq!(example.arm, bundled.arm);
    assert_eq!(example.joint_names, bundled.joint_names);
}

#[test]
fn the_measurement_example_holds_one_pose_under_two_loads() {
    let (_, text) = checked_examples()
        .into_iter()
        .find(|(k, _)| *k == "measurements")
        .expect("a measurement example");
    let rows = measurements::parse(&text).unwrap();
    assert_eq!(rows.len(), 4);
    assert_eq!(rows[0].pose, rows[1].pose);
    assert_eq!((rows[0].load_kg, rows[1].load_kg), (0.0, 0.0663));
    assert!((rows[0].position.x - 0.00574).abs() < 1e-12);
}

#[test]
fn the_motive_example_has_a_lost_frame_and_metres() {
    let (_, text) = checked_examples()
        .into_iter()
        .find(|(k, _)| *k == "motive take")
        .expect("a Motive take example");
    let take = motive::parse(&text, motive::Asset::RigidBody("Tool")).unwrap();
    assert_eq!(take.units, "Meters");
    let tracked: Vec<bool> = take.samples.iter().map(|s| s.position.is_some()).collect();
    assert_eq!(tracked, [true, true, false, true]);
    assert!((take.samples[0].position.unwrap().x - 0.212433).abs() < 1e-12);
}

/// The files every command test needs: each checked example written out,
/// and what a command needs beside it.
struct Workspace {
    dir: tempfile::TempDir,
    /// The first example of each kind, written out (the arm bodies appended
    /// to the arm, as the page says).
    first: HashMap<&'static str, PathBuf>,
}

impl Workspace {
    fn new(examples: &[Example]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let mut first = HashMap::new();
        for (i, e) in examples.iter().enumerate() {
            let path = dir
                .path()
                .join(format!("example-{i}.{}", extension(e.kind)));
            let text = match e.kind {
                "arm bodies" => format!("{}\n{}", example("arm"), e.text),
                _ => e.text.clone(),
            };
            std::fs::write(&path, text).unwrap();
            first.entry(e.kind).or_insert(path);
        }
        Self { dir, first }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// The first example of `kind`, as a file.
    fn example(&self, kind: &str) -> &Path {
        self.first
            .get(kind)
            .unwrap_or_else(|| panic!("no `{kind}` example"))
    }
}

/// The file name extension of an example of `kind`.
fn extension(kind: &str) -> &'static str {
    match kind {
        "arm" | "arm bodies" | "camera setup" => "toml",
        "camera intrinsics" | "board" => "yaml",
        "calibration" => "json",
        "dtrack datagram" => "txt",
        _ => "csv",
    }
}

/// Runs `lrmcal` with `args` on the example `file` of `kind`; fails, naming
/// the example and the command, unless it succeeds. What it printed.
fn accepted(kind: &str, file: &Path, args: &[&str]) -> String {
    let run = lrmcal(args);
    assert!(
        run.status.success(),
        "`lrmcal {}` refuses the `{kind}` example of docs/FORMATS.md ({}):\n{}\n{}",
        args.join(" "),
        file.display(),
        text(&run),
        std::fs::read_to_string(file).unwrap_or_default()
    );
    text(&run)
}

/// The commands that read an example of `kind` at `file`, each an argument
/// list; `out` names a new output path.
fn commands(
    w: &Workspace,
    kind: &str,
    file: &Path,
    out: &dyn Fn(&str) -> PathBuf,
) -> Vec<Vec<String>> {
    let s = |p: &Path| p.display().to_string();
    let poses = s(w.example("pose list"));
    let f = s(file);
    let list = |args: &[&str]| args.iter().map(|a| a.to_string()).collect::<Vec<_>>();
    match kind {
        "arm" => vec![
            list(&["plan", "--arm", &f, "--out", &s(&out("plan.csv"))]),
            list(&["predict", "--arm", &f, "--poses", &poses]),
            list(&[
                "simulate",
                "--arm",
                &f,
                "--poses",
                &poses,
                "--out",
                &s(&out("sim.csv")),
            ]),
            list(&[
                "export",
                "--urdf",
                "--arm",
                &f,
                "--out",
                &s(&out("arm.urdf")),
            ]),
        ],
        "arm bodies" => vec![list(&["plan", "--arm", &f, "--out", &s(&out("plan.csv"))])],
        // identify writes the calibration validate then checks the file with.
        "measurements" => vec![
            list(&["identify", "--measurements", &f, "--out", &s(&out("cal"))]),
            list(&[
                "validate",
                "--measurements",
                &f,
                "--calibration",
                &s(&out("cal")),
            ]),
            list(&["predict", "--poses", &f]),
        ],
        "pose list" => vec![
            list(&["simulate", "--poses", &f, "--out", &s(&out("sim.csv"))]),
            list(&["predict", "--poses", &f]),
            list(&[
                "select",
                "--candidates",
                &s(&w.path("candidates.csv")),
                "--evaluate",
                &f,
                "--compare-random",
                "0",
            ]),
        ],
        "calibration" => vec![
            list(&["predict", "--arm", &f, "--poses", &poses]),
            list(&[
                "validate",
                "--calibration",
                &f,
                "--measurements",
                &s(w.example("measurements")),
            ]),
            list(&["push", &f, "--dry-run"]),
            list(&[
                "export",
                "--urdf",
                "--calibration",
                &f,
                "--out",
                &s(&out("arm.urdf")),
            ]),
        ],
        "motive take" => vec![list(&[
            "import-tracker",
            "--motive",
            &f,
            "--poses",
            &s(&w.path("one-pose.csv")),
            "--out",
            &s(&out("measured.csv")),
        ])],
        "joint stream" => vec![list(&[
            "measure",
            "--joints",
            &f,
            "--tracker",
            &s(&w.path("points.txt")),
            "--out",
            &s(&out("measured.csv")),
        ])],
        // The setup names its intrinsics and board files: the page's examples,
        // beside it under those names.
        "camera setup" => {
            let setup = setup::parse(&std::fs::read_to_string(file).unwrap()).unwrap();
            let folder = file.parent().unwrap();
            for (kind, name) in [
                ("camera intrinsics", &setup.intrinsics),
                ("board", &setup.board),
            ] {
                std::fs::copy(w.example(kind), folder.join(name)).unwrap();
            }
            vec![list(&[
                "plan",
                "--camera",
                &f,
                "--out",
                &s(&out("plan.csv")),
            ])]
        }
        // Read through the camera setup that names them.
        "camera intrinsics" | "board" => vec![],
        // Read by people and scripts, and by `measure` from a live stream.
        "predictions" | "dtrack datagram" | "camera measurements" => vec![],
        other => panic!("no commands known for `{other}` examples"),
    }
}

/// The calibration file `identify` wrote into `dir`.
fn written_calibration(dir: &Path) -> PathBuf {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("calibration-")
        })
        .unwrap_or_else(|| panic!("no calibration file in {}", dir.display()))
}

#[test]
fn every_checked_example_goes_through_every_command_that_reads_its_kind() {
    let examples = examples();
    let w = Workspace::new(&examples);
    // What commands need beside an example: the planner's candidates (to
    // evaluate a pose list among), a one-pose list (a take's one hold) and
    // tracker positions (to measure a stream of joint angles with).
    let plan = lrmcal(&["plan", "--out", p(&w.path("candidates.csv"))]);
    assert!(plan.status.success(), "{}", text(&plan));
    let poses = std::fs::read_to_string(w.example("pose list")).unwrap();
    let one: Vec<&str> = poses.lines().take(2).collect();
    std::fs::write(w.path("one-pose.csv"), one.join("\n") + "\n").unwrap();
    // Tracker positions for a stream of joint angles, one a line.
    std::fs::write(w.path("points.txt"), "212.41 -35.02 188.77\n".repeat(20)).unwrap();

    let mut ran = Vec::new();
    for (i, e) in examples.iter().enumerate() {
        let file = w.path(&format!("example-{i}.{}", extension(e.kind)));
        let out = |name: &str| w.path(&format!("out-{i}-{name}"));
        let commands = commands(&w, e.kind, &file, &out);
        // Every command the marker gives options for reads this kind.
        for command in e.options.keys() {
            assert!(
                commands.iter().any(|c| c[0] == *command),
                "the marker of a `{}` example names `{command}`, which does not read it",
                e.kind
            );
        }
        for mut args in commands {
            let command = args[0].clone();
            let options = e.options.get(command.as_str()).cloned().unwrap_or_default();
            args.extend(options.iter().map(|o| o.to_string()));
            if options.contains(&"--tool-only") {
                // Re-teaching tool points keeps the arm of a calibration:
                // the page's complete one, which these measurements are of.
                args.extend(["--calibration".into(), p(w.example("calibration")).into()]);
            }
            if command == "validate" && e.kind == "measurements" {
                // The calibration identify wrote into its folder.
                let at = args.iter().position(|a| a == "--calibration").unwrap() + 1;
                args[at] = written_calibration(Path::new(&args[at]))
                    .display()
                    .to_string();
            }
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            accepted(e.kind, &file, &args);
            ran.push(format!("{} {command}", e.kind));
        }
    }
    ran.sort();
    ran.dedup();
    assert_eq!(
        ran,
        [
            "arm bodies plan",
            "arm export",
            "arm plan",
            "arm predict",
            "arm simulate",
            "calibration export",
            "calibration predict",
            "calibration push",
            "calibration validate",
            "camera setup plan",
            "joint stream measure",
            "measurements identify",
            "measurements predict",
            "measurements validate",
            "motive take import-tracker",
            "pose list predict",
            "pose list select",
            "pose list simulate",
        ]
    );
}

/// The predictions example is what `predict` writes for the pose list
/// example with the calibration example's arm, as the page says.
#[test]
fn the_predictions_example_is_the_calibration_example_predicting_the_pose_list() {
    let examples = examples();
    let w = Workspace::new(&examples);
    let out = w.path("predicted.csv");
    accepted(
        "calibration",
        w.example("calibration"),
        &[
            "predict",
            "--arm",
            p(w.example("calibration")),
            "--poses",
            p(w.example("pose list")),
            "--out",
            p(&out),
        ],
    );
    let written = predictions::read(&out).unwrap();
    let documented = predictions::parse(&example("predictions")).unwrap();
    assert_eq!(written.len(), documented.len());
    for (w, d) in written.iter().zip(&documented) {
        assert_eq!(w.pose, d.pose);
        assert!(
            (w.position - d.position).norm() < 1e-6,
            "pose {}: predict writes {:?} mm, the page says {:?} mm",
            w.pose,
            w.position * 1e3,
            d.position * 1e3
        );
    }
}
