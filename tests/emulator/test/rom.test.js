//! The ROM stub, run on rp2040js's own CPU: the lookup finds every service, the reset path
//! reaches boot2 with LR = 0, and the flash services behave like NOR flash (and can be cut).

import assert from 'node:assert/strict';
import { test } from 'node:test';
import { RP2040 } from 'rp2040js';
import { FLASH_TIMINGS, FlashServices } from '../src/flash.js';
import { buildRom, LOOKUP_TRAP, romCode, serviceName, SERVICES } from '../src/rom.js';

/** A bare chip on our ROM; BKPTs run the flash services like the board does. */
function chip() {
  const mcu = new RP2040();
  mcu.logger = { debug() {}, info() {}, warn() {}, error() {} };
  mcu.loadBootrom(buildRom());
  const services = new FlashServices(() => {});
  const traps = [];
  mcu.onBreak = (code) => {
    traps.push(code);
    const r = mcu.core.registers;
    if (code === LOOKUP_TRAP) return; // answered by the caller of `call` below
    services.call(serviceName(code), mcu, r);
  };
  return { mcu, services, traps };
}

/** Calls a ROM function at `address` with arguments; returns r0 when it comes back. */
function call(mcu, address, args, onLookup) {
  const RETURN = 0x20010000;
  mcu.writeUint16(RETURN, 0xe7fe); // b . : where the call returns
  args.forEach((a, i) => {
    mcu.core.registers[i] = a;
  });
  mcu.core.LR = RETURN | 1;
  mcu.core.PC = address & ~1;
  mcu.core.SP = 0x20040000;
  for (let i = 0; i < 100 && mcu.core.PC !== RETURN; i++) {
    const pc = mcu.core.PC;
    mcu.core.executeInstruction();
    if (onLookup && pc === (mcu.readUint16(0x18) & ~1)) onLookup(mcu.core.registers);
  }
  assert.equal(mcu.core.PC, RETURN, 'the ROM function did not return');
  return mcu.core.registers[0] >>> 0;
}

test('header has the magic, the version and 16-bit table pointers', () => {
  const { mcu } = chip();
  assert.deepEqual([0x10, 0x11, 0x12].map((a) => mcu.readUint8(a)), [0x4d, 0x75, 0x01]);
  assert.equal(mcu.readUint16(0x18) & 1, 1, 'the lookup function pointer has the Thumb bit');
  assert.notEqual(mcu.readUint16(0x14), 0);
});

test('reset runs the ROM reset routine into boot2 with LR = 0', () => {
  const { mcu } = chip();
  mcu.core.LR = 0x1234;
  mcu.core.reset();
  for (let i = 0; i < 10 && mcu.core.PC !== 0x10000000; i++) mcu.core.executeInstruction();
  assert.equal(mcu.core.PC, 0x10000000);
  assert.equal(mcu.core.LR, 0);
  assert.equal(mcu.core.SP, 0x20042000);
});

test('the lookup function traps, and every service stub traps with its own number', async () => {
  const { mcu, traps } = chip();
  const lookup = mcu.readUint16(0x18);
  const { serviceAddress } = await import('../src/rom.js');
  for (const [index, name] of SERVICES.entries()) {
    const address = call(mcu, lookup, [mcu.readUint16(0x14), romCode(name)], (r) => {
      r[0] = serviceAddress(r[1]);
    });
    assert.equal(address & 1, 1, `${name}: Thumb bit`);
    traps.length = 0;
    if (name === 'UB') continue; // the board halts there; nothing to run
    call(mcu, address, [0x20020000, 0x20020000, 0, 0]);
    assert.deepEqual(traps, [index], `${name} stub traps with #${index}`);
  }
});

test('erase sets whole sectors to 0xFF, program can only clear bits', () => {
  const { mcu, services } = chip();
  mcu.flash.fill(0x00, 0x1000, 0x3000);
  const at = (a) => SERVICES.indexOf(a) * 4 + 0x101;
  call(mcu, at('RE'), [0x1000, 0x1000, 1 << 31, 0]);
  assert.equal(mcu.flash[0x1000], 0xff);
  assert.equal(mcu.flash[0x1fff], 0xff);
  assert.equal(mcu.flash[0x2000], 0x00, 'the next sector is untouched');
  const data = 0x20020000;
  [0xf0, 0x0f, 0xaa].forEach((b, i) => mcu.writeUint8(data + i, b));
  call(mcu, at('RP'), [0x1000, data, 3]);
  assert.deepEqual([...mcu.flash.subarray(0x1000, 0x1003)], [0xf0, 0x0f, 0xaa]);
  call(mcu, at('RP'), [0x1000, data + 1, 1]); // 0xf0 & 0x0f: a write without erase ANDs
  assert.equal(mcu.flash[0x1000], 0x00);
  assert.equal(services.erases, 1);
  assert.equal(services.programs, 2);
});

test('an armed power cut stops the n-th program part-way and asks for a reset', () => {
  const { mcu } = chip();
  const services = new FlashServices(() => {});
  services.armCut('program', 2, 5);
  const data = 0x20020000;
  for (let i = 0; i < 16; i++) mcu.writeUint8(data + i, i);
  const regs = (offset) => Uint32Array.from([offset, data, 16, 0]);
  assert.equal(services.call('RP', mcu, regs(0x4000)), 'ok');
  assert.equal(services.call('RP', mcu, regs(0x5000)), 'reset');
  assert.deepEqual([...mcu.flash.subarray(0x5000, 0x5006)], [0, 1, 2, 3, 4, 0xff]);
  assert.equal(services.call('RP', mcu, regs(0x6000)), 'ok', 'a cut fires once');
});

test('the flash chip is busy per erased sector and per programmed page, as timed', () => {
  const { mcu } = chip();
  const data = 0x20020000;
  const services = new FlashServices(() => {});
  assert.equal(services.timingName, 'typical', 'the default is the datasheet\'s typical timing');
  services.call('RE', mcu, Uint32Array.from([0x2000, 0x2000, 0, 0]));
  assert.equal(services.takeBusy(), 2 * FLASH_TIMINGS.typical.eraseSectorNs, 'two sectors');
  assert.equal(services.takeBusy(), 0, 'busy time is handed out once');
  // 300 bytes from offset 250 touch three 256-byte pages.
  services.call('RP', mcu, Uint32Array.from([0x2000 + 250, data, 300, 0]));
  assert.equal(services.takeBusy(), 3 * FLASH_TIMINGS.typical.programPageNs);
  services.setTiming('max');
  services.call('RP', mcu, Uint32Array.from([0x2000, data, 256, 0]));
  assert.equal(services.takeBusy(), FLASH_TIMINGS.max.programPageNs);
  assert.equal(services.busyTotalNs, 2 * 45e6 + 3 * 0.4e6 + 3e6);
  services.setTiming('none');
  services.call('RE', mcu, Uint32Array.from([0x2000, 0x1000, 0, 0]));
  assert.equal(services.takeBusy(), 0);
  assert.throws(() => services.setTiming('slow'), /unknown flash timing 'slow'/);
  // A write cut by a power loss leaves no wait behind: the chip resets.
  services.setTiming('typical');
  services.armCut('erase', 1, 100);
  assert.equal(services.call('RE', mcu, Uint32Array.from([0x2000, 0x1000, 0, 0])), 'reset');
  assert.equal(services.takeBusy(), 0);
});

test('memcpy44 copies words (the flash driver copies boot2 with it)', () => {
  const { mcu } = chip();
  for (let i = 0; i < 8; i++) mcu.writeUint8(0x20020000 + i, 0x10 + i);
  const at = SERVICES.indexOf('C4') * 4 + 0x101;
  const r0 = call(mcu, at, [0x20030000, 0x20020000, 8]);
  assert.equal(r0, 0x20030000);
  assert.equal(mcu.readUint32(0x20030004), 0x17161514);
});
