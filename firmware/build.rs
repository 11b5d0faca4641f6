//! Build script of the firmware package: linker setup for the RP2040 binary.
//!
//! The memory map lives once, in the workspace root's `memory.x`, beside
//! `.cargo/config.toml`, because it describes the board rather than this
//! crate's code. cortex-m-rt's `link.x` looks for `memory.x` on the linker
//! search path, and the root is not on it: so this script copies the file into
//! `OUT_DIR` and adds that directory to the search path.
//!
//! The link arguments apply only when building for the MCU (`target_os =
//! "none"`); on the host the same package builds its library and a host stub
//! of the binary, which must link as an ordinary program.

use std::{env, fs, path::PathBuf};

fn main() {
    let root_memory_x = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../memory.x");
    println!("cargo:rerun-if-changed={}", root_memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");

    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }

    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory_x = fs::read(&root_memory_x)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", root_memory_x.display()));
    fs::write(out.join("memory.x"), memory_x)
        .unwrap_or_else(|e| panic!("cannot write memory.x to {}: {e}", out.display()));
    println!("cargo:rustc-link-search={}", out.display());

    // cortex-m-rt's link.x (vector table, sections; includes memory.x),
    // embassy-rp's link-rp.x (places the boot2 block in BOOT2) and defmt's
    // defmt.x (the log's interned strings). --nmagic keeps sections unaligned
    // to pages so the image is not padded.
    for arg in ["--nmagic", "-Tlink.x", "-Tlink-rp.x", "-Tdefmt.x"] {
        println!("cargo:rustc-link-arg-bins={arg}");
    }
}
