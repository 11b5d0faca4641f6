//! The board without hardware, on the host: a servo bus that records every
//! pulse and a flash that can lose power at any byte (feature `sim`). The
//! host's in-memory board (`lrmcal_engine::device::memory`) runs the firmware
//! library on them, so they are product code and carry nothing of the tests.
//!
//! The tests' calibrations to load (`test_calibration`, built on the model's
//! test arm, in `sim/calibrations.rs`) are here only for this crate's tests
//! and with feature `fuzz`.

use crate::{CHANNELS, FlashStorage, ServoBus};

#[cfg(any(test, feature = "fuzz"))]
mod calibrations;
#[cfg(any(test, feature = "fuzz"))]
pub use calibrations::{test_calibration, test_calibration_of, test_curve};

/// Records every call to [`ServoBus::set_pulse`].
#[derive(Clone, Debug, Default)]
pub struct MockBus {
    /// Every call in order: channel and pulse (µs) or `None` for limp.
    pub log: Vec<(usize, Option<u16>)>,
    /// What each channel outputs now.
    pub now: [Option<u16>; CHANNELS],
}

impl ServoBus for MockBus {
    fn set_pulse(&mut self, channel: usize, pulse_us: Option<u16>) {
        self.log.push((channel, pulse_us));
        if let Some(slot) = self.now.get_mut(channel) {
            *slot = pulse_us;
        }
    }
}

/// Bytes of one simulated slot (one RP2040 erase sector).
pub const SLOT_SIZE: usize = 4096;

/// The flash lost power: the operation stopped part way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PowerCut;

/// Two NOR flash sectors that count every byte erased or programmed and can
/// lose power after a given count, leaving the operation half done.
#[derive(Clone, Debug)]
pub struct SimFlash {
    slots: [Vec<u8>; 2],
    operations: usize,
    budget: Option<usize>,
    dead: bool,
}

impl Default for SimFlash {
    fn default() -> Self {
        Self::new()
    }
}

impl SimFlash {
    /// Erased flash.
    pub fn new() -> Self {
        Self {
            slots: [vec![0xFF; SLOT_SIZE], vec![0xFF; SLOT_SIZE]],
            operations: 0,
            budget: None,
            dead: false,
        }
    }

    /// Byte operations (erased or programmed bytes) so far.
    pub fn operations(&self) -> usize {
        self.operations
    }

    /// Power fails after `n` more byte operations; every operation after that fails.
    pub fn cut_after(&mut self, n: usize) {
        self.budget = Some(n);
    }

    /// Power returns (a reboot): operations work again, without a cut pending.
    pub fn power_on(&mut self) {
        self.dead = false;
        self.budget = None;
    }

    /// Flips one bit, as a worn or disturbed cell would.
    pub fn corrupt(&mut self, slot: u8, offset: usize) {
        self.slots[slot as usize][offset] ^= 0x01;
    }

    /// Spends one byte operation; `Err` when the power is (or just went) off.
    fn spend(&mut self) -> Result<(), PowerCut> {
        if self.dead {
            return Err(PowerCut);
        }
        if let Some(b) = &mut self.budget {
            if *b == 0 {
                self.dead = true;
                return Err(PowerCut);
            }
            *b -= 1;
        }
        self.operations += 1;
        Ok(())
    }

    fn slot(&mut self, slot: u8) -> Result<&mut Vec<u8>, PowerCut> {
        self.slots.get_mut(slot as usize).ok_or(PowerCut)
    }
}

impl FlashStorage for SimFlash {
    type Error = PowerCut;

    fn slot_size(&self) -> usize {
        SLOT_SIZE
    }

    fn read(&mut self, slot: u8, offset: usize, buf: &mut [u8]) -> Result<(), PowerCut> {
        if self.dead {
            return Err(PowerCut);
        }
        let src = self
            .slot(slot)?
            .get(offset..offset + buf.len())
            .ok_or(PowerCut)?;
        buf.copy_from_slice(src);
        Ok(())
    }

    fn erase(&mut self, slot: u8) -> Result<(), PowerCut> {
        self.slot(slot)?;
        for i in 0..SLOT_SIZE {
            self.spend()?;
            self.slots[slot as usize][i] = 0xFF;
        }
        Ok(())
    }

    fn write(&mut self, slot: u8, offset: usize, data: &[u8]) -> Result<(), PowerCut> {
        if offset + data.len() > SLOT_SIZE {
            return Err(PowerCut);
        }
        self.slot(slot)?;
        for (i, &byte) in data.iter().enumerate() {
            self.spend()?;
            // NOR flash: programming only clears bits.
            self.slots[slot as usize][offset + i] &= byte;
        }
        Ok(())
    }
}
