//! A tool change: `identify --tool-only` re-teaches the tool point from a few
//! poses measured with the new tool, keeping the arm of the old calibration.

mod common;

use common::{default_calibration_file, lrmcal};

use std::path::Path;

use lrmcal_core::io::calibration_file::CalibrationFile;

fn s(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 temporary path")
}

/// Runs `lrmcal` and returns its standard output, failing on an error.
fn ok(args: &[&str]) -> String {
    let run = lrmcal(args);
    assert!(
        run.status.success(),
        "lrmcal {args:?}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    String::from_utf8_lossy(&run.stdout).into_owned()
}

/// The bundled arm's tool point, and the new tool's offset from it, m.
const OLD_TOOL: &str = "xyz = [0.02, 0.0, 0.05]";
const NEW_TOOL_OFFSET: [f64; 3] = [0.03, -0.01, 0.02];

#[test]
fn a_tool_change_re_teaches_the_tool_point_and_keeps_the_arm() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);

    // The first calibration, with the bundled tool.
    ok(&["plan", "--out", s(&path("candidates.csv"))]);
    ok(&[
        "simulate",
        "--poses",
        s(&path("candidates.csv")),
        "--loads",
        "0",
        "--seed",
        "3",
        "--out",
        s(&path("before.csv")),
    ]);
    ok(&[
        "identify",
        "--measurements",
        s(&path("before.csv")),
        "--select",
        "40",
        "--out",
        s(&path("cal")),
    ]);
    let old_file = path("cal").join(default_calibration_file());
    let old = CalibrationFile::read(&old_file).unwrap();

    // The same arm (same seed: the same drawn errors) with a new tool,
    // measured at eight poses only.
    let bundled =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("core/arms/lrm.toml"))
            .unwrap();
    assert!(bundled.contains(OLD_TOOL));
    let [dx, dy, dz] = NEW_TOOL_OFFSET;
    let new_tool = format!("xyz = [{:?}, {:?}, {:?}]", 0.02 + dx, dy, 0.05 + dz);
    std::fs::write(
        path("new-tool.toml"),
        bundled.replacen(OLD_TOOL, &new_tool, 1),
    )
    .unwrap();
    let candidates = std::fs::read_to_string(path("candidates.csv")).unwrap();
    let few: Vec<&str> = candidates.lines().take(9).collect();
    std::fs::write(path("few.csv"), few.join("\n") + "\n").unwrap();
    ok(&[
        "simulate",
        "--arm",
        s(&path("new-tool.toml")),
        "--poses",
        s(&path("few.csv")),
        "--loads",
        "0",
        "--seed",
        "3",
        "--out",
        s(&path("after.csv")),
    ]);

    let printed = ok(&[
        "identify",
        "--measurements",
        s(&path("after.csv")),
        "--calibration",
        s(&old_file),
        "--tool-only",
        "--out",
        s(&path("retaught")),
    ]);
    assert!(
        printed.contains("tool points re-taught from 8 measurements"),
        "{printed}"
    );
    let new = CalibrationFile::read(&path("retaught").join(default_calibration_file())).unwrap();

    // The arm is the old calibration's, joint by joint and base; only the tool moved.
    assert_eq!(new.arm.joints, old.arm.joints);
    assert_eq!(new.arm.base, old.arm.base);
    assert_eq!(new.nominal, old.nominal);
    let moved: Vec<f64> = (0..3)
        .map(|i| new.arm.tool.xyz[i] - old.arm.tool.xyz[i])
        .collect();
    for (m, want) in moved.iter().zip(NEW_TOOL_OFFSET) {
        assert!(
            (m - want).abs() < 1.5e-3,
            "the tool point moved by {moved:?} m, not {NEW_TOOL_OFFSET:?}\n{printed}"
        );
    }
}
