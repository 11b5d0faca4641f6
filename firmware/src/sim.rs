//! Test doubles for the firmware logic, on the host: a servo bus that records
//! every pulse, a flash that can lose power at any byte, and a calibration to
//! load. Used by this crate's tests and, with feature `sim`, by `tests/`.

use model::{PerJoint, ServoCurve};
use protocol::{Calibration, ModelOption};

use crate::{CHANNELS, FlashStorage, PerChannel, ServoBus};

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

/// A calibration of the shared LRM-like test arm
/// ([`model::testing::lrm_like_arm`]): millimetre and degree-level geometric
/// errors, changed compliances and individual servo curves of 3 to 9 knots,
/// each with its own bow between the ends.
pub fn test_calibration(id: u32) -> Calibration {
    test_calibration_of(id, model::testing::TEST_ARM_JOINTS)
}

/// [`test_calibration`] of the test arm's first `joints` joints (1 to 6):
/// the tool sits on the last of them, as on an arm built without the rest.
pub fn test_calibration_of(id: u32, joints: usize) -> Calibration {
    let mut nominal = model::testing::lrm_like_arm::<f32>();
    nominal.joints = PerJoint::from_slice(&nominal.joints[..joints]).expect("at most six joints");
    let mut calibrated = nominal;
    for (i, j) in calibrated.joints.iter_mut().enumerate() {
        let s = if i % 2 == 0 { 1.0 } else { -1.0 };
        j.theta += s * 0.01;
        j.d += 0.001 * s;
        j.a += 0.0015 * s;
        j.compliance *= 1.3;
        j.servo = test_curve(i);
        j.limits = [-1.7, 1.7];
    }
    calibrated.base.rpy[1] += 0.005;
    calibrated.tool.xyz[0] += 0.002;
    Calibration {
        id,
        option: ModelOption::ElastoKinematic,
        nominal,
        calibrated,
        home_rad: PerChannel::from_slice(&[0.0, 0.3, -0.3, 0.0, 0.5, 0.0][..joints])
            .expect("at most six joints"),
        // 20° per joint: far beyond the corrections this calibration asks for.
        max_correction_rad: PerChannel::splat(joints, 0.35),
    }
}

/// Joint `i`'s servo curve in [`test_calibration`]: knots evenly spaced over
/// ±100° (5, 3, 7, 9, 5 and 4 of them), the ends where a three-point tuning
/// would put them, a bow of 12 - 4i µs in between.
pub fn test_curve(i: usize) -> ServoCurve<f32> {
    let n = [5, 3, 7, 9, 5, 4][i % CHANNELS];
    let span = 100f32.to_radians();
    let ends = ServoCurve::from_three_points(
        880.0 + 10.0 * i as f32,
        1640.0 + 5.0 * i as f32,
        2420.0 - 7.0 * i as f32,
    );
    let mut angles = [0.0f32; model::servo::MAX_KNOTS];
    let mut pulses = [0.0f32; model::servo::MAX_KNOTS];
    for k in 0..n {
        let t = k as f32 / (n - 1) as f32;
        angles[k] = span * (2.0 * t - 1.0);
        let bow = (12.0 - 4.0 * i as f32) * libm::sinf(core::f32::consts::PI * t);
        pulses[k] = ends.pulse_us(angles[k]) + bow;
    }
    ServoCurve::new(&angles[..n], &pulses[..n]).expect("3 to 9 knots")
}
