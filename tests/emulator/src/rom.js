//! A minimal RP2040 boot ROM of our own, plus the harness side of the ROM services it offers.
//!
//! rp2040js ships no bootrom. The firmware needs only a handful of ROM services (flash
//! programming, memcpy44 for the boot2 copy, reboot to the USB bootloader), found through the
//! documented lookup scheme: a 16-bit pointer to the function table at 0x14, the data table at
//! 0x16 and a 16-bit pointer to the lookup function at 0x18. Here the lookup function and every
//! service are two Thumb instructions, `BKPT #n; BX LR`: the breakpoint traps to the harness,
//! which does the work in JavaScript on the emulator's state (registers, RAM, the flash array)
//! and returns through `BX LR`. Nothing here is copied from a real bootrom: the image is built
//! below, instruction by instruction.

/** Thumb `BX LR`. */
const BX_LR = 0x4770;
/** Thumb `BKPT #imm8`. */
const bkpt = (imm8) => 0xbe00 | (imm8 & 0xff);

/** Initial stack pointer (top of the striped SRAM) used only until the firmware sets its own. */
const RESET_SP = 0x20042000;
/** Where the reset routine sits; the vector table occupies 0x00..0x40. */
const RESET_ROUTINE = 0x40;
/** Where the lookup function sits. */
const LOOKUP_FN = 0x60;
/** Trap number of the lookup function (distinct from every service number below). */
export const LOOKUP_TRAP = 0xf0;
/** Trap number of the ROM's own fault vectors (NMI/HardFault before the firmware's vectors). */
export const FAULT_TRAP = 0xfe;
/** Empty function and data tables (a zero code ends a table): nothing reads them but our lookup. */
const FUNC_TABLE = 0x80;
const DATA_TABLE = 0x84;
/** Service stubs start here, 4 bytes each (`BKPT #index; BX LR`). */
const STUBS = 0x100;
/** First address past the ROM code; a BKPT below it is a ROM service, above it a firmware fault. */
export const ROM_CODE_END = 0x400;

/** Two-character ROM function codes, as the datasheet's table lists them, in stub order. */
export const SERVICES = [
  'IF', // connect_internal_flash()
  'EX', // flash_exit_xip()
  'RE', // flash_range_erase(addr, count, block_size, block_cmd)
  'RP', // flash_range_program(addr, data, count)
  'FC', // flash_flush_cache()
  'CX', // flash_enter_cmd_xip()
  'UB', // reset_to_usb_boot(gpio_activity_pin_mask, disable_interface_mask)
  'C4', // memcpy44(dest, src, n) -> dest
  'MC', // memcpy(dest, src, n) -> dest
  'M4', // memset4(dest, value, n) -> dest
  'MS', // memset(dest, value, n) -> dest
];

/** The code a ROM table stores for a two-character name: first char in the low byte. */
export function romCode(name) {
  return name.charCodeAt(0) | (name.charCodeAt(1) << 8);
}

/**
 * Builds the ROM image as 32-bit words (what `RP2040.loadBootrom` takes).
 * @returns {Uint32Array}
 */
export function buildRom() {
  const bytes = new Uint8Array(ROM_CODE_END);
  const view = new DataView(bytes.buffer);
  const h = (addr, v) => view.setUint16(addr, v, true);
  const w = (addr, v) => view.setUint32(addr, v >>> 0, true);

  // Vector table: the core's reset reads SP and PC from here (VTOR = 0).
  w(0x00, RESET_SP);
  w(0x04, RESET_ROUTINE | 1);
  w(0x08, (LOOKUP_FN + 4) | 1); // NMI -> fault trap below
  w(0x0c, (LOOKUP_FN + 4) | 1); // HardFault -> fault trap below
  // Header: magic 'M' 'u' 0x01 and the ROM version byte (3 = the B2 silicon's).
  bytes.set([0x4d, 0x75, 0x01, 0x03], 0x10);
  h(0x14, FUNC_TABLE);
  h(0x16, DATA_TABLE);
  h(0x18, LOOKUP_FN | 1);

  // Reset routine: LR = 0 so that boot2, entered like the real ROM does, vectors into the
  // application instead of returning; then jump to boot2 at the start of flash.
  h(RESET_ROUTINE + 0x0, 0x2000); // movs r0, #0
  h(RESET_ROUTINE + 0x2, 0x4686); // mov  lr, r0
  h(RESET_ROUTINE + 0x4, 0x4801); // ldr  r0, [pc, #4]   (literal at +0xc)
  h(RESET_ROUTINE + 0x6, 0x4700); // bx   r0
  h(RESET_ROUTINE + 0x8, 0xbf00); // nop (literal alignment)
  h(RESET_ROUTINE + 0xa, 0xbf00); // nop
  w(RESET_ROUTINE + 0xc, 0x10000001); // boot2, Thumb bit set

  // Lookup function and the fault vector trap.
  h(LOOKUP_FN + 0, bkpt(LOOKUP_TRAP));
  h(LOOKUP_FN + 2, BX_LR);
  h(LOOKUP_FN + 4, bkpt(FAULT_TRAP));
  h(LOOKUP_FN + 6, 0xe7fe); // b . (never reached: the harness halts on the fault trap)

  // Zero-terminated empty tables.
  w(FUNC_TABLE, 0);
  w(DATA_TABLE, 0);

  SERVICES.forEach((_, i) => {
    h(STUBS + 4 * i, bkpt(i));
    h(STUBS + 4 * i + 2, BX_LR);
  });
  return new Uint32Array(bytes.buffer);
}

/** Address (Thumb bit set) of the stub of a service, or 0 if the ROM lacks it. */
export function serviceAddress(code) {
  const index = SERVICES.findIndex((name) => romCode(name) === code);
  return index < 0 ? 0 : (STUBS + 4 * index) | 1;
}

/** The name of a trap number's service, or undefined. */
export function serviceName(trap) {
  return SERVICES[trap];
}
