//! The RP2040 firmware binary: init, and one task per long-lived job.
//!
//! Built only for the MCU with `cargo firmware` (alias for
//! `cargo build -p firmware --release --target thumbv6m-none-eabi`). On the
//! host, where `cargo test` / `cargo build -p firmware` also compile this
//! target, it is a stub that says how to build the real one. The logic worth
//! testing lives in the firmware library and in `layout`, both tested on the host.
//!
//! | module | job |
//! |---|---|
//! | `layout` | the board's numbers as pure functions (PWM timing, flash slots), host-tested |
//! | `board` | chip drivers: servo PWM, calibration flash, USB serial |
//! | `context` | the library's device on this board, shared by the tasks |
//! | `tasks` | servo frames, serial link, USB stack |
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod board;
#[cfg(target_os = "none")]
mod context;
#[cfg(any(target_os = "none", test))]
mod layout;
#[cfg(target_os = "none")]
mod tasks;

#[cfg(target_os = "none")]
mod mcu {
    //! Init: split the peripherals, build the device, spawn the tasks.

    use core::cell::RefCell;

    use defmt::{info, unwrap};
    use embassy_executor::Spawner;
    use embassy_rp::watchdog::Watchdog;
    use embassy_sync::blocking_mutex::Mutex;
    use static_cell::StaticCell;
    use {defmt_rtt as _, panic_probe as _};

    use crate::board::flash::CalibrationFlash;
    use crate::board::servo_pwm::ServoPwm;
    use crate::board::{Resources, usb};
    use crate::context::{self, SharedBoard};
    use crate::tasks::{serial, servo};

    static BOARD: StaticCell<SharedBoard> = StaticCell::new();

    #[embassy_executor::main(
        executor = "embassy_rp::executor::Executor",
        entry = "cortex_m_rt::entry"
    )]
    async fn main(spawner: Spawner) {
        let p = embassy_rp::init(Default::default());
        let r = Resources::take(p);
        info!("lrmcal firmware {} booting", env!("CARGO_PKG_VERSION"));

        let mut watchdog = Watchdog::new(r.watchdog);
        // Halted at a debugger's breakpoint is not a hung servo loop.
        watchdog.pause_on_debug(true);
        if let Some(reason) = watchdog.reset_reason() {
            defmt::warn!(
                "restarted by the watchdog: {}",
                defmt::Debug2Format(&reason)
            );
        }

        // Every channel starts limp (the library's start-up rule).
        let servos = ServoPwm::new(r.servo, embassy_rp::clocks::clk_sys_freq());
        let flash = CalibrationFlash::new(r.flash);
        let device = firmware::Device::new(servos, flash, context::config(), context::now_us());
        let board: &'static SharedBoard = BOARD.init(Mutex::new(RefCell::new(device)));

        let (usb_device, serial_port) = usb::init(r.usb);
        spawner.spawn(unwrap!(crate::tasks::usb::usb_device(usb_device)));
        spawner.spawn(unwrap!(serial::serial(serial_port, board)));
        spawner.spawn(unwrap!(servo::servo_frames(board, watchdog)));
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
