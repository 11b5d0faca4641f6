//! The 50 Hz servo frame: the one real-time job.

use embassy_rp::watchdog::Watchdog;
use embassy_time::{Duration, Ticker};

use crate::context::{SharedBoard, now_us, with_board};

/// Servo frame period: RC servos expect one pulse every 20 ms.
pub const FRAME: Duration = Duration::from_millis(20);
/// Longest the servo loop may stall before the watchdog resets the chip.
/// Covers a calibration commit (a 4 KiB sector erase stalls the CPU for at
/// most 400 ms) with room to spare.
pub const WATCHDOG_TIMEOUT: Duration = Duration::from_millis(1500);

/// Runs one servo frame per period and feeds the watchdog after each.
#[embassy_executor::task]
pub async fn servo_frames(board: &'static SharedBoard, mut watchdog: Watchdog) -> ! {
    watchdog.start(WATCHDOG_TIMEOUT);
    let mut ticker = Ticker::every(FRAME);
    defmt::info!("servo frames at 50 Hz");
    loop {
        run_servo_frame(board);
        watchdog.feed(WATCHDOG_TIMEOUT);
        ticker.next().await;
    }
}

/// One frame of the device (motion, compensation, pulses). Never inlined, so
/// the emulator's cycle probe finds it by name (`run_servo_frame`).
#[inline(never)]
fn run_servo_frame(board: &SharedBoard) {
    with_board(board, |b| b.servo_frame(now_us()));
}
