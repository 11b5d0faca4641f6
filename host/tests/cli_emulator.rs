//! `lrmcal emulator` refusing to start, run as a user runs it: a missing Node.js, a flash file
//! that is not a flash image and a missing `--elf` each get a message that says what to do and
//! the exit code of the README's list, before anything is built, installed or started. (The
//! emulated board itself is tested in package e2e, feature `emulator`.)

use std::path::Path;
use std::process::{Command, Output};

fn emulator(args: &[&str], node: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lrmcal"))
        .arg("emulator")
        .args(args)
        .env("LRM_NODE", node)
        .output()
        .expect("lrmcal runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn s(path: &Path) -> &str {
    path.to_str().expect("UTF-8 temp path")
}

#[test]
fn a_missing_node_is_named_with_the_way_to_get_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    let flash = dir.path().join("board.flash");
    let out = emulator(&["--flash", s(&flash)], "/nonexistent/node");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(6), "{err}");
    assert!(
        err.contains("error: failed to run the emulated board")
            && err.contains("`/nonexistent/node` cannot be run")
            && err.contains("install Node.js 18 or newer")
            && err.contains("LRM_NODE"),
        "{err}"
    );
    assert!(out.stdout.is_empty(), "no port is announced");
    assert!(!flash.exists(), "no flash file is made");
}

#[cfg(unix)]
#[test]
fn a_program_that_is_not_node_is_refused() {
    // `true` runs, but it is not a Node.js the emulator can use.
    let out = emulator(&["--flash", "unused.flash"], "true");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(6), "{err}");
    assert!(
        err.contains("needs Node.js 18 or newer") && err.contains("`true --version` says `"),
        "{err}"
    );
}

#[test]
fn a_flash_file_of_another_size_is_invalid_input() {
    let dir = tempfile::tempdir().expect("temp dir");
    let flash = dir.path().join("notes.txt");
    std::fs::write(&flash, "not a flash image").expect("write");
    let out = emulator(&["--flash", s(&flash)], "/nonexistent/node");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("notes.txt")
            && err.contains("expected a 2097152-byte image of the flash chip, found 17 bytes"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&flash).expect("read"),
        "not a flash image",
        "the file is left alone"
    );
}

#[test]
fn a_missing_elf_is_a_file_access_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let flash = dir.path().join("board.flash");
    let elf = dir.path().join("firmware.elf");
    let out = emulator(
        &["--flash", s(&flash), "--elf", s(&elf)],
        "/nonexistent/node",
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(4), "{err}");
    assert!(
        err.contains("failed to read") && err.contains("firmware.elf"),
        "{err}"
    );
}
