//! The two calibration slots at the end of flash, through embassy-rp's flash driver.
//!
//! Where the slots are is said once, in the root `memory.x` (region `CALIB`,
//! exported as `__calib_start` / `__calib_end`); this driver takes the
//! addresses from those linker symbols, so the program and the slots can
//! never overlap by a mismatch of constants.
//!
//! Erase and program run from RAM with interrupts off while the flash is out
//! of XIP mode (embassy-rp does that): the CPU stalls for the erase of one
//! 4 KiB sector (about 50 ms, at most 400 ms on a W25Q16). The PWM keeps
//! sending the last pulses meanwhile, so the servos hold.

use embassy_rp::Peri;
use embassy_rp::flash::{Blocking, ERASE_SIZE, Error, Flash};
use embassy_rp::peripherals::FLASH;
use firmware::FlashStorage;

use crate::layout::{FLASH_SIZE, SECTOR, SLOT_LEN, calib_region, slot_offset};

// The layout's sector is the driver's erase unit.
const _: () = assert!(SECTOR == ERASE_SIZE);

// The only way to learn where the linker put a region. The statics are
// declared `safe`: only their addresses are taken, never their bytes read.
#[allow(unsafe_code)]
unsafe extern "C" {
    /// First byte of the `CALIB` region (memory.x).
    safe static __calib_start: u8;
    /// One past the last byte of the `CALIB` region (memory.x).
    safe static __calib_end: u8;
}

/// The calibration slots, implementing the library's [`FlashStorage`].
pub struct CalibrationFlash {
    flash: Flash<'static, FLASH, Blocking, FLASH_SIZE>,
    /// Offset of slot 0 from the start of flash.
    base: u32,
}

impl CalibrationFlash {
    /// Takes the flash. Panics if memory.x does not reserve two sector-aligned
    /// slots at the end of flash: a build bug, caught at the first boot.
    pub fn new(flash: Peri<'static, FLASH>) -> Self {
        let start = &raw const __calib_start as usize;
        let end = &raw const __calib_end as usize;
        let Some((base, _)) = calib_region(start, end) else {
            defmt::panic!(
                "memory.x: CALIB region {=usize:#x}..{=usize:#x} is not 2 x 4 KiB slots",
                start,
                end
            );
        };
        defmt::info!(
            "calibration slots at flash offset {=u32:#x}, 2 x {} bytes",
            base,
            SLOT_LEN
        );
        Self {
            flash: Flash::new_blocking(flash),
            base,
        }
    }

    /// Flash offset of byte `offset` of `slot`, if `len` bytes from there stay inside the slot.
    fn offset(&self, slot: u8, offset: usize, len: usize) -> Result<u32, Error> {
        slot_offset(self.base, slot, offset, len).ok_or(Error::OutOfBounds)
    }
}

impl FlashStorage for CalibrationFlash {
    type Error = Error;

    fn slot_size(&self) -> usize {
        SLOT_LEN
    }

    fn read(&mut self, slot: u8, offset: usize, buf: &mut [u8]) -> Result<(), Error> {
        let at = self.offset(slot, offset, buf.len())?;
        self.flash.blocking_read(at, buf)
    }

    fn erase(&mut self, slot: u8) -> Result<(), Error> {
        let at = self.offset(slot, 0, SLOT_LEN)?;
        self.flash.blocking_erase(at, at + SLOT_LEN as u32)
    }

    fn write(&mut self, slot: u8, offset: usize, data: &[u8]) -> Result<(), Error> {
        let at = self.offset(slot, offset, data.len())?;
        self.flash.blocking_write(at, data)
    }
}
