//! The run loop's sleep: a chip waiting for an interrupt wakes at its clock's next alarm, also
//! after resets have pushed the board's emulated time far from the chip's own clock.

import assert from 'node:assert/strict';
import { test } from 'node:test';
import { RP2040 } from 'rp2040js';
import { Board } from '../src/board.js';
import { tickThroughNextAlarm } from '../src/clock-step.js';

/** A board whose core sleeps (WFI) on a chip clock that started `baseNanos` after power-on. */
function sleepingBoard(baseNanos, clockNanos) {
  const mcu = new RP2040();
  mcu.clock.tick(clockNanos);
  mcu.core.waiting = true;
  const board = Object.create(Board.prototype);
  Object.assign(board, { mcu, baseNanos, stallNanos: 0, timers: [], pendingReset: null, halted: null });
  return board;
}

test('a sleeping chip reaches its alarm when earlier resets carry odd nanoseconds', () => {
  // Found by search: adding the alarm's distance to the board's time and taking the board's
  // time off again rounds a step that stops a fraction of a nanosecond short of the alarm.
  const board = sleepingBoard(3356243004.607, 27.583);
  let fired = false;
  board.mcu.clock.createAlarm(() => {
    fired = true;
  }).schedule(535.487);
  board.run(Infinity, 10);
  assert.ok(fired, `the alarm did not fire; the chip's clock stands at ${board.mcu.clock.nanos} ns`);
});

test('a sleeping chip wakes for an alarm already due, and for harness timers', () => {
  const board = sleepingBoard(1e9 + 0.3, 12.7);
  let alarms = 0;
  board.mcu.clock.createAlarm(() => {
    alarms += 1;
  }).schedule(0);
  let timers = 0;
  board.after(3, () => {
    timers += 1;
  });
  board.run(Infinity, 10);
  assert.equal(alarms, 1);
  assert.equal(timers, 1);
});

test('a step to an alarm always arrives, however the clock stands', () => {
  const clock = new RP2040().clock;
  for (const [start, delta] of [
    [0, 0],
    [8.034385832143016, 1178599.8814790915],
    [0.1, 1e15],
  ]) {
    clock.tick(start);
    let fired = false;
    clock.createAlarm(() => {
      fired = true;
    }).schedule(delta);
    tickThroughNextAlarm(clock);
    assert.ok(fired, `alarm ${delta} ns after ${clock.nanos} ns`);
  }
});

test('an overdue harness timer fires without lengthening a flash stall', () => {
  const board = sleepingBoard(2e9 + 0.7, 4000.25);
  board.mcu.core.waiting = false;
  board.stallNanos = 1000;
  let fired = 0;
  board.timers.push({ at: board.nanos - 50, fn: () => (fired += 1) });
  const before = board.mcu.clock.nanos;
  board.run(Infinity, 1);
  assert.equal(fired, 1);
  assert.equal(board.stallNanos, 1000);
  assert.equal(board.mcu.clock.nanos, before);
  board.run(Infinity, 1);
  assert.equal(board.stallNanos, 0);
  assert.equal(board.mcu.clock.nanos, before + 1000);
});
