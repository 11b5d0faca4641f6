//! Every caller calibrates through the one run (`calib::run`): no production
//! file of the host's crates assembles a fit from its stages itself. The
//! compiler keeps the other crates out (`calibrate_blocks` is the engine's
//! own); this test keeps the engine's other rooms out, so the demo's
//! figures and a user's `identify` come from the same code by construction.

use std::path::{Path, PathBuf};

/// The `.rs` files under `dir`, recursively.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).expect("a source folder") {
        let path = entry.expect("a folder entry").path();
        if path.is_dir() {
            out.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
    out
}

/// The production files of the host's three crates that call `call`,
/// relative to the workspace's `host/` folder.
fn callers(call: &str) -> Vec<String> {
    let host = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    ["engine/src", "core/src", "src"]
        .iter()
        .flat_map(|dir| sources(&host.join(dir)))
        .filter(|path| {
            let text = std::fs::read_to_string(path).expect("a readable source");
            text.lines()
                .any(|l| l.contains(call) && !l.trim_start().starts_with("//"))
        })
        .map(|path| {
            path.strip_prefix(&host)
                .expect("under host/")
                .to_string_lossy()
                .replace('\\', "/")
        })
        .collect()
}

#[test]
fn only_the_run_assembles_a_fit() {
    let mut stages = callers("calibrate_blocks(");
    stages.sort();
    assert_eq!(
        stages,
        [
            "engine/src/calib/fit/pipeline.rs",
            "engine/src/calib/run.rs"
        ],
        "a fit assembled outside calib/run.rs (pipeline.rs defines it)"
    );
    let mut growers = callers("grow(");
    growers.sort();
    assert_eq!(
        growers,
        [
            "engine/src/calib/fit/grow.rs",
            "engine/src/calib/fit/pipeline.rs"
        ],
        "the fit's stages grown outside the run's pipeline"
    );
}
