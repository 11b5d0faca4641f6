//! What the CLI tests share: running the `lrmcal` binary built for them.

use std::process::{Command, Output};

/// Runs `lrmcal` with `args` and waits for it, its output captured.
pub fn lrmcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lrmcal"))
        .args(args)
        .output()
        .expect("lrmcal runs")
}
