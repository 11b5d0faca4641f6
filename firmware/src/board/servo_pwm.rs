//! Six RC servo outputs on three PWM slices: 50 Hz frames, 1 µs pulse resolution.
//!
//! Each slice counts at 1 MHz (system clock divided by an integer) and wraps
//! every 20 000 counts, so a slice's period is exactly 20 ms (50 Hz) and a
//! channel's compare value *is* its pulse width in µs. The compare registers
//! are double-buffered by the hardware and latched at the wrap: a new pulse
//! takes effect at the next period boundary, never mid-pulse.
//!
//! Pin map (Raspberry Pi Pico numbering):
//!
//! | servo | joint | GPIO | Pico pin | PWM slice / channel |
//! |---|---|---|---|---|
//! | 1 | j1 | GP2 | 4  | 1 A |
//! | 2 | j2 | GP3 | 5  | 1 B |
//! | 3 | j3 | GP4 | 6  | 2 A |
//! | 4 | j4 | GP5 | 7  | 2 B |
//! | 5 | j5 | GP6 | 9  | 3 A |
//! | 6 | j6 | GP7 | 10 | 3 B |
//!
//! GP0/GP1 stay free for a UART or a debug probe's serial. A detached
//! (limp) servo gets no pulse at all: its output is held low.

use embassy_rp::pwm::{Config, Pwm, SetDutyCycle};
use firmware::ServoBus;
use fixed::FixedU16;
use fixed::types::extra::U4;

use super::ServoResources;
use crate::layout::{PERIOD_US, divider_bits};

/// Number of servo outputs.
const CHANNELS: usize = firmware::CHANNELS;

/// The six servo outputs.
pub struct ServoPwm {
    /// Slices 1, 2, 3: servo `2k + 1` is channel A of `slices[k]`, servo
    /// `2k + 2` channel B. Kept whole (not split into outputs) because
    /// dropping a `Pwm` stops its slice.
    slices: [Pwm<'static>; CHANNELS / 2],
    /// The compare value each output holds, once written: the register keeps
    /// it, so a servo frame that leaves a pulse as it was (every channel of a
    /// held pose) writes nothing (a write through the driver costs about 200
    /// cycles).
    compare: [Option<u16>; CHANNELS],
}

impl ServoPwm {
    /// Starts the three slices at 50 Hz with every output low (detached).
    ///
    /// Panics if the system clock cannot be divided down to exactly 1 MHz:
    /// that is a clock configuration bug, not a run-time condition.
    pub fn new(r: ServoResources, clk_sys_hz: u32) -> Self {
        let Some(bits) = divider_bits(clk_sys_hz) else {
            defmt::panic!("clk_sys {} Hz has no exact 1 MHz PWM divider", clk_sys_hz);
        };
        let mut config = Config::default();
        config.divider = FixedU16::<U4>::from_bits(bits);
        config.top = PERIOD_US - 1;
        config.compare_a = 0;
        config.compare_b = 0;

        let slices = [
            Pwm::new_output_ab(r.slice1, r.s1, r.s2, config.clone()),
            Pwm::new_output_ab(r.slice2, r.s3, r.s4, config.clone()),
            Pwm::new_output_ab(r.slice3, r.s5, r.s6, config),
        ];
        Self {
            slices,
            compare: [None; CHANNELS],
        }
    }
}

impl ServoBus for ServoPwm {
    /// Sets servo `channel`'s (0-based) pulse width from the next period on;
    /// `None` holds the output low (limp). Widths are saturated to the period:
    /// the library already keeps them in the safe pulse range.
    fn set_pulse(&mut self, channel: usize, pulse_us: Option<u16>) {
        let (Some(slice), Some(held)) = (
            self.slices.get_mut(channel / 2),
            self.compare.get_mut(channel),
        ) else {
            defmt::warn!("no servo channel {}", channel);
            return;
        };
        let compare = pulse_us.unwrap_or(0).min(PERIOD_US - 1);
        if *held == Some(compare) {
            return;
        }
        let (a, b) = slice.split_by_ref();
        let output = if channel.is_multiple_of(2) { a } else { b };
        // Both channels exist (`new_output_ab`), and the compare value is at
        // most TOP, the largest duty accepted: this cannot fail.
        match output.map(|mut o| o.set_duty_cycle(compare)) {
            Some(Ok(())) => *held = Some(compare),
            Some(Err(e)) => defmt::warn!("servo {}: {}", channel + 1, defmt::Debug2Format(&e)),
            None => {}
        }
    }
}
