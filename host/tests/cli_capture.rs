//! `lrmcal measure --capture`: a webcam as the frame source, injected as a
//! command that copies images the simulated webcam rendered. Each pose's
//! image is taken, checked for the board's tags and named in the pose list
//! `detect` reads; a frame without tags is taken again, then kept with a
//! warning; a command that fails stops the run naming the pose.

mod common;

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

use common::{lrmcal, p, text};

/// Runs `lrmcal measure` with `args`, Enter pressed at every pose.
fn measure(args: &[&str]) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lrmcal"))
        .arg("measure")
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all("\n".repeat(50).as_bytes())
        .unwrap();
    child.wait_with_output().unwrap()
}

/// Images of the bundled webcam setup rendered at a few seen poses: the
/// setup's folder and the rendered images' pose list.
fn rendered(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let setup = Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/lrm-webcam");
    let seen = dir.join("seen.csv");
    let run = lrmcal(&[
        "plan",
        "--camera",
        p(&setup.join("setup.toml")),
        "--random",
        "0",
        "--out",
        p(&seen),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    let few: String = std::fs::read_to_string(&seen)
        .unwrap()
        .lines()
        .take(4)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&seen, few).unwrap();
    let images = dir.join("rendered");
    let run = lrmcal(&[
        "simulate",
        "--camera",
        p(&setup.join("setup.toml")),
        "--poses",
        p(&seen),
        "--loads",
        "0",
        "--images",
        p(&images),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    (setup, images.join("poses.csv"))
}

#[test]
fn each_pose_gets_its_image_checked_for_tags_and_named_in_the_list() {
    let dir = tempfile::tempdir().unwrap();
    let (setup, list) = rendered(dir.path());
    let board = setup.join("board.yaml");
    let source = list.parent().unwrap();
    let shots = dir.path().join("shots");
    let out = dir.path().join("shots.csv");
    let copy = format!("cp {}/pose{{pose}}-{{load_kg}}kg.png {{image}}", p(source));
    let run = measure(&[
        "--poses",
        p(&list),
        "--capture",
        &copy,
        "--images",
        p(&shots),
        "--board",
        p(&board),
        "--out",
        p(&out),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    let named = std::fs::read_to_string(&out).unwrap();
    assert_eq!(
        named.lines().count(),
        std::fs::read_to_string(&list).unwrap().lines().count()
    );
    let views = dir.path().join("views.csv");
    let run = lrmcal(&[
        "detect",
        "--images",
        p(&shots),
        "--board",
        p(&board),
        "--poses",
        p(&out),
        "--out",
        p(&views),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    assert!(
        text(&run).contains("seen in 3 of 3 images"),
        "{}",
        text(&run)
    );

    // A frame that shows no tag is taken again, then kept with a warning.
    let blank = dir.path().join("blank.png");
    image::GrayImage::from_pixel(1280, 720, image::Luma([128]))
        .save(&blank)
        .unwrap();
    let again = dir.path().join("again.csv");
    let run = measure(&[
        "--poses",
        p(&list),
        "--capture",
        &format!("cp {} {{image}}", p(&blank)),
        "--images",
        p(&dir.path().join("blank")),
        "--board",
        p(&board),
        "--out",
        p(&again),
    ]);
    assert!(run.status.success(), "{}", text(&run));
    assert!(
        text(&run).contains("try 3 of 3), kept: check the focus and the light"),
        "{}",
        text(&run)
    );

    // A command that fails stops the run, naming the pose; the list holds what was taken.
    let failed = dir.path().join("failed.csv");
    let run = measure(&[
        "--poses",
        p(&list),
        "--capture",
        "false {image}",
        "--images",
        p(&dir.path().join("none")),
        "--out",
        p(&failed),
    ]);
    assert!(!run.status.success());
    assert!(
        text(&run).contains("take the image of pose"),
        "{}",
        text(&run)
    );
    assert!(!failed.exists());
}
