//! Reads what the harness needs from the firmware's ELF: the flash image and the symbol table.
//!
//! The flash image is built from the loadable segments at their load (physical) addresses, as a
//! flasher would write them: `.data`'s initial values sit in flash and are copied to RAM by the
//! firmware's own start-up code. Symbols give the RTT control block and the functions whose
//! cycles the benchmark counts.

import { readFileSync } from 'node:fs';

const PT_LOAD = 1;
const SHT_SYMTAB = 2;
const STT_FUNC = 2;

/** Start of the RP2040's XIP flash window. */
export const FLASH_BASE = 0x10000000;

/** Thrown for a file that is not a 32-bit little-endian ARM ELF or is truncated. */
export class ElfError extends Error {}

/**
 * A parsed firmware ELF.
 * @property {Array<{paddr:number,data:Uint8Array}>} segments loadable bytes by load address
 * @property {Array<{name:string,value:number,size:number,func:boolean}>} symbols
 */
export class Elf {
  /** @param {string} path */
  static load(path) {
    let buf;
    try {
      buf = readFileSync(path);
    } catch (e) {
      throw new ElfError(`cannot read firmware ELF ${path}: ${e.message}`);
    }
    return new Elf(new Uint8Array(buf.buffer, buf.byteOffset, buf.byteLength), path);
  }

  /** @param {Uint8Array} bytes @param {string} name for messages */
  constructor(bytes, name = 'ELF') {
    const v = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const need = (off, len, what) => {
      if (off + len > bytes.length) {
        throw new ElfError(`${name}: truncated (${what} at byte ${off} past end ${bytes.length})`);
      }
    };
    need(0, 52, 'ELF header');
    if (v.getUint32(0, false) !== 0x7f454c46) throw new ElfError(`${name}: not an ELF file`);
    if (bytes[4] !== 1 || bytes[5] !== 1) {
      throw new ElfError(`${name}: expected a 32-bit little-endian ELF (thumbv6m-none-eabi)`);
    }
    if (v.getUint16(18, true) !== 40) throw new ElfError(`${name}: not an ARM ELF`);
    this.entry = v.getUint32(24, true);
    const phoff = v.getUint32(28, true);
    const shoff = v.getUint32(32, true);
    const phentsize = v.getUint16(42, true);
    const phnum = v.getUint16(44, true);
    const shentsize = v.getUint16(46, true);
    const shnum = v.getUint16(48, true);

    this.segments = [];
    for (let i = 0; i < phnum; i++) {
      const o = phoff + i * phentsize;
      need(o, 32, `program header ${i}`);
      if (v.getUint32(o, true) !== PT_LOAD) continue;
      const offset = v.getUint32(o + 4, true);
      const paddr = v.getUint32(o + 12, true);
      const filesz = v.getUint32(o + 16, true);
      if (filesz === 0) continue;
      need(offset, filesz, `segment ${i}`);
      this.segments.push({ paddr, data: bytes.slice(offset, offset + filesz) });
    }

    this.symbols = [];
    for (let i = 0; i < shnum; i++) {
      const o = shoff + i * shentsize;
      need(o, 40, `section header ${i}`);
      if (v.getUint32(o + 4, true) !== SHT_SYMTAB) continue;
      const symOff = v.getUint32(o + 16, true);
      const symSize = v.getUint32(o + 20, true);
      const strIndex = v.getUint32(o + 24, true);
      const so = shoff + strIndex * shentsize;
      need(so, 40, `string table header ${strIndex}`);
      const strOff = v.getUint32(so + 16, true);
      need(symOff, symSize, 'symbol table');
      for (let s = symOff; s + 16 <= symOff + symSize; s += 16) {
        const nameOff = strOff + v.getUint32(s, true);
        let end = nameOff;
        while (end < bytes.length && bytes[end] !== 0) end++;
        const symName = new TextDecoder().decode(bytes.subarray(nameOff, end));
        if (!symName) continue;
        this.symbols.push({
          name: symName,
          value: v.getUint32(s + 4, true),
          size: v.getUint32(s + 8, true),
          func: (bytes[s + 12] & 0xf) === STT_FUNC,
        });
      }
    }
  }

  /** The address of a symbol by exact name, or undefined. */
  symbol(name) {
    return this.symbols.find((s) => s.name === name)?.value;
  }

  /** Function symbols whose (mangled) name contains `part`. */
  functionsMatching(part) {
    return this.symbols.filter((s) => s.func && s.name.includes(part));
  }

  /**
   * Writes the segments that load into flash into a flash array (index 0 = 0x10000000).
   * @param {Uint8Array} flash
   * @returns {number} the highest flash offset written, i.e. the image size
   */
  writeFlash(flash) {
    let end = 0;
    for (const { paddr, data } of this.segments) {
      if (paddr < FLASH_BASE || paddr + data.length > FLASH_BASE + flash.length) continue;
      flash.set(data, paddr - FLASH_BASE);
      end = Math.max(end, paddr - FLASH_BASE + data.length);
    }
    if (end === 0) throw new ElfError('the ELF has no segment that loads into flash at 0x10000000');
    return end;
  }
}
