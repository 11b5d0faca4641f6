//! Counts the CPU cycles the firmware spends inside chosen functions, from the emulator's cycle
//! counter: a call starts when the PC reaches the function's entry, and ends when it comes back
//! to the return address with the stack pointer where it was at the call. Cycles spent in
//! interrupt handlers during the call are counted apart, so the figure is the function's own.
//! Each call also keeps the emulated time it started at, so tests can see when a periodic
//! function ran late.

/** Cycle statistics for the functions matching one name. */
export class CycleProbe {
  /**
   * @param {string} label
   * @param {Array<{name:string,value:number}>} functions
   * @param {() => number} now emulated time, ns
   */
  constructor(label, functions, now) {
    this.label = label;
    this.now = now;
    this.functions = functions;
    this.entries = new Set(functions.map((f) => f.value & ~1));
    this.calls = [];
    this.active = null;
  }

  /** Hooks the probe into a chip's instruction stream (again after every reset). */
  attach(mcu) {
    const core = mcu.core;
    const execute = core.executeInstruction.bind(core);
    this.active = null;
    core.executeInstruction = () => {
      const pc = core.PC;
      const active = this.active;
      if (active === null) {
        if (this.entries.has(pc)) {
          this.active = { ret: core.LR & ~1, sp: core.SP, start: core.cycles, startNs: this.now(), isr: 0 };
        }
      } else if (pc === active.ret && core.SP === active.sp && core.IPSR === 0) {
        this.calls.push({ total: core.cycles - active.start, isr: active.isr, startNs: active.startNs });
        if (this.calls.length > 10000) this.calls.shift();
        this.active = null;
      }
      const cycles = execute();
      if (this.active !== null && core.IPSR !== 0) this.active.isr += cycles;
      return cycles;
    };
  }

  /** Per-call cycles without interrupt handlers: count, min, mean, max, last. */
  stats() {
    const own = this.calls.map((c) => c.total - c.isr);
    if (own.length === 0) return { label: this.label, calls: 0 };
    const sum = own.reduce((a, b) => a + b, 0);
    return {
      label: this.label,
      functions: this.functions.map((f) => f.name),
      calls: own.length,
      min: Math.min(...own),
      mean: Math.round(sum / own.length),
      max: Math.max(...own),
      last: own[own.length - 1],
    };
  }

  /** The calls that started at or after `sinceNs`: start time (ns) and own cycles of each. */
  callsSince(sinceNs) {
    const calls = this.calls.filter((c) => c.startNs >= sinceNs);
    return { starts_ns: calls.map((c) => c.startNs), cycles: calls.map((c) => c.total - c.isr) };
  }

  /** Forgets the calls seen so far. */
  clear() {
    this.calls = [];
  }
}
