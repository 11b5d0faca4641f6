//! The board's numbers as pure functions: PWM timing and the calibration
//! flash layout. The drivers in `board` apply them to the hardware; kept
//! apart so they compile and are tested on the host.

/// Servo frame period, µs (50 Hz).
pub const PERIOD_US: u16 = 20_000;
/// PWM counter rate: one count per µs, so a compare value is a pulse width in µs.
pub const COUNT_HZ: u32 = 1_000_000;

/// XIP address of the first byte of flash.
pub const FLASH_BASE: usize = 0x1000_0000;
/// Flash size of the board (Raspberry Pi Pico: 2 MiB W25Q16).
pub const FLASH_SIZE: usize = 2 * 1024 * 1024;
/// The flash's erase sector, bytes.
pub const SECTOR: usize = 4096;
/// Bytes per calibration slot: one sector, so erasing one slot never touches the other.
pub const SLOT_LEN: usize = SECTOR;
/// Number of calibration slots.
pub const SLOTS: usize = 2;

/// Clock divider (8.4 fixed point, as the hardware holds it) that makes a
/// PWM slice count at [`COUNT_HZ`] from `clk_sys_hz`, or `None` if no divider
/// gives exactly that rate (the pulse widths would then be off).
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

/// The calibration region as (offset from the start of flash, length) from
/// the XIP addresses of its first byte and one past its last; `None` unless
/// it is [`SLOTS`] whole, sector-aligned slots inside the flash.
pub fn calib_region(start_addr: usize, end_addr: usize) -> Option<(u32, usize)> {
    let offset = start_addr.checked_sub(FLASH_BASE)?;
    let len = end_addr.checked_sub(start_addr)?;
    let fits = offset.checked_add(len)? <= FLASH_SIZE;
    (fits && len == SLOTS * SLOT_LEN && offset.is_multiple_of(SECTOR))
        .then_some((offset as u32, len))
}

/// Flash offset of byte `offset` of `slot` in a region starting at flash
/// offset `base`, if `len` bytes from there stay inside the slot.
pub fn slot_offset(base: u32, slot: u8, offset: usize, len: usize) -> Option<u32> {
    let slot = usize::from(slot);
    let end = offset.checked_add(len)?;
    (slot < SLOTS && end <= SLOT_LEN).then(|| base + (slot * SLOT_LEN + offset) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pwm_counts_at_1_mhz_from_common_clocks() {
        assert_eq!(divider_bits(125_000_000), Some(125 << 4));
        assert_eq!(divider_bits(133_000_000), Some(133 << 4));
        assert_eq!(divider_bits(48_000_000), Some(48 << 4));
        // A fractional divider is fine when it is exact: 125.5.
        assert_eq!(divider_bits(125_500_000), Some((125 << 4) | 8));
        // 20 000 counts of 1 µs: a 50 Hz frame.
        assert_eq!(u32::from(PERIOD_US) * 50, COUNT_HZ);
    }

    #[test]
    fn inexact_or_out_of_range_clocks_have_no_divider() {
        assert_eq!(divider_bits(125_000_001), None);
        assert_eq!(divider_bits(500_000), None); // below 1.0
        assert_eq!(divider_bits(256_000_000), None); // above 255 + 15/16
    }

    #[test]
    fn two_slots_at_the_end_of_flash_are_accepted() {
        let start = FLASH_BASE + FLASH_SIZE - 2 * SECTOR;
        assert_eq!(
            calib_region(start, start + 2 * SECTOR),
            Some((0x1F_E000, 2 * SECTOR))
        );
    }

    #[test]
    fn bad_regions_are_refused() {
        let start = FLASH_BASE + FLASH_SIZE - 2 * SECTOR;
        // One slot only, unaligned, past the end, before flash, reversed.
        assert_eq!(calib_region(start, start + SECTOR), None);
        assert_eq!(calib_region(start - 16, start - 16 + 2 * SECTOR), None);
        assert_eq!(calib_region(start + SECTOR, start + 3 * SECTOR), None);
        assert_eq!(
            calib_region(0x2000_0000 - 1, 0x2000_0000 + 2 * SECTOR),
            None
        );
        assert_eq!(
            calib_region(FLASH_BASE - 1, FLASH_BASE + 2 * SECTOR - 1),
            None
        );
        assert_eq!(calib_region(start, start - 1), None);
    }

    #[test]
    fn slot_accesses_stay_inside_their_slot() {
        let base = 0x1F_E000;
        assert_eq!(slot_offset(base, 0, 0, SLOT_LEN), Some(base));
        assert_eq!(slot_offset(base, 1, 256, 16), Some(base + 4096 + 256));
        assert_eq!(
            slot_offset(base, 1, SLOT_LEN - 1, 1),
            Some(base + 2 * 4096 - 1)
        );
        assert_eq!(slot_offset(base, 1, SLOT_LEN - 1, 2), None);
        assert_eq!(slot_offset(base, 0, 1, SLOT_LEN), None);
        assert_eq!(slot_offset(base, 2, 0, 1), None);
        assert_eq!(slot_offset(base, 0, usize::MAX, 2), None);
    }

    #[test]
    fn memory_x_reserves_the_slots_this_layout_expects() {
        // The linker script is the one source of the region; check that it
        // says what the driver is written for (2 x 4 KiB at the end of 2 MiB).
        let memory_x = include_str!("../../memory.x");
        let calib = memory_x
            .lines()
            .find(|l| l.trim_start().starts_with("CALIB"))
            .expect("memory.x has a CALIB region");
        assert!(
            calib.contains("ORIGIN = 0x10000000 + 2048K - 8K"),
            "{calib}"
        );
        assert!(calib.contains("LENGTH = 8K"), "{calib}");
        assert_eq!(FLASH_SIZE, 2048 * 1024);
        assert_eq!(SLOTS * SLOT_LEN, 8 * 1024);
    }
}
