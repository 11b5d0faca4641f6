//! The ROM's flash services, done by the harness on the emulator's flash array, with an
//! optional power cut in the middle of one.
//!
//! rp2040js's SSI does not model flash programming, so the ROM stubs trap here. Erase sets
//! whole 4 KiB sectors to 0xFF; program ANDs bytes in, as NOR flash can only clear bits. A
//! fault armed with `armCut` stops the n-th erase/program after `bytes` bytes and asks for a chip
//! reset: the state a power loss in the middle of a flash write leaves behind.

const SECTOR = 4096;

/** A flash fault armed for a coming erase or program. */
export class FlashCut {
  /**
   * @param {'erase'|'program'|'any'} op which operations count
   * @param {number} nth the 1-based count of matching operations at which to cut
   * @param {number} bytes how many bytes of that operation still happen
   */
  constructor(op, nth, bytes) {
    this.op = op;
    this.nth = nth;
    this.bytes = bytes;
    this.seen = 0;
    this.fired = false;
  }
}

/** Flash erase/program plus bookkeeping the tests read. */
export class FlashServices {
  constructor(log) {
    this.log = log;
    this.cut = null;
    this.erases = 0;
    this.programs = 0;
  }

  /** Arms a power cut; replaces any armed before. */
  armCut(op, nth, bytes) {
    this.cut = new FlashCut(op, nth, bytes);
    return this.cut;
  }

  /** Whether the armed cut (if any) should fire for this operation. */
  cutNow(op) {
    const cut = this.cut;
    if (!cut || cut.fired || (cut.op !== 'any' && cut.op !== op)) return null;
    cut.seen += 1;
    if (cut.seen < cut.nth) return null;
    cut.fired = true;
    return cut;
  }

  /**
   * Runs one ROM service with the core's registers (r0..r3 in, r0 out).
   * @returns {'ok'|'reset'|'usb-boot'}
   */
  call(name, mcu, r) {
    const flash = mcu.flash;
    switch (name) {
      case 'IF': // connect_internal_flash
      case 'EX': // flash_exit_xip
      case 'FC': // flash_flush_cache
      case 'CX': // flash_enter_cmd_xip: our flash array is always readable
        return 'ok';
      case 'RE': {
        const start = r[0] - (r[0] % SECTOR);
        const end = Math.min(flash.length, Math.ceil((r[0] + r[1]) / SECTOR) * SECTOR);
        if (r[0] % SECTOR || r[1] % SECTOR) {
          this.log(`flash_range_erase(0x${r[0].toString(16)}, ${r[1]}) not sector aligned`);
        }
        this.erases += 1;
        const cut = this.cutNow('erase');
        const stop = cut ? Math.min(end, start + cut.bytes) : end;
        flash.fill(0xff, start, stop);
        return cut ? 'reset' : 'ok';
      }
      case 'RP': {
        const [offset, data, count] = [r[0], r[1], r[2]];
        this.programs += 1;
        const cut = this.cutNow('program');
        const n = cut ? Math.min(count, cut.bytes) : count;
        for (let i = 0; i < n && offset + i < flash.length; i++) {
          flash[offset + i] &= mcu.readUint8(data + i);
        }
        return cut ? 'reset' : 'ok';
      }
      case 'UB':
        return 'usb-boot';
      case 'C4':
      case 'MC': {
        const [dest, src, n] = [r[0], r[1], r[2]];
        for (let i = 0; i < n; i++) mcu.writeUint8(dest + i, mcu.readUint8(src + i));
        return 'ok';
      }
      case 'M4':
      case 'MS': {
        const [dest, value, n] = [r[0], r[1] & 0xff, r[2]];
        for (let i = 0; i < n; i++) mcu.writeUint8(dest + i, value);
        return 'ok';
      }
      default:
        throw new Error(`ROM service '${name}' has a stub but no implementation`);
    }
  }
}
