//! Reads the firmware's defmt-rtt output out of emulated RAM, acting as the debug probe would.
//!
//! defmt-rtt keeps a SEGGER RTT control block at the `_SEGGER_RTT` symbol: a 16-byte id, the
//! up/down buffer counts, then one descriptor per up buffer (name, buffer, size, write offset,
//! read offset, flags). We copy the bytes between the read and the write offsets and advance the
//! read offset, so the firmware never finds its buffer full. The bytes are defmt-encoded (a
//! table index per message plus arguments): decoding needs the ELF's defmt table, which
//! `defmt-print` does when it is installed (see `decoder.js`).

const UP0 = 24;

/** The up-channel 0 reader of one emulated chip. */
export class RttReader {
  /** @param {import('rp2040js').RP2040} mcu @param {number|undefined} address `_SEGGER_RTT` */
  constructor(mcu, address) {
    this.mcu = mcu;
    this.address = address;
  }

  /** Returns the new bytes since the last poll (empty before the firmware set the block up). */
  poll() {
    const { mcu, address } = this;
    if (address === undefined) return new Uint8Array(0);
    const word = (offset) => mcu.readUint32(address + offset) >>> 0;
    if (word(16) < 1) return new Uint8Array(0); // max_up_buffers not written yet
    const buffer = word(UP0 + 4);
    const size = word(UP0 + 8);
    const write = word(UP0 + 12);
    let read = word(UP0 + 16);
    if (size === 0 || size > 0x10000 || write >= size || read >= size) return new Uint8Array(0);
    const out = [];
    while (read !== write) {
      out.push(mcu.readUint8(buffer + read));
      read = (read + 1) % size;
    }
    mcu.writeUint32(address + UP0 + 16, read);
    return Uint8Array.from(out);
  }
}
