//! Measures servo pulses from GPIO edges, timed by the emulator's clock.
//!
//! rp2040js drives PWM outputs from clock alarms, so an edge's timestamp is exact: a pulse is
//! the time from a rising to the next falling edge, a period the time between rising edges.

import { GPIOPinState } from 'rp2040js';

/** How many pulses each pin keeps. */
const HISTORY = 256;

/** Edge recorder on a set of pins; it outlives chip resets (re-attach it to the new chip). */
export class PwmCapture {
  /** @param {number[]} pins GPIO numbers @param {() => number} now emulated time, ns */
  constructor(pins, now) {
    this.now = now;
    /** @type {Map<number, {rise:number|null, lastRise:number|null, pulses:Array<{startNs:number,widthNs:number,periodNs:number|null}>}>} */
    this.pins = new Map(pins.map((pin) => [pin, { rise: null, lastRise: null, pulses: [] }]));
  }

  /** Listens to the pins of a (new) chip; a pulse cut by a reset is not counted. */
  attach(mcu) {
    for (const [pin, state] of this.pins) {
      state.rise = null;
      state.lastRise = null;
      mcu.gpio[pin].addListener((value) => this.edge(state, value));
    }
  }

  edge(state, value) {
    const now = this.now();
    if (value === GPIOPinState.High) {
      state.lastRise = state.rise;
      state.rise = now;
    } else if (value === GPIOPinState.Low && state.rise !== null) {
      state.pulses.push({
        startNs: state.rise,
        widthNs: now - state.rise,
        periodNs: state.lastRise === null ? null : state.rise - state.lastRise,
      });
      if (state.pulses.length > HISTORY) state.pulses.shift();
    }
  }

  /** Pulses of a pin that started at or after `sinceNs`. */
  pulsesSince(pin, sinceNs) {
    return (this.pins.get(pin)?.pulses ?? []).filter((p) => p.startNs >= sinceNs);
  }
}
