//! Calibration storage: two flash slots, each a whole erase sector, holding a
//! record with a sequence number and CRCs. The newest valid slot is the
//! calibration; a new one is written to the *other* slot, so a write cut off
//! at any byte (power loss, unplugged board) leaves the previous one intact.
//!
//! ```text
//! slot:  0        4        8         12       16          20           24     256
//!        | magic  | format | sequence | length | payload   | header     | 0xFF | payload …
//!        | "LRMC" | u32 LE | u32 LE   | u32 LE | CRC-32 LE | CRC-32 LE  |      |
//! ```
//!
//! Order of a write: erase the slot, program the payload (from offset 256, its
//! own flash pages), then the header last. Until the header lands the slot
//! reads as empty or damaged and is never chosen.

use protocol::calibration::{Calibration, MAX_CALIBRATION_LEN};
use protocol::frame::crc32;

/// The two calibration sectors.
pub trait FlashStorage {
    /// The driver's error; the storage only needs to know that it failed.
    type Error;
    /// Bytes in one slot; at least [`PAYLOAD_OFFSET`] + [`MAX_CALIBRATION_LEN`].
    fn slot_size(&self) -> usize;
    /// Reads `buf.len()` bytes of `slot` (0 or 1) from `offset`.
    fn read(&mut self, slot: u8, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error>;
    /// Erases `slot` to 0xFF.
    fn erase(&mut self, slot: u8) -> Result<(), Self::Error>;
    /// Programs `data` into the erased `slot` at `offset` (NOR: bits only go 1 → 0).
    fn write(&mut self, slot: u8, offset: usize, data: &[u8]) -> Result<(), Self::Error>;
}

/// Lets a caller keep the flash and lend it (tests "reboot" by building a new store over it).
impl<F: FlashStorage> FlashStorage for &mut F {
    type Error = F::Error;
    fn slot_size(&self) -> usize {
        (**self).slot_size()
    }
    fn read(&mut self, slot: u8, offset: usize, buf: &mut [u8]) -> Result<(), Self::Error> {
        (**self).read(slot, offset, buf)
    }
    fn erase(&mut self, slot: u8) -> Result<(), Self::Error> {
        (**self).erase(slot)
    }
    fn write(&mut self, slot: u8, offset: usize, data: &[u8]) -> Result<(), Self::Error> {
        (**self).write(slot, offset, data)
    }
}

const MAGIC: [u8; 4] = *b"LRMC";
/// Record layout version. An intact record of another layout reads as an
/// empty slot: its payload is another protocol's, which this firmware cannot
/// decode, so a board reflashed across a layout change boots without a
/// calibration (not with a damaged one) until one is pushed again.
/// 2: the payload of protocol 2 (servo curves of 2 to 9 knots).
/// 3: the payload of protocol 3 (each joint's backlash).
/// 4: the payload of protocol 4 (the option elasto-kinematic-servo, which
/// firmware of layout 3 cannot decode).
/// 5: the payload of protocol 5 (rated payloads, each joint's largest correction).
/// 6: the payload of protocol 6 (arms of 1 to 6 joints: a count before each
/// arm's joints, the home pose and the corrections).
const FORMAT: u32 = 6;
const HEADER_LEN: usize = 24;
/// Where the payload starts: one flash page after the header.
pub const PAYLOAD_OFFSET: usize = 256;

/// The header of a slot's record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Header {
    sequence: u32,
    len: u32,
    payload_crc: u32,
}

impl Header {
    fn to_bytes(self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        b[0..4].copy_from_slice(&MAGIC);
        b[4..8].copy_from_slice(&FORMAT.to_le_bytes());
        b[8..12].copy_from_slice(&self.sequence.to_le_bytes());
        b[12..16].copy_from_slice(&self.len.to_le_bytes());
        b[16..20].copy_from_slice(&self.payload_crc.to_le_bytes());
        let crc = crc32(&b[..20]);
        b[20..24].copy_from_slice(&crc.to_le_bytes());
        b
    }

    fn from_bytes(b: &[u8; HEADER_LEN]) -> SlotRead {
        if b.iter().all(|&x| x == 0xFF) {
            return SlotRead::Empty;
        }
        let word = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        if b[0..4] != MAGIC || crc32(&b[..20]) != word(20) {
            return SlotRead::Damaged;
        }
        if word(4) != FORMAT {
            return SlotRead::Empty;
        }
        let header = Header {
            sequence: word(8),
            len: word(12),
            payload_crc: word(16),
        };
        if header.len as usize > MAX_CALIBRATION_LEN {
            return SlotRead::Damaged;
        }
        SlotRead::Valid(header)
    }
}

/// What a slot holds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum SlotRead {
    Empty,
    Damaged,
    Valid(Header),
}

/// A calibration found in flash.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loaded {
    /// The calibration.
    pub calibration: Calibration,
    /// Its sequence number.
    pub sequence: u32,
}

/// What [`Storage::load`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadReport {
    /// The newest valid calibration, if any.
    pub loaded: Option<Loaded>,
    /// Whether a slot held a damaged record (e.g. a write cut short).
    pub damaged: bool,
}

/// Why a store or erase failed. The previous calibration is still in flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StorageError {
    /// The driver reported an error.
    Flash,
    /// The payload is empty or longer than [`MAX_CALIBRATION_LEN`], or the slot is too small.
    Size,
    /// The record read back differs from what was written.
    Verify,
}

/// The two-slot store over a [`FlashStorage`].
#[derive(Debug)]
pub struct Storage<F> {
    flash: F,
    /// The slot and header of the calibration in use.
    active: Option<(u8, Header)>,
}

/// Whether sequence `a` is newer than `b`, across wrap-around.
fn newer(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

impl<F: FlashStorage> Storage<F> {
    /// A store over `flash`; call [`Storage::load`] before anything else.
    pub fn new(flash: F) -> Self {
        Self {
            flash,
            active: None,
        }
    }

    /// Gives the flash back (to "reboot" in tests).
    pub fn into_flash(self) -> F {
        self.flash
    }

    /// The flash (to cut its power in tests).
    #[cfg(any(test, feature = "fuzz"))]
    pub fn flash_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    /// Reads both slots and picks the newest valid calibration.
    pub fn load(&mut self) -> LoadReport {
        let mut damaged = false;
        let mut best: Option<(u8, Header, Calibration)> = None;
        let mut buf = [0u8; MAX_CALIBRATION_LEN];
        for slot in 0..2u8 {
            match self.read_slot(slot, &mut buf) {
                Ok(Some((header, cal))) => {
                    if best
                        .as_ref()
                        .is_none_or(|(_, h, _)| newer(header.sequence, h.sequence))
                    {
                        best = Some((slot, header, cal));
                    }
                }
                Ok(None) => {}
                Err(()) => damaged = true,
            }
        }
        self.active = best.map(|(slot, h, _)| (slot, h));
        LoadReport {
            loaded: best.map(|(_, h, calibration)| Loaded {
                calibration,
                sequence: h.sequence,
            }),
            damaged,
        }
    }

    /// `Ok(None)` for an empty slot, `Err` for a damaged one.
    fn read_slot(
        &mut self,
        slot: u8,
        buf: &mut [u8; MAX_CALIBRATION_LEN],
    ) -> Result<Option<(Header, Calibration)>, ()> {
        let mut hb = [0u8; HEADER_LEN];
        self.flash.read(slot, 0, &mut hb).map_err(|_| ())?;
        let header = match Header::from_bytes(&hb) {
            SlotRead::Empty => return Ok(None),
            SlotRead::Damaged => return Err(()),
            SlotRead::Valid(h) => h,
        };
        let payload = &mut buf[..header.len as usize];
        self.flash
            .read(slot, PAYLOAD_OFFSET, payload)
            .map_err(|_| ())?;
        if crc32(payload) != header.payload_crc {
            return Err(());
        }
        Calibration::decode(payload)
            .map(|c| Some((header, c)))
            .ok_or(())
    }

    /// Writes `payload` (an encoded, checked [`Calibration`]) to the slot not
    /// in use, verifies it and makes it the active one; returns its sequence.
    pub fn store(&mut self, payload: &[u8]) -> Result<u32, StorageError> {
        if payload.is_empty()
            || payload.len() > MAX_CALIBRATION_LEN
            || self.flash.slot_size() < PAYLOAD_OFFSET + MAX_CALIBRATION_LEN
        {
            return Err(StorageError::Size);
        }
        let (slot, sequence) = match self.active {
            Some((slot, h)) => (1 - slot, h.sequence.wrapping_add(1)),
            None => (0, 1),
        };
        let header = Header {
            sequence,
            len: payload.len() as u32,
            payload_crc: crc32(payload),
        };
        self.flash.erase(slot).map_err(|_| StorageError::Flash)?;
        self.flash
            .write(slot, PAYLOAD_OFFSET, payload)
            .map_err(|_| StorageError::Flash)?;
        self.flash
            .write(slot, 0, &header.to_bytes())
            .map_err(|_| StorageError::Flash)?;
        let mut buf = [0u8; MAX_CALIBRATION_LEN];
        match self.read_slot(slot, &mut buf) {
            Ok(Some((h, _))) if h == header => {
                self.active = Some((slot, header));
                Ok(sequence)
            }
            _ => Err(StorageError::Verify),
        }
    }

    /// Erases both slots, the one not in use first, so a cut-off erase leaves
    /// either the old calibration or none, never a damaged one in use.
    pub fn erase(&mut self) -> Result<(), StorageError> {
        let first = self.active.map_or(0, |(slot, _)| 1 - slot);
        for slot in [first, 1 - first] {
            self.flash.erase(slot).map_err(|_| StorageError::Flash)?;
        }
        self.active = None;
        Ok(())
    }

    /// Length and CRC of the active calibration's encoded bytes.
    pub fn active_payload(&self) -> Option<(u32, u32)> {
        self.active.map(|(_, h)| (h.len, h.payload_crc))
    }

    /// Reads the active calibration's encoded bytes from `offset` into `buf`; returns the count.
    pub fn read_payload(&mut self, offset: usize, buf: &mut [u8]) -> Result<usize, StorageError> {
        let (slot, h) = self.active.ok_or(StorageError::Size)?;
        let len = h.len as usize;
        if offset > len {
            return Err(StorageError::Size);
        }
        let n = buf.len().min(len - offset);
        self.flash
            .read(slot, PAYLOAD_OFFSET + offset, &mut buf[..n])
            .map_err(|_| StorageError::Flash)?;
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{SimFlash, test_calibration};

    fn encoded(id: u32) -> Vec<u8> {
        let mut buf = [0u8; MAX_CALIBRATION_LEN];
        test_calibration(id).encode(&mut buf).unwrap().to_vec()
    }

    fn loaded_id(flash: &mut SimFlash) -> Option<u32> {
        flash.power_on();
        Storage::new(&mut *flash)
            .load()
            .loaded
            .map(|l| l.calibration.id)
    }

    #[test]
    fn empty_flash_has_no_calibration_and_is_not_damaged() {
        let mut flash = SimFlash::new();
        let report = Storage::new(&mut flash).load();
        assert_eq!(
            report,
            LoadReport {
                loaded: None,
                damaged: false
            }
        );
    }

    #[test]
    fn newest_of_the_two_slots_wins_and_survives_reboot() {
        let mut flash = SimFlash::new();
        let mut s = Storage::new(&mut flash);
        s.load();
        assert_eq!(s.store(&encoded(1)), Ok(1));
        assert_eq!(s.store(&encoded(2)), Ok(2));
        assert_eq!(s.store(&encoded(3)), Ok(3));
        assert_eq!(loaded_id(&mut flash), Some(3));
    }

    #[test]
    fn a_write_cut_at_any_byte_keeps_the_previous_calibration() {
        let mut reference = SimFlash::new();
        let mut s = Storage::new(&mut reference);
        s.load();
        s.store(&encoded(1)).unwrap();
        let ops_before = reference.operations();
        let mut s = Storage::new(&mut reference);
        s.load();
        s.store(&encoded(2)).unwrap();
        let write_cost = reference.operations() - ops_before;

        for cut in 0..write_cost {
            let mut flash = SimFlash::new();
            let mut s = Storage::new(&mut flash);
            s.load();
            s.store(&encoded(1)).unwrap();
            flash.cut_after(cut);
            let mut s = Storage::new(&mut flash);
            s.load();
            assert!(
                s.store(&encoded(2)).is_err(),
                "cut at {cut} must fail the store"
            );
            assert_eq!(loaded_id(&mut flash), Some(1), "cut at {cut}");
        }
    }

    #[test]
    fn a_cut_erase_never_leaves_a_damaged_calibration_in_use() {
        for cut in (0..2 * crate::sim::SLOT_SIZE).step_by(97) {
            let mut flash = SimFlash::new();
            let mut s = Storage::new(&mut flash);
            s.load();
            s.store(&encoded(1)).unwrap();
            s.store(&encoded(2)).unwrap();
            flash.cut_after(cut);
            let mut s = Storage::new(&mut flash);
            s.load();
            assert!(s.erase().is_err());
            let id = loaded_id(&mut flash);
            assert!(id == Some(2) || id.is_none(), "cut at {cut}: {id:?}");
        }
    }

    #[test]
    fn a_damaged_slot_is_reported_and_skipped() {
        let mut flash = SimFlash::new();
        let mut s = Storage::new(&mut flash);
        s.load();
        s.store(&encoded(1)).unwrap();
        s.store(&encoded(2)).unwrap();
        // Flip a payload bit of the newer record (slot 1).
        flash.corrupt(1, PAYLOAD_OFFSET + 10);
        let report = Storage::new(&mut flash).load();
        assert!(report.damaged);
        assert_eq!(report.loaded.map(|l| l.calibration.id), Some(1));
    }

    #[test]
    fn a_record_of_an_earlier_layout_reads_as_no_calibration_not_damage() {
        let mut flash = SimFlash::new();
        let mut s = Storage::new(&mut flash);
        s.load();
        s.store(&encoded(1)).unwrap();
        // The same record as firmware of the previous layout would have written it.
        let mut header = [0u8; HEADER_LEN];
        flash.read(0, 0, &mut header).unwrap();
        header[4..8].copy_from_slice(&(FORMAT - 1).to_le_bytes());
        let crc = crc32(&header[..20]);
        header[20..24].copy_from_slice(&crc.to_le_bytes());
        flash.erase(0).unwrap();
        flash.write(0, 0, &header).unwrap();
        let report = Storage::new(&mut flash).load();
        assert_eq!(
            report,
            LoadReport {
                loaded: None,
                damaged: false
            }
        );
        // A new calibration then takes its place.
        let mut s = Storage::new(&mut flash);
        s.load();
        assert_eq!(s.store(&encoded(2)), Ok(1));
        assert_eq!(loaded_id(&mut flash), Some(2));
    }

    #[test]
    fn sequence_numbers_wrap() {
        assert!(newer(0, u32::MAX));
        assert!(newer(5, 4) && !newer(4, 5) && !newer(4, 4));
    }
}
