//! Pulse capture from edges and the ELF reader, on synthetic input.

import assert from 'node:assert/strict';
import { test } from 'node:test';
import { GPIOPinState } from 'rp2040js';
import { Elf, ElfError } from '../src/elf.js';
import { PwmCapture } from '../src/pwm-capture.js';

test('pulse widths and periods come from edge timestamps', () => {
  const listeners = [];
  const clock = { nanos: 0 };
  const mcu = { gpio: [{ addListener: (f) => listeners.push(f) }] };
  const capture = new PwmCapture([0], () => clock.nanos);
  capture.attach(mcu);
  const edge = (t, v) => {
    clock.nanos = t;
    listeners[0](v);
  };
  edge(1000, GPIOPinState.High);
  edge(1_651_000, GPIOPinState.Low);
  edge(20_001_000, GPIOPinState.High);
  edge(21_501_000, GPIOPinState.Low);
  const pulses = capture.pulsesSince(0, 0);
  assert.deepEqual(
    pulses.map((p) => [p.widthNs, p.periodNs]),
    [
      [1_650_000, null],
      [1_500_000, 20_000_000],
    ],
  );
  assert.equal(capture.pulsesSince(0, 2_000_000).length, 1);
});

/** A minimal ARM ELF32 with one PT_LOAD at 0x10000000 and a symbol table. */
function tinyElf() {
  const b = new Uint8Array(0x200);
  const v = new DataView(b.buffer);
  b.set([0x7f, 0x45, 0x4c, 0x46, 1, 1, 1]);
  v.setUint16(18, 40, true); // EM_ARM
  v.setUint32(28, 52, true); // phoff
  v.setUint32(32, 0x100, true); // shoff
  v.setUint16(42, 32, true);
  v.setUint16(44, 1, true);
  v.setUint16(46, 40, true);
  v.setUint16(48, 3, true);
  // PT_LOAD: offset 0x90, paddr 0x10000000, 4 bytes
  v.setUint32(52, 1, true);
  v.setUint32(56, 0x90, true);
  v.setUint32(64, 0x10000000, true);
  v.setUint32(68, 4, true);
  b.set([0xde, 0xad, 0xbe, 0xef], 0x90);
  // section 1: symtab at 0xa0 (2 entries), link to section 2 (strtab at 0xd0)
  const sh = (i) => 0x100 + i * 40;
  v.setUint32(sh(1) + 4, 2, true);
  v.setUint32(sh(1) + 16, 0xa0, true);
  v.setUint32(sh(1) + 20, 32, true);
  v.setUint32(sh(1) + 24, 2, true);
  v.setUint32(sh(2) + 16, 0xd0, true);
  b.set(new TextEncoder().encode('\0_SEGGER_RTT\0servo_frame\0'), 0xd0);
  v.setUint32(0xa0, 1, true);
  v.setUint32(0xa4, 0x20000100, true);
  v.setUint32(0xb0, 13, true);
  v.setUint32(0xb4, 0x10000041, true);
  v.setUint32(0xb8, 20, true);
  b[0xbc] = 2; // STT_FUNC
  return b;
}

test('the ELF reader finds load segments and symbols', () => {
  const elf = new Elf(tinyElf());
  assert.equal(elf.symbol('_SEGGER_RTT'), 0x20000100);
  assert.deepEqual(elf.functionsMatching('servo').map((f) => f.value), [0x10000041]);
  const flash = new Uint8Array(4096).fill(0xff);
  assert.equal(elf.writeFlash(flash), 4);
  assert.deepEqual([...flash.subarray(0, 5)], [0xde, 0xad, 0xbe, 0xef, 0xff]);
});

test('a truncated or foreign file is refused with a reason', () => {
  assert.throws(() => new Elf(new Uint8Array(10), 'x.elf'), (e) => e instanceof ElfError && /x.elf: truncated/.test(e.message));
  const notArm = tinyElf();
  notArm[18] = 62;
  assert.throws(() => new Elf(notArm, 'y.elf'), /not an ARM ELF/);
});
