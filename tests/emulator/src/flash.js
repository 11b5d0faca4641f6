//! The ROM's flash services, done by the harness on the emulator's flash array, with an
//! optional power cut in the middle of one.
//!
//! rp2040js's SSI does not model flash programming, so the ROM stubs trap here. Erase sets
//! whole 4 KiB sectors to 0xFF; program ANDs bytes in, as NOR flash can only clear bits. A
//! fault armed with `armCut` stops the n-th erase/program after `bytes` bytes and asks for a chip
//! reset: the state a power loss in the middle of a flash write leaves behind.
//!
//! The flash chip is busy for a while after each erase and program, and the core waits for it
//! (the ROM polls the chip's status with interrupts off): `takeBusy` hands that time to the run
//! loop, which lets it pass without running an instruction. The times are a W25Q16JV's (the
//! Raspberry Pi Pico's flash chip), from its datasheet.

const SECTOR = 4096;
/** The chip programs at most one 256-byte page per program command. */
const PAGE = 256;

/**
 * Busy time of the flash chip per 4 KiB sector erase (tSE) and per page program (tPP), ns:
 * `typical` and `max` are the W25Q16JV datasheet's typical and maximum; `none` makes flash
 * writes instantaneous.
 */
export const FLASH_TIMINGS = {
  none: { eraseSectorNs: 0, programPageNs: 0 },
  typical: { eraseSectorNs: 45e6, programPageNs: 0.4e6 },
  max: { eraseSectorNs: 400e6, programPageNs: 3e6 },
};

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
  constructor(log, timing = 'typical') {
    this.log = log;
    this.cut = null;
    this.erases = 0;
    this.programs = 0;
    this.setTiming(timing);
    /** Chip busy time of the operations done but not yet waited for, ns. */
    this.busyNs = 0;
    /** Chip busy time of every operation so far, ns. */
    this.busyTotalNs = 0;
  }

  /** Chooses the chip's busy times by name (a key of FLASH_TIMINGS). */
  setTiming(name) {
    const timing = FLASH_TIMINGS[name];
    if (!timing) throw new Error(`unknown flash timing '${name}' (expected ${Object.keys(FLASH_TIMINGS).join(', ')})`);
    this.timingName = name;
    this.timing = timing;
  }

  /** The chip busy time of the operations since the last call, ns (the core waits that long). */
  takeBusy() {
    const busy = this.busyNs;
    this.busyNs = 0;
    return busy;
  }

  busy(ns) {
    this.busyNs += ns;
    this.busyTotalNs += ns;
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
        if (cut) return 'reset';
        this.busy(((end - start) / SECTOR) * this.timing.eraseSectorNs);
        return 'ok';
      }
      case 'RP': {
        const [offset, data, count] = [r[0], r[1], r[2]];
        this.programs += 1;
        const cut = this.cutNow('program');
        const n = cut ? Math.min(count, cut.bytes) : count;
        for (let i = 0; i < n && offset + i < flash.length; i++) {
          flash[offset + i] &= mcu.readUint8(data + i);
        }
        if (cut) return 'reset';
        const pages = count === 0 ? 0 : Math.ceil((offset + count) / PAGE) - Math.floor(offset / PAGE);
        this.busy(pages * this.timing.programPageNs);
        return 'ok';
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
