//! Calling one function on the emulated core: the results come back and the core is put back
//! as it was, so the board goes on undisturbed.

import assert from 'node:assert/strict';
import { test } from 'node:test';
import { RP2040 } from 'rp2040js';
import { callFunction } from '../src/function-call.js';

/** A bare chip with `code` (Thumb halfwords) in RAM; returns the chip and the code's address. */
function chipWith(code) {
  const mcu = new RP2040();
  mcu.logger = { debug() {}, info() {}, warn() {}, error() {} };
  const address = 0x20001000;
  code.forEach((halfword, i) => mcu.writeUint16(address + 2 * i, halfword));
  mcu.core.SP = 0x20040000;
  return { mcu, address };
}

test('returns r0 of each call and its cycles', () => {
  // push {r4}; muls r0, r1, r0; adds r0, r0, r2; pop {r4}; bx lr
  const { mcu, address } = chipWith([0xb410, 0x4348, 0x1880, 0xbc10, 0x4770]);
  const { results, cycles } = callFunction(mcu, address, [[6, 7, 1], [0xffffffff, 2, 0]]);
  assert.deepEqual(results, [43, 0xfffffffe]);
  assert.equal(cycles.length, 2);
  assert.ok(cycles.every((c) => c >= 5 && c < 20), `cycles ${cycles}`);
});

test('puts the registers, flags, interrupt mask and cycle counter back', () => {
  const { mcu, address } = chipWith([0x4348, 0x4770]); // muls r0, r1, r0; bx lr
  const core = mcu.core;
  core.registers.set([1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 0x20040000, 0x1234, 0x10000100]);
  core.APSR = 0x60000000;
  core.PM = false;
  core.cycles = 777;
  const before = core.registers.slice();
  callFunction(mcu, address, [[3, 5]]);
  assert.deepEqual(core.registers, before);
  assert.equal(core.APSR, 0x60000000);
  assert.equal(core.PM, false);
  assert.equal(core.cycles, 777);
});

test('a function that does not return is an error, and the core is still put back', () => {
  const { mcu, address } = chipWith([0xe7fe]); // b .
  const pc = mcu.core.PC;
  assert.throws(() => callFunction(mcu, address, [[1]]), /did not return/);
  assert.equal(mcu.core.PC, pc);
});
