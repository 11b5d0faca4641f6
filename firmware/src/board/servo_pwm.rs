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

use embassy_rp::pwm::{Config, Pwm, PwmOutput, SetDutyCycle};
use fixed::FixedU16;
use fixed::types::extra::U4;

use super::ServoResources;

/// Servo frame period, µs (50 Hz).
pub const PERIOD_US: u16 = 20_000;
/// PWM counter rate: one count per µs.
const COUNT_HZ: u32 = 1_000_000;
/// Number of servo outputs.
pub const CHANNELS: usize = 6;

/// Clock divider (8.4 fixed point, as the hardware holds it) that makes a
/// slice count at 1 MHz from `clk_sys_hz`, or `None` if no divider gives
/// exactly 1 MHz (the pulse widths would then be off).
pub const fn divider_bits(clk_sys_hz: u32) -> Option<u16> {
    let sixteenths = clk_sys_hz as u64 * 16;
    if !sixteenths.is_multiple_of(COUNT_HZ as u64) {
        return None;
    }
    let bits = sixteenths / COUNT_HZ as u64;
    // The divider runs from 1.0 to 255 + 15/16.
    if bits < 16 || bits > 0xFFF {
        return None;
    }
    Some(bits as u16)
}

/// The six servo outputs.
pub struct ServoPwm {
    /// Outputs in servo order 1..6; the slices they belong to are kept
    /// running by the `Pwm` handles below.
    outputs: [PwmOutput<'static>; CHANNELS],
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

        let (o1, o2) = Pwm::new_output_ab(r.slice1, r.s1, r.s2, config.clone()).split();
        let (o3, o4) = Pwm::new_output_ab(r.slice2, r.s3, r.s4, config.clone()).split();
        let (o5, o6) = Pwm::new_output_ab(r.slice3, r.s5, r.s6, config).split();
        // `new_output_ab` always returns both channels.
        let outputs = [o1, o2, o3, o4, o5, o6].map(|o| defmt::unwrap!(o));
        Self { outputs }
    }

    /// Sets servo `channel`'s (0-based) pulse width in µs from the next
    /// period on; 0 detaches the servo. Widths are saturated to the period.
    pub fn set_pulse_us(&mut self, channel: usize, pulse_us: u16) {
        let Some(out) = self.outputs.get_mut(channel) else {
            defmt::warn!("no servo channel {}", channel);
            return;
        };
        // Cannot fail: the width is at most TOP, the largest duty accepted.
        let _ = out.set_duty_cycle(pulse_us.min(PERIOD_US - 1));
    }
}
