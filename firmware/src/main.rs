//! The RP2040 firmware binary: boots the board and drives the six servos.
//!
//! Built only for the MCU with `cargo firmware` (alias for
//! `cargo build -p firmware --release --target thumbv6m-none-eabi`). On the
//! host, where `cargo test` / `cargo build -p firmware` also compile this
//! target, it is a stub that says how to build the real one; all logic worth
//! testing lives in the firmware library and is tested there.
//!
//! `main` only initialises the chip and spawns one task per long-lived job.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;

#[cfg(target_os = "none")]
mod mcu {
    //! Init and the tasks of the board.

    use defmt::{info, unwrap};
    use embassy_executor::Spawner;
    use embassy_time::{Duration, Ticker};
    use {defmt_rtt as _, panic_probe as _};

    use crate::board::Resources;
    use crate::board::servo_pwm::{CHANNELS, ServoPwm};

    /// The servo frame rate: one pulse per servo every 20 ms.
    const FRAME: Duration = Duration::from_millis(20);
    /// Neutral pulse of the nominal servo curve (0 deg), µs.
    const NEUTRAL_US: u16 = 1650;

    #[embassy_executor::main(
        executor = "embassy_rp::executor::Executor",
        entry = "cortex_m_rt::entry"
    )]
    async fn main(spawner: Spawner) {
        let p = embassy_rp::init(Default::default());
        let r = Resources::take(p);
        info!("lrmcal firmware {} booting", env!("CARGO_PKG_VERSION"));

        let servos = ServoPwm::new(r.servo, embassy_rp::clocks::clk_sys_freq());
        spawner.spawn(unwrap!(servo_frames(servos)));
    }

    /// Writes the six servo pulses once per 50 Hz frame.
    #[embassy_executor::task]
    async fn servo_frames(mut servos: ServoPwm) -> ! {
        let mut ticker = Ticker::every(FRAME);
        info!("servo frames at 50 Hz, all servos at {} us", NEUTRAL_US);
        loop {
            for channel in 0..CHANNELS {
                servos.set_pulse_us(channel, NEUTRAL_US);
            }
            ticker.next().await;
        }
    }
}

/// Host stub: the real program runs only on the RP2040.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "the firmware runs on the RP2040; build it with `cargo firmware` \
         (cargo build -p firmware --release --target thumbv6m-none-eabi)"
    );
    std::process::exit(2);
}
