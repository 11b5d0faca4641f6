//! `lrmcal flash`: put a firmware image on the board through the RP2040's
//! USB bootloader (a UF2 file copied to the RPI-RP2 drive).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::error::Error;
use lrmcal_engine::device::{Client, open};

/// Reboot the board into its USB bootloader and copy a UF2 image onto it.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal flash target/thumbv6m-none-eabi/release/firmware.uf2 --port /dev/ttyACM0\n  \
lrmcal flash firmware.uf2 --mount /media/me/RPI-RP2   # board already in bootloader mode\n\n\
Make the UF2 from the ELF with `cargo firmware && elf2uf2-rs \
target/thumbv6m-none-eabi/release/firmware firmware.uf2`. With a debug probe, \
`cargo firmware-run` flashes through probe-rs instead. The calibration lives in its own \
flash sectors and survives a firmware update of the same protocol version; after an update to \
a new version (`lrmcal status` shows it) the board starts without one: push it again.")]
pub struct Args {
    /// Firmware image, `.uf2`.
    pub image: PathBuf,
    /// The running board's serial port, to reboot it into the bootloader (omit if it
    /// is already there: hold BOOTSEL while plugging it in).
    #[arg(long, short, env = "LRMCAL_PORT")]
    pub port: Option<String>,
    /// Where the bootloader's drive is mounted [default: search /media, /run/media, /mnt].
    #[arg(long, value_name = "DIR")]
    pub mount: Option<PathBuf>,
    /// How long to wait for the drive to appear, s.
    #[arg(long, default_value_t = 20)]
    pub wait_s: u64,
}

/// The file the RP2040 bootloader's drive always holds.
const MARKER: &str = "INFO_UF2.TXT";

/// Mounted RPI-RP2 drives in the usual places.
fn find_drive() -> Option<PathBuf> {
    let roots = ["/media", "/run/media", "/mnt", "/Volumes"];
    let mut candidates = vec![];
    for root in roots {
        candidates.push(Path::new(root).join("RPI-RP2"));
        for entry in std::fs::read_dir(root).into_iter().flatten().flatten() {
            candidates.push(entry.path().join("RPI-RP2"));
        }
    }
    candidates.into_iter().find(|p| p.join(MARKER).is_file())
}

/// Runs `lrmcal flash`.
pub fn run(args: &Args) -> Result<(), Error> {
    let input = |reason: String| Error::DeviceInput {
        what: format!("flash `{}`", args.image.display()),
        reason,
    };
    if args.image.extension().and_then(|e| e.to_str()) != Some("uf2") {
        return Err(input(
            "expected a .uf2 image; convert the ELF with `elf2uf2-rs ELF OUT.uf2`, or flash the ELF \
             through a debug probe with `cargo firmware-run`"
                .into(),
        ));
    }
    let image = std::fs::read(&args.image).map_err(|source| lrmcal_core::Error::Read {
        path: args.image.clone(),
        source,
    })?;
    if let Some(port) = &args.port {
        let link = open(port).map_err(lrmcal_engine::device::ClientError::from)?;
        let mut client = Client::new(link, Duration::from_millis(500), 2);
        client.reboot_to_bootloader()?;
        println!("board is rebooting into its USB bootloader");
    }
    let deadline = Instant::now() + Duration::from_secs(args.wait_s);
    let drive = loop {
        let found = match &args.mount {
            Some(dir) => Some(dir.clone()).filter(|d| d.join(MARKER).is_file()),
            None => find_drive(),
        };
        if let Some(d) = found {
            break d;
        }
        if Instant::now() > deadline {
            return Err(input(format!(
                "no RPI-RP2 drive with {MARKER} appeared within {} s; mount it and pass --mount DIR",
                args.wait_s
            )));
        }
        std::thread::sleep(Duration::from_millis(250));
    };
    let target = drive.join("firmware.uf2");
    // The bootloader writes flash as blocks arrive and reboots after the last: a plain copy.
    std::fs::write(&target, &image).map_err(|source| lrmcal_core::Error::Write {
        path: target.clone(),
        source,
    })?;
    println!(
        "wrote {} bytes to {}; the board reboots into the new firmware",
        image.len(),
        target.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(image: PathBuf, mount: PathBuf) -> Args {
        Args {
            image,
            port: None,
            mount: Some(mount),
            wait_s: 0,
        }
    }

    #[test]
    fn copies_the_image_onto_the_bootloader_drive() {
        let dir = tempfile::tempdir().unwrap();
        let drive = dir.path().join("RPI-RP2");
        std::fs::create_dir(&drive).unwrap();
        std::fs::write(drive.join(MARKER), "UF2 Bootloader v3.0\n").unwrap();
        let image = dir.path().join("fw.uf2");
        std::fs::write(&image, [0x55u8; 1024]).unwrap();
        run(&args(image, drive.clone())).unwrap();
        assert_eq!(
            std::fs::read(drive.join("firmware.uf2")).unwrap(),
            vec![0x55u8; 1024]
        );
    }

    #[test]
    fn refuses_an_elf_and_a_missing_drive_with_the_way_forward() {
        let dir = tempfile::tempdir().unwrap();
        let elf = dir.path().join("firmware");
        std::fs::write(&elf, b"\x7fELF").unwrap();
        let err = run(&args(elf, dir.path().into())).unwrap_err();
        assert!(err.report().contains("elf2uf2-rs") && err.report().contains("cargo firmware-run"));
        let image = dir.path().join("fw.uf2");
        std::fs::write(&image, [0u8; 512]).unwrap();
        let err = run(&args(image, dir.path().join("nowhere"))).unwrap_err();
        assert!(
            err.report().contains("no RPI-RP2 drive"),
            "{}",
            err.report()
        );
    }
}
