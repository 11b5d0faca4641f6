//! The calibration's page through the `lrmcal` binary: `identify` writes
//! `report.html` beside `report.json`, every section and plot on it; `lrmcal
//! report DIR` builds the same page again from `report.json` alone; a
//! folder without a report, or with another kind of file in its place, is
//! refused naming the file and what was expected.

mod common;

use common::{lrmcal, p, text};

use host::error::exit_codes;
use host::report_page::{PAGE, SECTIONS};
use lrmcal_core::dataset::PoseRow;
use lrmcal_core::io::pose_list;

#[test]
fn identify_writes_the_page_and_report_builds_it_again() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);
    let (candidates, poses, meas, cal) = (
        path("candidates.csv"),
        path("poses.csv"),
        path("measured.csv"),
        path("cal"),
    );
    let run = |args: &[&str]| {
        let out = lrmcal(args);
        assert!(out.status.success(), "lrmcal {args:?}: {}", text(&out));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    run(&["plan", "--out", p(&candidates)]);
    let every_third: Vec<PoseRow> = pose_list::read(&candidates)
        .unwrap()
        .into_iter()
        .step_by(3)
        .collect();
    pose_list::write(&poses, &every_third, &[model::JointKind::Revolute; 6]).unwrap();
    run(&[
        "simulate",
        "--poses",
        p(&poses),
        "--loads",
        "0,0.0663",
        "--seed",
        "5",
        "--out",
        p(&meas),
    ]);
    let printed = run(&[
        "identify",
        "--measurements",
        p(&meas),
        "--load-kg",
        "0.0663",
        "--select",
        "40",
        "--starts",
        "2",
        "--option",
        "all",
        "--out",
        p(&cal),
    ]);
    let page = cal.join(PAGE);
    assert!(
        printed.contains(&format!("(the page: {})", page.display())),
        "{printed}"
    );
    let html = std::fs::read_to_string(&page).unwrap();
    for (id, _) in SECTIONS {
        assert!(
            html.contains(&format!("<section id=\"{id}\">")),
            "section {id}"
        );
    }
    // Three options, each with its parameters and its errors per pose (kinematic is
    // refused: its geometry alone predicts these poses worse than the arm placed);
    // ours with its model ladder and knots; the registration identify did.
    assert!(!cal.join("calibration-kinematic.json").exists());
    for i in 0..3 {
        assert!(
            html.contains(&format!("<table id=\"params-{i}\">")),
            "params-{i}"
        );
        assert!(
            html.contains(&format!("<figure id=\"fig-per-pose-{i}\">")),
            "per-pose {i}"
        );
    }
    for id in [
        "<figure id=\"fig-errors\">",
        "<figure id=\"fig-errors-cross-load\">",
        "<table id=\"model-2\">",
        "<table id=\"knots-2\">",
        "<table id=\"registration-table\">",
        "<li>Push calibration-",
    ] {
        assert!(html.contains(id), "{id}");
    }
    assert!(!html.contains("The arm was not registered"));
    assert!(!html.contains("http") && !html.contains("src="));

    // Built again from report.json alone: the same page, byte for byte.
    std::fs::remove_file(&page).unwrap();
    let printed = run(&["report", p(&cal)]);
    assert!(printed.contains(&page.display().to_string()), "{printed}");
    assert_eq!(std::fs::read_to_string(&page).unwrap(), html);

    // No report in the folder: refused, naming the file and what was expected.
    let out = lrmcal(&["report", p(dir.path())]);
    let message = text(&out);
    assert_eq!(
        out.status.code(),
        Some(i32::from(exit_codes::INVALID_INPUT)),
        "{message}"
    );
    assert!(
        message.contains(&format!("`{}` not found", path("report.json").display()))
            && message.contains("expected the report.json that `lrmcal identify`"),
        "{message}"
    );
    assert!(!path(PAGE).exists());

    // Another of our files under the report's name: refused by its schema, the page left as it was.
    let other = path("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::copy(
        cal.join("calibration-elastic.json"),
        other.join("report.json"),
    )
    .unwrap();
    let out = lrmcal(&["report", p(&other)]);
    let message = text(&out);
    assert_eq!(
        out.status.code(),
        Some(i32::from(exit_codes::INVALID_INPUT)),
        "{message}"
    );
    assert!(
        message.contains(&other.join("report.json").display().to_string())
            && message.contains("lrmcal-report")
            && message.contains("lrmcal-calibration"),
        "{message}"
    );
    assert!(!other.join(PAGE).exists());
}
