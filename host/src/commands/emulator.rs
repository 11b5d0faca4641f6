//! `lrmcal emulator`: the board without hardware. Runs the real firmware ELF in the rp2040js
//! emulator of the checkout (`tests/emulator`), serves the board's USB serial port on
//! `socket://127.0.0.1:PORT` for every device command, and keeps its flash in a file, until
//! Ctrl-C.
//!
//! Before the board starts, the command checks the user's files (flash image, `--elf`), then
//! what it needs from the machine, each with a message that says how to get it: Node, the
//! checkout, the firmware ELF (brought up to date with `cargo firmware`, which rebuilds
//! only what changed) and the emulator's one package (`npm ci` once).

use std::ffi::{OsStr, OsString};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::{Duration, Instant};

use crate::error::Error;

/// The emulator's entry script, relative to the checkout's root.
const HARNESS: &str = "tests/emulator/bin/lrm-emulator.js";
/// The emulator's folder (its `package.json`), relative to the checkout's root.
const EMULATOR_DIR: &str = "tests/emulator";
/// The oldest Node.js the emulator runs on (its `package.json`, `engines`).
const MIN_NODE_MAJOR: u32 = 18;
/// Size of a saved flash image: the board's whole 2 MiB flash chip (`memory.x`).
const FLASH_IMAGE_BYTES: u64 = 2 * 1024 * 1024;
/// How long the emulator may take to load the ELF and open its port.
const START_TIMEOUT: Duration = Duration::from_secs(60);
/// How long the emulator may take to save the flash and exit once asked to stop.
const STOP_TIMEOUT: Duration = Duration::from_secs(10);

/// Run the board's real firmware in an emulated RP2040 (no hardware needed).
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Run it from a checkout of lrmcal (it uses tests/emulator and the firmware \
build). Needs Node.js 18 or newer (or LRM_NODE naming it), and npm once, to install the \
emulator.\n\n\
Example:\n  lrmcal emulator --flash board.flash\n  \
# in another terminal:\n  export LRMCAL_PORT=socket://127.0.0.1:4040\n  lrmcal status\n\n\
Ctrl-C stops the board and saves its flash: a calibration pushed to it is there on the next \
start, as on a real board after a power cycle."
)]
pub struct Args {
    /// The board's flash (firmware and calibration) is kept in this file across runs; made
    /// when missing.
    #[arg(long, value_name = "FILE", default_value = "lrmcal-board.flash")]
    pub flash: PathBuf,
    /// TCP port on 127.0.0.1 for the board's serial port (0: any free port).
    #[arg(long, default_value_t = 4040)]
    pub port: u16,
    /// Firmware ELF to run instead of the checkout's `cargo firmware` build (never rebuilt).
    #[arg(long, value_name = "FILE")]
    pub elf: Option<PathBuf>,
}

/// An error that stops the emulated board from starting or running.
fn emulator_error(reason: impl Into<String>) -> Error {
    Error::Emulator {
        reason: reason.into(),
    }
}

/// Runs `lrmcal emulator`.
pub fn run(args: &Args) -> Result<(), Error> {
    let flash = std::path::absolute(&args.flash).map_err(|source| lrmcal_core::Error::Write {
        path: args.flash.clone(),
        source,
    })?;
    check_flash_file(&flash)?;
    if let Some(elf) = &args.elf {
        std::fs::metadata(elf).map_err(|source| lrmcal_core::Error::Read {
            path: elf.clone(),
            source,
        })?;
    }
    let node = std::env::var_os("LRM_NODE").unwrap_or_else(|| "node".into());
    check_node(&node)?;
    let root = checkout()?;
    let elf = match &args.elf {
        Some(elf) => elf.clone(),
        None => firmware_elf(&root)?,
    };
    install_emulator(&root)?;

    // The handler goes in before the board starts, so no Ctrl-C finds the default action
    // (which would end lrmcal and leave the board to notice its closed stdin on its own).
    let (stop_tx, stop) = mpsc::channel();
    ctrlc::set_handler(move || {
        let _ = stop_tx.send(());
    })
    .map_err(|e| emulator_error(format!("catch Ctrl-C: {e}")))?;

    let mut command = Command::new(&node);
    command
        .arg(root.join(HARNESS))
        .arg("--child")
        .args(["--port", &args.port.to_string()])
        .arg("--flash")
        .arg(&flash)
        .arg("--elf")
        .arg(&elf)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    // Its own process group: a Ctrl-C at the terminal then reaches lrmcal alone, which stops
    // the board in order (flash saved) instead of racing it.
    #[cfg(unix)]
    std::os::unix::process::CommandExt::process_group(&mut command, 0);
    let mut child = command
        .spawn()
        .map_err(|e| emulator_error(format!("start `{}`: {e}", node.display())))?;
    let port = match wait_for_port(&mut child) {
        Ok(port) => port,
        Err(e) => {
            let _ = child.kill();
            let _ = child.wait();
            return Err(e);
        }
    };

    let mut out = std::io::stdout().lock();
    let _ = writeln!(
        out,
        "emulated board running {}\nflash kept in {}\n\
         serial port socket://127.0.0.1:{port}, for every device command; in another terminal:\n  \
         export LRMCAL_PORT=socket://127.0.0.1:{port}\n  lrmcal status\n\
         Ctrl-C stops the board.",
        elf.display(),
        flash.display()
    );
    let _ = out.flush();
    drop(out);

    loop {
        match stop.recv_timeout(Duration::from_millis(100)) {
            Ok(()) => break,
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {}
        }
        let exited = child
            .try_wait()
            .map_err(|e| emulator_error(format!("watch the emulator: {e}")))?;
        if let Some(status) = exited {
            return Err(stopped_by_itself(status));
        }
    }
    stop_board(&mut child)?;
    println!("board stopped; flash saved in {}", flash.display());
    Ok(())
}

/// A flash file must be a whole flash image, and must be writable where it is named.
fn check_flash_file(flash: &Path) -> Result<(), Error> {
    match std::fs::metadata(flash) {
        Ok(meta) if meta.len() != FLASH_IMAGE_BYTES => Err(Error::FlashImage {
            path: flash.to_path_buf(),
            expected: FLASH_IMAGE_BYTES,
            found: meta.len(),
        }),
        Ok(_) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // The emulator writes it when it stops: its folder must be there.
            match flash.parent().map(std::fs::metadata) {
                Some(Ok(dir)) if dir.is_dir() => Ok(()),
                _ => Err(lrmcal_core::Error::Write {
                    path: flash.to_path_buf(),
                    source: std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        "its folder does not exist",
                    ),
                }
                .into()),
            }
        }
        Err(source) => Err(lrmcal_core::Error::Read {
            path: flash.to_path_buf(),
            source,
        }
        .into()),
    }
}

/// Node runs the emulator: it must start and be recent enough.
fn check_node(node: &OsStr) -> Result<(), Error> {
    let how = format!(
        "install Node.js {MIN_NODE_MAJOR} or newer (https://nodejs.org), or set LRM_NODE to its path"
    );
    let output = Command::new(node).arg("--version").output().map_err(|e| {
        emulator_error(format!(
            "the emulator runs on Node.js, and `{}` cannot be run ({e}): {how}",
            node.display()
        ))
    })?;
    let answer = String::from_utf8_lossy(&output.stdout);
    let version = answer.lines().next().unwrap_or_default().trim();
    match node_major(version) {
        Some(major) if output.status.success() && major >= MIN_NODE_MAJOR => Ok(()),
        _ => Err(emulator_error(format!(
            "the emulator needs Node.js {MIN_NODE_MAJOR} or newer, and `{} --version` says `{version}`: {how}",
            node.display()
        ))),
    }
}

/// The major version in `node --version`'s answer (`v20.11.1`).
fn node_major(version: &str) -> Option<u32> {
    version.strip_prefix('v')?.split('.').next()?.parse().ok()
}

/// The checkout's root, searched from the current directory up, then from the executable up
/// (a `cargo build` puts it in the checkout's `target/`).
fn checkout() -> Result<PathBuf, Error> {
    let mut starts = Vec::new();
    starts.extend(std::env::current_dir().ok());
    starts.extend(std::env::current_exe().ok());
    find_checkout(&starts).ok_or_else(|| {
        emulator_error(format!(
            "the emulator ({HARNESS}) is neither in the current directory or above it nor \
             above the lrmcal executable: run `lrmcal emulator` inside a checkout of lrmcal"
        ))
    })
}

/// The first of `starts` and their ancestors that holds the emulator.
pub fn find_checkout(starts: &[PathBuf]) -> Option<PathBuf> {
    starts
        .iter()
        .flat_map(|start| start.ancestors())
        .find(|dir| dir.join(HARNESS).is_file())
        .map(Path::to_path_buf)
}

/// The checkout's firmware ELF, brought up to date by `cargo firmware`
/// (cargo rebuilds only what changed since the last build, and knows what
/// the firmware is built from).
fn firmware_elf(root: &Path) -> Result<PathBuf, Error> {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(|dir| root.join(dir))
        .unwrap_or_else(|| root.join("target"));
    let elf = target.join("thumbv6m-none-eabi/release/firmware");
    build_firmware(root)?;
    if !elf.is_file() {
        return Err(emulator_error(format!(
            "`cargo firmware` left no ELF at {}: name one with --elf",
            elf.display()
        )));
    }
    Ok(elf)
}

/// Runs `cargo firmware` in the checkout, its output on the terminal.
fn build_firmware(root: &Path) -> Result<(), Error> {
    eprintln!(
        "bringing the firmware up to date with `cargo firmware` \
         (cargo build -p firmware --release --target thumbv6m-none-eabi)"
    );
    // `cargo run` says which cargo it is; that one matches the checkout's toolchain.
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| OsString::from("cargo"));
    let status = Command::new(&cargo)
        .arg("firmware")
        .current_dir(root)
        .status()
        .map_err(|e| {
            emulator_error(format!(
                "build the firmware: `{}` cannot be run ({e}); install Rust with rustup \
                 (https://rustup.rs), or build the ELF elsewhere and name it with --elf",
                cargo.display()
            ))
        })?;
    if !status.success() {
        return Err(emulator_error(format!(
            "build the firmware: `cargo firmware` failed ({status}); its messages are above"
        )));
    }
    Ok(())
}

/// Installs the emulator's package (rp2040js, pinned by its lock file) once.
fn install_emulator(root: &Path) -> Result<(), Error> {
    let dir = root.join(EMULATOR_DIR);
    if dir.join("node_modules/rp2040js").is_dir() {
        return Ok(());
    }
    eprintln!(
        "installing the emulator (rp2040js) once: npm ci in {}",
        dir.display()
    );
    let status = Command::new("npm")
        .args(["ci", "--no-audit", "--no-fund"])
        .current_dir(&dir)
        .status()
        .map_err(|e| {
            emulator_error(format!(
                "install the emulator: `npm` cannot be run ({e}); npm comes with Node.js \
                 (https://nodejs.org); or run `npm ci` in {} yourself",
                dir.display()
            ))
        })?;
    if !status.success() {
        return Err(emulator_error(format!(
            "install the emulator: `npm ci` in {} failed ({status}); its messages are above",
            dir.display()
        )));
    }
    Ok(())
}

/// The port the emulator announces on its stdout (`{"event":"listening","port":N}`).
fn wait_for_port(child: &mut Child) -> Result<u16, Error> {
    let stdout = child
        .stdout
        .take()
        .ok_or_else(|| emulator_error("read the emulator's output: no pipe"))?;
    let (tx, announced) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Some(port) = announced_port(&line) {
                let _ = tx.send(port);
            }
        }
    });
    let deadline = Instant::now() + START_TIMEOUT;
    loop {
        match announced.recv_timeout(Duration::from_millis(100)) {
            Ok(port) => return Ok(port),
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {}
        }
        if let Ok(Some(status)) = child.try_wait() {
            return Err(stopped_by_itself(status));
        }
        if Instant::now() > deadline {
            return Err(emulator_error(format!(
                "the emulator did not open its serial port within {} s",
                START_TIMEOUT.as_secs()
            )));
        }
    }
}

/// The port of an announce line, if `line` is one.
fn announced_port(line: &str) -> Option<u16> {
    let value: serde_json::Value = serde_json::from_str(line).ok()?;
    if value["event"] != "listening" {
        return None;
    }
    u16::try_from(value["port"].as_u64()?).ok()
}

/// The board ended without being asked to.
fn stopped_by_itself(status: ExitStatus) -> Error {
    emulator_error(format!(
        "the emulator stopped ({status}); its messages are above"
    ))
}

/// Asks the emulator to stop (it saves the flash and exits) by closing its stdin.
fn stop_board(child: &mut Child) -> Result<(), Error> {
    drop(child.stdin.take());
    let deadline = Instant::now() + STOP_TIMEOUT;
    loop {
        match child.try_wait() {
            Ok(Some(status)) if status.success() => return Ok(()),
            Ok(Some(status)) => return Err(stopped_by_itself(status)),
            Ok(None) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(emulator_error(format!(
                    "the emulator did not stop within {} s and was killed: its flash file may \
                     not hold the last changes",
                    STOP_TIMEOUT.as_secs()
                )));
            }
        }
    }
}

#[cfg(test)]
mod tests {

    use super::*;

    #[test]
    fn node_versions_are_read_from_the_banner() {
        assert_eq!(node_major("v20.11.1"), Some(20));
        assert_eq!(node_major("v18.0.0"), Some(18));
        assert_eq!(node_major("20.1.0"), None);
        assert_eq!(node_major(""), None);
    }

    #[test]
    fn the_port_comes_from_the_announce_line_only() {
        assert_eq!(
            announced_port(r#"{"event":"listening","port":4040}"#),
            Some(4040)
        );
        assert_eq!(announced_port(r#"{"event":"configured","port":1}"#), None);
        assert_eq!(
            announced_port(r#"{"event":"listening","port":70000}"#),
            None
        );
        assert_eq!(announced_port("serial port: socket://127.0.0.1:4040"), None);
    }

    #[test]
    fn the_checkout_is_found_from_below_it() {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
        let found = find_checkout(&[root.join("host/src/commands")]).expect("the checkout");
        assert!(found.join(HARNESS).is_file());
        assert_eq!(find_checkout(&[std::env::temp_dir()]), None);
    }

    #[test]
    fn a_flash_file_of_the_wrong_size_is_refused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let short = dir.path().join("short.flash");
        std::fs::write(&short, [0xFF; 100]).expect("write");
        let err = check_flash_file(&short).expect_err("a 100-byte image");
        assert!(err.to_string().contains("found 100 bytes"), "{err}");
        assert_eq!(err.exit_code(), crate::error::exit_codes::INVALID_INPUT);
        assert!(check_flash_file(&dir.path().join("new.flash")).is_ok());
        let nowhere = dir.path().join("no/such/folder/board.flash");
        let err = check_flash_file(&nowhere).expect_err("no folder");
        assert_eq!(err.exit_code(), crate::error::exit_codes::FILE_ACCESS);
    }
}
