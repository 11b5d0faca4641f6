//! Faults on the real firmware in the emulated RP2040: a calibration push cut off mid-transfer,
//! a power cut in the middle of a flash erase or program, and garbage on the serial line. In
//! every case the board keeps the previous calibration (bit-identical) and its servo frames.
//!
//! Needs `cargo firmware`, Node and `npm ci` in `tests/emulator`; run with
//! `cargo test -p e2e --features emulator --test emulator_faults`.

mod emulator_support;

use emulator_support::{EmulatedBoard, RawLink, calibration_bytes, test_calibration};
use protocol::{Request, Response};
use serde_json::json;

/// A board holding calibration `old`, with a fresh link to it.
fn board_with_calibration(old: &protocol::Calibration) -> (EmulatedBoard, RawLink) {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let mut link = RawLink::connect(&board);
    link.push(old);
    (board, link)
}

/// After a reset (or a dropped connection): the board runs on `old`, stored bit-identical.
fn assert_keeps(board: &mut EmulatedBoard, old: &protocol::Calibration) {
    board.wait_configured();
    let mut link = RawLink::connect(board);
    let status = link.status();
    let info = status.calibration.expect("a calibration in use");
    assert_eq!(
        info.id, old.id,
        "the board uses calibration {} instead of {}",
        info.id, old.id
    );
    assert_eq!(
        link.pull(),
        calibration_bytes(old),
        "stored calibration differs from the one pushed"
    );
}

#[test]
fn push_cut_off_mid_transfer_keeps_the_previous_calibration() {
    let (old, new) = (test_calibration(11), test_calibration(12));
    let (mut board, mut link) = board_with_calibration(&old);
    link.push_chunks(&calibration_bytes(&new), 3);
    drop(link); // the host goes away in the middle of the upload
    assert_keeps(&mut board, &old);
    // A commit without the rest of the upload is refused, and still nothing changes.
    let mut link = RawLink::connect(&board);
    link.push_chunks(&calibration_bytes(&new), 2);
    let commit = link.request(&Request::CalibrationCommit);
    assert!(
        matches!(commit, Response::Error(_)),
        "commit of a partial upload answered {commit:?}"
    );
    drop(link);
    board.reset();
    assert_keeps(&mut board, &old);
}

#[test]
fn power_cut_during_a_flash_write_keeps_the_previous_calibration() {
    let (old, new) = (test_calibration(21), test_calibration(22));
    // Cut during the sector erase (nothing / half erased) and during the program (before the
    // first byte, after one byte, in the middle, one byte short of the end).
    let len = calibration_bytes(&new).len();
    let cuts = [
        ("erase", 0),
        ("erase", 2048),
        ("program", 0),
        ("program", 1),
        ("program", 100),
        ("program", len - 1),
    ];
    for (op, bytes) in cuts {
        let (mut board, mut link) = board_with_calibration(&old);
        board.request(json!({"cmd": "cut_flash", "op": op, "nth": 1, "bytes": bytes}));
        link.push_chunks(&calibration_bytes(&new), usize::MAX);
        let commit = link.request_or_closed(&Request::CalibrationCommit);
        assert!(
            commit.is_none(),
            "cut in {op} after {bytes} bytes: the commit still answered {commit:?}"
        );
        let cut = board.request(json!({"cmd": "cut_status"}));
        assert_eq!(cut["fired"], true, "the flash {op} never happened");
        assert_eq!(board.status()["resets"], 1);
        assert_keeps(&mut board, &old);
    }
}

#[test]
fn a_completed_write_survives_a_reset() {
    let (old, new) = (test_calibration(31), test_calibration(32));
    let (mut board, mut link) = board_with_calibration(&old);
    link.push(&new);
    drop(link);
    board.reset();
    assert_keeps(&mut board, &new);
}

#[test]
fn garbage_on_the_serial_line_does_not_stop_the_servo_frames() {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let mut link = RawLink::connect(&board);
    assert_eq!(
        link.request(&Request::Attach { channel: None }),
        Response::Done
    );
    let before = board.servo_pulses(2).0;

    // 16 KiB of noise (xorshift, zeros included so it splits into many bogus frames), then
    // bytes that look like a frame start but never end.
    let mut state = 0x2545_f491_u32;
    let mut noise: Vec<u8> = (0..16 * 1024)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state as u8
        })
        .collect();
    noise.extend(std::iter::repeat_n(0x55, 600));
    link.send_bytes(&noise);

    let (widths, periods) = board.servo_pulses(25);
    for (servo, (widths, periods)) in widths.iter().zip(&periods).enumerate() {
        for width in widths {
            assert!(
                (width - before[servo][0]).abs() <= 1.0,
                "servo {} pulse {width} µs during garbage",
                servo + 1
            );
        }
        for period in periods.iter().flatten() {
            assert!(
                (period - 20_000.0).abs() <= 1.0,
                "servo {} frame period {period} µs during garbage",
                servo + 1
            );
        }
    }
    // The link still works after a terminator resynchronises the frame reader.
    link.send_bytes(&[0]);
    assert!(matches!(
        link.request(&Request::Status),
        Response::Status(_)
    ));
    assert!(board.status()["halted"].is_null());
}

#[test]
fn a_peer_of_another_protocol_version_is_refused_clearly() {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let mut link = RawLink::connect(&board);
    let theirs = protocol::PROTOCOL_VERSION.wrapping_add(1);
    let reply = link.exchange(theirs, &Request::Status);
    assert_eq!(
        reply,
        Some(Response::Error(protocol::WireError::VersionMismatch))
    );
    // The board is none the worse for it.
    assert!(matches!(
        link.request(&Request::Status),
        Response::Status(_)
    ));
}

#[test]
fn reboot_to_the_usb_bootloader_goes_through_the_rom() {
    let mut board = EmulatedBoard::start();
    board.wait_configured();
    let mut link = RawLink::connect(&board);
    // The board may answer before it leaves, or leave first; either way it ends in the ROM.
    let reply = link.request_or_closed(&Request::RebootToBootloader);
    assert!(matches!(reply, None | Some(Response::Done)), "{reply:?}");
    // The emulator stops the clock when the chip leaves for its bootloader: poll its status.
    let mut halted = String::new();
    for _ in 0..100 {
        halted = board.status()["halted"]
            .as_str()
            .unwrap_or_default()
            .to_owned();
        if !halted.is_empty() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    assert!(
        halted.contains("USB bootloader"),
        "the board did not call reset_to_usb_boot: {halted:?}"
    );
}
