//! The serial link: frames from the host into the device, replies back.
//!
//! Bytes are cut into frames at each 0x00 by the protocol's
//! [`FrameReader`]; each frame is handled to the end (reply written)
//! before the next byte is read, so the host sees replies in order.

use protocol::frame::{Feed, FrameReader, MAX_FRAME};

use crate::board::usb::{Disconnected, PACKET, Serial, write_all};
use crate::context::{SharedBoard, perform, with_board};

/// Serves the host over USB serial, one connection after another.
#[embassy_executor::task]
pub async fn serial(mut serial: Serial, board: &'static SharedBoard) -> ! {
    let mut reply = [0u8; MAX_FRAME];
    loop {
        serial.wait_connection().await;
        defmt::info!("host connected");
        // A fresh reader per connection: a frame cut off by the last
        // disconnect must not prefix the next one.
        let mut reader = FrameReader::<MAX_FRAME>::new();
        let Disconnected = session(&mut serial, board, &mut reader, &mut reply).await;
        defmt::info!("host disconnected");
    }
}

/// Reads and answers frames until the host goes away.
async fn session(
    serial: &mut Serial,
    board: &SharedBoard,
    reader: &mut FrameReader<MAX_FRAME>,
    reply: &mut [u8; MAX_FRAME],
) -> Disconnected {
    let mut packet = [0u8; PACKET];
    loop {
        let n = match serial.read_packet(&mut packet).await {
            Ok(n) => n,
            Err(e) => return e.into(),
        };
        for &byte in &packet[..n] {
            let len = match reader.feed(byte) {
                Feed::Pending => continue,
                Feed::Overflow => {
                    with_board(board, |b| b.frame_overflowed());
                    continue;
                }
                Feed::Frame(frame) => with_board(board, |b| b.handle_frame(frame, reply)),
            };
            if len > 0
                && let Err(disconnected) = write_all(serial, &reply[..len]).await
            {
                return disconnected;
            }
            if let Some(action) = with_board(board, |b| b.take_action()) {
                // Let the reply leave the USB buffers before the board goes away.
                embassy_time::Timer::after_millis(50).await;
                perform(action);
            }
        }
    }
}
