//! What the CLI tests share: running the `lrmcal` binary built for them,
//! reading its output, naming paths on its command line. Each test crate
//! compiles this module for itself and uses part of it, hence the
//! `dead_code` allowances.

use std::path::Path;
use std::process::{Command, Output};

/// Runs `lrmcal` with `args` and waits for it, its output captured.
pub fn lrmcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lrmcal"))
        .args(args)
        .output()
        .expect("lrmcal runs")
}

/// What `out` printed, standard output then standard error.
#[allow(dead_code)]
pub fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// `path` as a command-line argument (the tests' paths are UTF-8).
#[allow(dead_code)]
pub fn p(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// The file `identify` writes for its default model option.
#[allow(dead_code)]
pub fn default_calibration_file() -> String {
    format!(
        "calibration-{}.json",
        lrmcal_engine::calib::parameters::option::DEFAULT.name()
    )
}
