//! `lrmcal measure --capture`: a webcam as the frame source, injected as a
//! command that copies images the simulated webcam rendered. Each pose's
//! image is taken, checked for the board's tags and named in the pose list
//! `detect` reads; a frame without tags is taken again, then kept with a
//! warning; a command that fails stops the run naming the pose. Of several
//! frames a pose the sharpest still one is kept and the others deleted; a
//! scene that moves between frames is taken again, and a kept image far
//! blurrier than the run's others is warned of. A webcam read directly
//! that cannot be opened is named, and nothing is written.

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use image::GrayImage;

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

/// The rendered images of the pose list `list`, grey, by pose id in the
/// list's order.
fn rendered_images(list: &Path) -> Vec<(u32, GrayImage)> {
    std::fs::read_to_string(list)
        .unwrap()
        .lines()
        .skip(1)
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            let image = list.parent().unwrap().join(fields[fields.len() - 1]);
            (
                fields[0].parse().unwrap(),
                image::open(image).unwrap().into_luma8(),
            )
        })
        .collect()
}

/// A frame source in `dir` for `--capture`: a script that copies pose
/// `{pose}`'s frames `dir/pose<id>/1.png`, `2.png`, ... in turn into
/// `{image}`, counting them in `dir/pose<id>/taken`, and fails once they run
/// out; and the command that runs it.
fn frame_source(dir: &Path) -> String {
    std::fs::create_dir_all(dir).unwrap();
    let script = dir.join("frames.sh");
    std::fs::write(
        &script,
        "d=\"$(dirname \"$0\")/pose$1\"\n\
         n=$(( $(cat \"$d/taken\" 2>/dev/null || echo 0) + 1 ))\n\
         echo \"$n\" > \"$d/taken\"\n\
         cp \"$d/$n.png\" \"$2\"\n",
    )
    .unwrap();
    format!("sh {} {{pose}} {{image}}", p(&script))
}

/// Gives pose `pose` of the frame source in `dir` the frames `frames`, in
/// order; their files.
fn give_frames(dir: &Path, pose: u32, frames: &[&GrayImage]) -> Vec<PathBuf> {
    let folder = dir.join(format!("pose{pose}"));
    std::fs::create_dir_all(&folder).unwrap();
    frames
        .iter()
        .enumerate()
        .map(|(i, frame)| {
            let path = folder.join(format!("{}.png", i + 1));
            frame.save(&path).unwrap();
            path
        })
        .collect()
}

/// How many frames pose `pose` took from the frame source in `dir`.
fn frames_taken(dir: &Path, pose: u32) -> usize {
    std::fs::read_to_string(dir.join(format!("pose{pose}/taken")))
        .unwrap()
        .trim()
        .parse()
        .unwrap()
}

/// `frame` moved `px` pixels to the right (its left column repeated).
fn shifted(frame: &GrayImage, px: u32) -> GrayImage {
    GrayImage::from_fn(frame.width(), frame.height(), |x, y| {
        *frame.get_pixel(x.saturating_sub(px), y)
    })
}

/// The files in `dir`, by name, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

#[test]
fn the_sharpest_of_still_frames_is_kept_and_a_moving_scene_taken_again() {
    let dir = tempfile::tempdir().unwrap();
    let (_, list) = rendered(dir.path());
    let images = rendered_images(&list);
    let [(sharp, a), (moving, b), (restless, c)] = &images[..] else {
        panic!("three rendered poses, not {}", images.len());
    };
    let source = dir.path().join("frames");
    let command = frame_source(&source);
    // Frames of a still scene, the middle one sharp, the others blurred.
    let blurred = image::imageops::blur(a, 1.0);
    let kept_sharp = give_frames(&source, *sharp, &[&blurred, a, &blurred])[1].clone();
    // The arm sways through the first two frames, then holds still.
    let kept_still = give_frames(
        &source,
        *moving,
        &[&shifted(b, 12), &shifted(b, 6), b, b, b],
    )[2]
    .clone();
    // A scene that never holds still.
    let c_moved = shifted(c, 6);
    give_frames(&source, *restless, &[c, &c_moved, c, &c_moved, c, &c_moved]);
    let shots = dir.path().join("shots");
    let out = dir.path().join("shots.csv");
    let run = measure(&[
        "--poses",
        p(&list),
        "--capture",
        &command,
        "--images",
        p(&shots),
        "--out",
        p(&out),
    ]);
    let said = text(&run);
    assert!(run.status.success(), "{said}");
    let image = |pose: &u32| shots.join(format!("pose{pose}-0kg.png"));
    assert_eq!(frames_taken(&source, *sharp), 3);
    assert_eq!(
        std::fs::read(image(sharp)).unwrap(),
        std::fs::read(&kept_sharp).unwrap(),
        "the sharp frame is kept: {said}"
    );
    assert!(!said.contains(&format!("pose {sharp}: the arm")), "{said}");
    assert_eq!(frames_taken(&source, *moving), 5, "{said}");
    for frame in [2, 3] {
        assert!(
            said.contains(&format!(
                "pose {moving}: the arm was still moving (frame {frame} differs from the one before"
            )),
            "{said}"
        );
    }
    assert!(said.contains("taking another frame"), "{said}");
    assert_eq!(
        std::fs::read(image(moving)).unwrap(),
        std::fs::read(&kept_still).unwrap(),
        "a frame of the still stretch is kept: {said}"
    );
    assert_eq!(frames_taken(&source, *restless), 6, "{said}");
    assert!(
        said.contains(&format!(
            "pose {restless}: the arm was still moving after 6 frames; kept the sharpest of the last 1"
        )),
        "{said}"
    );
    // Only the kept images are left, each named in the list.
    assert_eq!(
        files(&shots),
        images
            .iter()
            .map(|(pose, _)| format!("pose{pose}-0kg.png"))
            .collect::<Vec<_>>()
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap().lines().count(), 4);

    // A frame that fails stops the run and leaves no frame behind.
    let failing = dir.path().join("failing");
    let command = frame_source(&failing);
    give_frames(&failing, *sharp, &[a]);
    let shots = dir.path().join("failed-shots");
    let out = dir.path().join("failed.csv");
    let run = measure(&[
        "--poses",
        p(&list),
        "--capture",
        &command,
        "--images",
        p(&shots),
        "--out",
        p(&out),
    ]);
    assert!(!run.status.success(), "{}", text(&run));
    assert!(
        text(&run).contains(&format!("take the image of pose {sharp}")),
        "{}",
        text(&run)
    );
    assert_eq!(files(&shots), Vec::<String>::new());
    assert!(!out.exists());
}

#[test]
fn a_pose_far_blurrier_than_the_others_is_warned_of() {
    let dir = tempfile::tempdir().unwrap();
    let (_, list) = rendered(dir.path());
    let images = rendered_images(&list);
    let source = dir.path().join("frames");
    let command = frame_source(&source);
    for (pose, frame) in &images {
        give_frames(&source, *pose, &[frame, frame, frame]);
    }
    // One more pose, after the sharp ones, at the first one's angles, whose
    // every frame is the first one's image blurred.
    let blurred_pose = images.iter().map(|(pose, _)| pose).max().unwrap() + 1;
    let blurred = image::imageops::blur(&images[0].1, 2.0);
    give_frames(&source, blurred_pose, &[&blurred, &blurred, &blurred]);
    let listed = std::fs::read_to_string(&list).unwrap();
    let mut row: Vec<&str> = listed.lines().nth(1).unwrap().split(',').collect();
    let (id, name) = (
        blurred_pose.to_string(),
        format!("pose{blurred_pose}-0kg.png"),
    );
    row[0] = &id;
    *row.last_mut().unwrap() = &name;
    let poses = dir.path().join("poses.csv");
    std::fs::write(&poses, format!("{listed}{}\n", row.join(","))).unwrap();
    let shots = dir.path().join("shots");
    let run = measure(&[
        "--poses",
        p(&poses),
        "--capture",
        &command,
        "--images",
        p(&shots),
        "--out",
        p(&dir.path().join("shots.csv")),
    ]);
    let said = text(&run);
    assert!(run.status.success(), "{said}");
    assert!(
        said.contains(&format!(
            "pose {blurred_pose}: {} is blurred",
            p(&shots.join(format!("pose{blurred_pose}-0kg.png")))
        )),
        "{said}"
    );
    assert_eq!(said.matches("is blurred").count(), 1, "{said}");
    assert!(!said.contains("still moving"), "{said}");
}

#[test]
fn a_webcam_that_cannot_be_read_is_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let list = dir.path().join("poses.csv");
    std::fs::write(
        &list,
        "pose,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,0,0,0,0,0,0\n",
    )
    .unwrap();
    let (shots, out) = (dir.path().join("shots"), dir.path().join("shots.csv"));
    for device in ["/nonexistent/video9", "/dev/null"] {
        let run = lrmcal(&[
            "measure",
            "--poses",
            p(&list),
            "--webcam",
            device,
            "--images",
            p(&shots),
            "--out",
            p(&out),
        ]);
        let said = text(&run);
        assert_eq!(run.status.code(), Some(6), "{said}");
        assert!(
            said.contains(&format!("read the webcam {device}")),
            "{said}"
        );
        assert!(!shots.exists() && !out.exists(), "{said}");
    }
    // A size that is no size is refused before any device is opened.
    let run = lrmcal(&[
        "measure",
        "--poses",
        p(&list),
        "--webcam",
        "/dev/video0",
        "--webcam-size",
        "1280",
        "--images",
        p(&shots),
        "--out",
        p(&out),
    ]);
    assert!(
        text(&run).contains("expected WIDTHxHEIGHT"),
        "{}",
        text(&run)
    );
}
