//! The examples of `docs/FORMATS.md` marked `<!-- checked: KIND -->` are valid
//! files of that kind, so a user who copies one gets a file `lrmcal` reads.

use host::io::{arm_toml, measurements, pose_list, predictions};
use host::plan::{PlanConfig, candidates};
use host::tracker::motive;

const FORMATS: &str = include_str!("../../docs/FORMATS.md");

/// The fenced block following each `<!-- checked: KIND -->` marker, as (kind, text).
fn checked_examples() -> Vec<(&'static str, String)> {
    let mut out = Vec::new();
    let mut lines = FORMATS.lines();
    while let Some(line) = lines.next() {
        let Some(kind) = line
            .trim()
            .strip_prefix("<!-- checked: ")
            .and_then(|rest| rest.strip_suffix(" -->"))
        else {
            continue;
        };
        let fence = lines.next().unwrap_or_default();
        assert!(
            fence.starts_with("```"),
            "no code block after the `{kind}` marker"
        );
        let body: Vec<&str> = lines.by_ref().take_while(|l| *l != "```").collect();
        out.push((kind, body.join("\n") + "\n"));
    }
    out
}

#[test]
fn every_checked_example_parses_as_its_kind() {
    let examples = checked_examples();
    let kinds: Vec<&str> = examples.iter().map(|(k, _)| *k).collect();
    assert_eq!(
        kinds,
        [
            "arm",
            "arm bodies",
            "measurements",
            "measurements",
            "pose list",
            "predictions",
            "motive take"
        ],
        "the examples the page is expected to carry"
    );
    for (kind, text) in &examples {
        let result = match *kind {
            "arm" => arm_toml::parse(text).map(|_| ()),
            "arm bodies" => arm_toml::parse(&format!("{}\n{text}", example("arm"))).map(|_| ()),
            "measurements" => measurements::parse(text).map(|_| ()),
            "pose list" => pose_list::parse(text).map(|_| ()),
            "predictions" => predictions::parse(text).map(|_| ()),
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
    let bundled = host::io::arm_source::bundled("lrm").unwrap();
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
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[0].pose, rows[1].pose);
    assert_eq!((rows[0].load_kg, rows[1].load_kg), (0.0, 0.0663));
    assert!((rows[0].position.x - 0.21241).abs() < 1e-12);
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
