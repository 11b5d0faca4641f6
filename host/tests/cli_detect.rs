//! `lrmcal detect`: a folder of rendered board images and one without tags
//! gives the CSV of every corner and names the empty image; a wrong image
//! size against the intrinsics, and a file that is not an image, are refused
//! by name, leaving no CSV behind. With `--poses`, the images a pose list
//! names become a camera measurement file in the list's order, the folder's
//! other images unread; a list without loads, or naming an image twice or
//! one not in the folder, is refused by its line.

mod common;
#[path = "common/tags.rs"]
mod tags;

use std::path::Path;

use common::{lrmcal, p, text};
use lrmcal_core::camera::views;
use tags::{HEIGHT, Truth, View, WIDTH, board, render};

/// [`tags::board`] as a Kalibr aprilgrid file.
const BOARD: &str = "target_type: 'aprilgrid'\ntagCols: 3\ntagRows: 2\ntagSize: 0.04\n\
tagSpacing: 0.3\nfirstId: 5\n";

/// ROS camera_info of a camera of `width` x `height` px without distortion.
fn camera_info(width: u32, height: u32) -> String {
    let (cx, cy) = (width / 2, height / 2);
    format!(
        "image_width: {width}\nimage_height: {height}\ncamera_name: webcam\n\
camera_matrix: {{rows: 3, cols: 3, data: [900.0, 0.0, {cx}, 0.0, 900.0, {cy}, 0.0, 0.0, 1.0]}}\n\
distortion_model: plumb_bob\n\
distortion_coefficients: {{rows: 1, cols: 5, data: [0.0, 0.0, 0.0, 0.0, 0.0]}}\n"
    )
}

/// Writes `pixels` (WIDTH x HEIGHT grey) as a PNG.
fn save(path: &Path, pixels: Vec<u8>) {
    image::GrayImage::from_raw(WIDTH, HEIGHT, pixels)
        .unwrap()
        .save(path)
        .unwrap();
}

/// A folder with two rendered boards (upright, turned by 90°) and a grey
/// gradient without tags; returns each board image's name and true corners.
fn folder(dir: &Path) -> Vec<(&'static str, Truth)> {
    let mut truths = Vec::new();
    for (name, roll_deg) in [("a_upright.png", 0.0), ("b_turned.png", 90.0)] {
        let view = View {
            roll_deg,
            tilt_deg: 0.0,
            distance_m: 0.8,
        };
        let image = render(&board(), view);
        save(&dir.join(name), image.pixels);
        truths.push((name, image.truth));
    }
    let gradient = (0..WIDTH * HEIGHT).map(|k| (k % WIDTH / 5) as u8).collect();
    save(&dir.join("c_blank.png"), gradient);
    std::fs::write(dir.join("notes.txt"), "not an image, not read").unwrap();
    truths
}

#[test]
fn every_corner_of_every_image_is_written_and_an_empty_image_named() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("shots");
    std::fs::create_dir(&images).unwrap();
    let truths = folder(&images);
    let board_file = dir.path().join("board.yaml");
    std::fs::write(&board_file, BOARD).unwrap();
    let camera = dir.path().join("camera_info.yaml");
    std::fs::write(&camera, camera_info(WIDTH, HEIGHT)).unwrap();
    let out = dir.path().join("corners.csv");
    let run = lrmcal(&[
        "detect",
        "--images",
        p(&images),
        "--board",
        p(&board_file),
        "--intrinsics",
        p(&camera),
        "--out",
        p(&out),
    ]);
    let said = text(&run);
    assert!(run.status.success(), "{said}");
    assert!(
        said.contains("c_blank.png: no tag of the board found"),
        "{said}"
    );
    assert!(
        said.contains("12 tags of the board seen in 2 of 3 images"),
        "{said}"
    );

    let mut csv = csv::Reader::from_path(&out).unwrap();
    let header: Vec<String> = csv.headers().unwrap().iter().map(str::to_owned).collect();
    assert_eq!(header, ["image", "tag", "corner", "u_px", "v_px"]);
    let rows: Vec<csv::StringRecord> = csv.records().map(Result::unwrap).collect();
    let expected: Vec<_> = truths
        .iter()
        .flat_map(|(name, tags)| {
            tags.iter().flat_map(move |(id, corners)| {
                corners
                    .iter()
                    .enumerate()
                    .map(move |(k, c)| (*name, *id, k, *c))
            })
        })
        .collect();
    assert_eq!(rows.len(), expected.len());
    for (row, (name, id, k, [u, v])) in rows.iter().zip(expected) {
        assert_eq!(&row[0], name);
        assert_eq!(row[1].parse::<u32>().unwrap(), id);
        assert_eq!(row[2].parse::<usize>().unwrap(), k);
        let (du, dv) = (
            row[3].parse::<f64>().unwrap() - u,
            row[4].parse::<f64>().unwrap() - v,
        );
        assert!(du.hypot(dv) < 0.5, "{row:?}: truth ({u}, {v})");
    }
}

#[test]
fn tags_off_the_board_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    folder(dir.path());
    let board_file = dir.path().join("board.yaml");
    // Ids 7 and 8 only: the other four of each board image are foreign.
    std::fs::write(
        &board_file,
        BOARD
            .replace("tagCols: 3", "tagCols: 2")
            .replace("tagRows: 2", "tagRows: 1")
            .replace("firstId: 5", "firstId: 7"),
    )
    .unwrap();
    let out = dir.path().join("corners.csv");
    let run = lrmcal(&[
        "detect",
        "--images",
        p(dir.path()),
        "--board",
        p(&board_file),
        "--out",
        p(&out),
    ]);
    let said = text(&run);
    assert!(run.status.success(), "{said}");
    assert!(
        said.contains("ignored 8 tags whose id is not on the board ("),
        "{said}"
    );
    let rows = csv::Reader::from_path(&out).unwrap().records().count();
    assert_eq!(rows, 2 * 2 * 4);
}

#[test]
fn a_wrong_size_or_a_file_that_is_no_image_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    folder(dir.path());
    let board_file = dir.path().join("board.yaml");
    std::fs::write(&board_file, BOARD).unwrap();
    let camera = dir.path().join("camera_info.yaml");
    std::fs::write(&camera, camera_info(640, 480)).unwrap();
    let out = dir.path().join("corners.csv");
    let detect = |extra: &[&str]| {
        let mut args = vec![
            "detect",
            "--images",
            p(dir.path()),
            "--board",
            p(&board_file),
            "--out",
            p(&out),
        ];
        args.extend(extra);
        lrmcal(&args)
    };
    let run = detect(&["--intrinsics", p(&camera)]);
    let said = text(&run);
    assert_eq!(run.status.code(), Some(3), "{said}");
    assert!(
        said.contains("a_upright.png") && said.contains("1280x720") && said.contains("640x480"),
        "{said}"
    );
    assert!(!out.exists());

    std::fs::write(dir.path().join("b_broken.jpg"), "not a JPEG").unwrap();
    let run = detect(&[]);
    let said = text(&run);
    assert_eq!(run.status.code(), Some(3), "{said}");
    assert!(
        said.contains("read the image") && said.contains("b_broken.jpg"),
        "{said}"
    );
    assert!(!out.exists());
}

/// The header of the tests' pose lists: a prismatic third joint, whose
/// `q3_mm` the camera measurements keep, and a column pose lists ignore.
const LIST_HEADER: &str = "pose,load_kg,q1_deg,q2_deg,q3_mm,q4_deg,q5_deg,q6_deg,image,note_t\n";

/// Runs `detect --poses list` over `images`, writing `out`.
fn detect_poses(images: &Path, board_file: &Path, list: &Path, out: &Path) -> std::process::Output {
    lrmcal(&[
        "detect",
        "--images",
        p(images),
        "--board",
        p(board_file),
        "--poses",
        p(list),
        "--out",
        p(out),
    ])
}

#[test]
fn listed_images_become_camera_measurements_in_the_lists_order() {
    let dir = tempfile::tempdir().unwrap();
    let images = dir.path().join("shots");
    std::fs::create_dir(&images).unwrap();
    let truths = folder(&images);
    // Not an image at all: were it read, detect would fail on it.
    std::fs::write(images.join("z_unlisted.png"), "not a PNG").unwrap();
    let board_file = dir.path().join("board.yaml");
    std::fs::write(&board_file, BOARD).unwrap();
    // Visited in another order than the names': pose 4 turned, then empty,
    // then pose 4 again under a load, upright.
    let list = dir.path().join("shots.csv");
    std::fs::write(
        &list,
        format!(
            "# session 1\n{LIST_HEADER}\
             4,0,10,-20,35.5,0,0,0,b_turned.png,1\n\
             9,0,0,0,0,0,0,0,c_blank.png,2\n\
             4,0.25,10,-20,35.5,0,0,0,a_upright.png,3\n"
        ),
    )
    .unwrap();
    let out = dir.path().join("views.csv");
    let run = detect_poses(&images, &board_file, &list, &out);
    let said = text(&run);
    assert!(run.status.success(), "{said}");
    assert!(
        said.contains("c_blank.png: no tag of the board found"),
        "{said}"
    );
    assert!(
        said.contains("12 tags of the board seen in 2 of 3 images"),
        "{said}"
    );
    assert!(
        said.contains("1 images of `") && said.contains("were not read"),
        "{said}"
    );

    let header = std::fs::read_to_string(&out).unwrap();
    assert!(
        header.starts_with(
            "pose,load_kg,q1_deg,q2_deg,q3_mm,q4_deg,q5_deg,q6_deg,tag,corner,u_px,v_px,image\n"
        ),
        "{header}"
    );
    let seen = views::read(&out).unwrap();
    let truth = |name: &str| &truths.iter().find(|(n, _)| *n == name).unwrap().1;
    let expected = [(4, 0.0, "b_turned.png"), (4, 0.25, "a_upright.png")];
    assert_eq!(seen.len(), expected.len());
    for (view, (pose, load_kg, image)) in seen.iter().zip(expected) {
        assert_eq!(
            (view.pose.id, view.load_kg, view.image.as_deref()),
            (pose, load_kg, Some(image))
        );
        let q = [
            10f64.to_radians(),
            -20f64.to_radians(),
            0.0355,
            0.0,
            0.0,
            0.0,
        ];
        assert!(
            view.pose
                .q
                .iter()
                .zip(q)
                .all(|(a, b)| (a - b).abs() < 1e-12),
            "{:?}",
            view.pose.q
        );
        let truth = truth(image);
        assert_eq!(view.tags.len(), truth.len(), "{image}");
        for tag in &view.tags {
            let (_, corners) = truth.iter().find(|(id, _)| *id == tag.id).unwrap();
            for ([u, v], [tu, tv]) in tag.corners_px.iter().zip(corners) {
                assert!(
                    (u - tu).hypot(v - tv) < 0.5,
                    "{image}, tag {}: ({u}, {v}), truth ({tu}, {tv})",
                    tag.id
                );
            }
        }
    }
}

#[test]
fn a_list_without_loads_or_naming_an_image_twice_or_not_there_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // Never read: every refusal comes before any image is opened.
    for name in ["a.png", "b.jpg"] {
        std::fs::write(dir.path().join(name), "not an image").unwrap();
    }
    let board_file = dir.path().join("board.yaml");
    std::fs::write(&board_file, BOARD).unwrap();
    let list = dir.path().join("shots.csv");
    let out = dir.path().join("views.csv");
    let refused = |list_text: &str| {
        std::fs::write(&list, list_text).unwrap();
        let run = detect_poses(dir.path(), &board_file, &list, &out);
        let said = text(&run);
        assert_eq!(run.status.code(), Some(3), "{said}");
        assert!(said.contains("shots.csv"), "{said}");
        assert!(!out.exists());
        said
    };
    let said = refused("pose,q1_deg,image\n1,0,a.png\n");
    assert!(
        said.contains("column `load_kg`") && said.contains("each image's load is needed"),
        "{said}"
    );
    let said = refused(&format!(
        "{LIST_HEADER}1,0,0,0,0,0,0,0,a.png,\n2,0,5,0,0,0,0,0,c.png,\n"
    ));
    assert!(
        said.contains("line 3, column `image`") && said.contains("`c.png` is not an image"),
        "{said}"
    );
    let said = refused(&format!(
        "{LIST_HEADER}1,0,0,0,0,0,0,0,a.png,\n2,0,5,0,0,0,0,0,b.jpg,\n3,0,9,0,0,0,0,0,a.png,\n"
    ));
    assert!(
        said.contains("line 4, column `image`") && said.contains("`a.png` is named on line 2"),
        "{said}"
    );
}

/// `print-board` writes the board file's grid as a page of its true size;
/// a board file that is not one is refused by name, nothing written.
#[test]
fn the_board_prints_at_its_true_size() {
    let dir = tempfile::tempdir().unwrap();
    let board_file = dir.path().join("board.yaml");
    std::fs::write(&board_file, BOARD).unwrap();
    let page = dir.path().join("board.svg");
    let run = lrmcal(&["print-board", "--board", p(&board_file), "--out", p(&page)]);
    assert!(run.status.success(), "{}", text(&run));
    let svg = std::fs::read_to_string(&page).unwrap();
    // 3 × 2 tags of 40 mm every 52 mm: 144 × 92 mm, 20 mm of white around.
    assert!(svg.contains(r#"width="184.000mm""#), "{}", &svg[..120]);
    assert_eq!(svg.matches("<!-- tag ").count(), 6);

    std::fs::write(&board_file, "target_type: 'checkerboard'\n").unwrap();
    let other = dir.path().join("other.svg");
    let run = lrmcal(&["print-board", "--board", p(&board_file), "--out", p(&other)]);
    assert_eq!(run.status.code(), Some(3), "{}", text(&run));
    assert!(text(&run).contains("board.yaml"), "{}", text(&run));
    assert!(!other.exists());
}
