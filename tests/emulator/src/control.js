//! The test-control channel: JSON lines on stdin, replies and events as JSON lines on stdout.
//!
//! Requests are `{"id": N, "cmd": NAME, ...}`; each gets `{"id": N, "ok": true, ...}` or
//! `{"id": N, "ok": false, "error": TEXT}`. Unprompted events carry `"event"` instead of `"id"`.
//! Waits are in emulated time, bounded by an emulated-time timeout, so a test never hangs on a
//! board that stopped.
//!
//! | cmd | arguments | reply |
//! |---|---|---|
//! | `status` | | `nanos`, `resets`, `halted`, `configured`, `erases`, `programs`, `flash_busy_ns`, `flash_timing`, `last_erase_ns` |
//! | `wait_configured` | `timeout_ms` | `nanos` once USB is enumerated |
//! | `run` | `us` | `nanos` after that much emulated time |
//! | `pulses` | `pins`, `count`, `timeout_ms` | per pin `widths_us`, `periods_us` of the next `count` pulses |
//! | `pulses_since` | `pins`, `since_ns` | per pin `widths_us` of every pulse since that time |
//! | `reset` | | chip reset now, flash kept |
//! | `cut_flash` | `op` (erase/program/any), `nth`, `bytes` | arms a power cut |
//! | `flash_timing` | `timing` (none/typical/max) | the flash chip's busy time per erase and program from now on |
//! | `cut_status` | | `armed`, `fired` |
//! | `flash_read` | `offset`, `length` | `hex` |
//! | `rtt` | | `hex` (all raw defmt bytes so far), `lines` (decoded, if defmt-print) |
//! | `busy_cycles` | `windows`, `window_us` | CPU cycles executed (not asleep) in each window |
//! | `probe` | `symbol` | adds a cycle probe; `functions` |
//! | `probe_stats` | `symbol`, `clear` | `calls`, `min`, `mean`, `max`, `last` cycles |
//! | `probe_calls` | `symbol`, `since_ns` | `starts_ns` (emulated start time) and `cycles` of each call since then |
//! | `call` | `symbol` (exact name), `args` (lists of up to four u32) | `results` (r0 of each call), `cycles` of each |
//! | `quit` | | the process exits |

import { createInterface } from 'node:readline';

/** Answers control requests for one board. */
export class Control {
  /**
   * @param {import('./board.js').Board} board
   * @param {{rttBytes:()=>Uint8Array, rttLines:()=>string[], settle:()=>Promise<void>, quit:()=>void}} logs
   */
  constructor(board, logs) {
    this.board = board;
    this.logs = logs;
    this.configured = false;
    board.on('configured', () => {
      this.configured = true;
      this.event({ event: 'configured', nanos: board.nanos });
    });
    board.on('reset', ({ reason }) => {
      this.configured = false;
      this.event({ event: 'reset', reason, nanos: board.nanos });
    });
    board.on('halted', ({ reason }) => this.event({ event: 'halted', reason, nanos: board.nanos }));
  }

  event(object) {
    process.stdout.write(`${JSON.stringify(object)}\n`);
  }

  /** Reads requests from stdin until it closes (then quits). */
  listen() {
    const lines = createInterface({ input: process.stdin });
    lines.on('line', (line) => this.line(line));
    lines.on('close', () => this.logs.quit());
  }

  async line(line) {
    if (!line.trim()) return;
    let request;
    try {
      request = JSON.parse(line);
    } catch (e) {
      this.event({ id: null, ok: false, error: `control line is not JSON: ${e.message}` });
      return;
    }
    try {
      const reply = await this.handle(request);
      this.event({ id: request.id ?? null, ok: true, ...reply });
    } catch (e) {
      this.event({ id: request.id ?? null, ok: false, error: e.message });
    }
  }

  /** Resolves when `done()` is true, checked as emulated time passes; rejects after the timeout. */
  waitFor(done, timeoutMs, what) {
    const board = this.board;
    const deadline = board.nanos + timeoutMs * 1e6;
    return new Promise((resolve, reject) => {
      const check = () => {
        const value = done();
        if (value) return resolve(value);
        if (board.halted) return reject(new Error(`${what}: board halted: ${board.halted}`));
        if (board.nanos >= deadline) {
          return reject(new Error(`${what}: not within ${timeoutMs} ms of emulated time`));
        }
        board.after(1000, check);
      };
      check();
    });
  }

  async handle(request) {
    const { board } = this;
    switch (request.cmd) {
      case 'status':
        return {
          nanos: board.nanos,
          resets: board.resets,
          halted: board.halted,
          configured: this.configured,
          erases: board.flashServices.erases,
          programs: board.flashServices.programs,
          flash_busy_ns: board.flashServices.busyTotalNs,
          flash_timing: board.flashServices.timingName,
          last_erase_ns: board.lastEraseNanos,
        };
      case 'wait_configured':
        await this.waitFor(() => this.configured, request.timeout_ms ?? 2000, 'USB enumeration');
        return { nanos: board.nanos };
      case 'run': {
        const until = board.nanos + (request.us ?? 0) * 1000;
        await this.waitFor(() => board.nanos >= until, (request.us ?? 0) / 1000 + 1000, 'run');
        return { nanos: board.nanos };
      }
      case 'pulses': {
        const pins = request.pins ?? board.servoPins;
        const count = request.count ?? 2;
        const since = board.nanos;
        const collect = () => {
          const per = pins.map((pin) => board.capture.pulsesSince(pin, since).slice(0, count));
          return per.every((p) => p.length >= count) ? per : null;
        };
        const per = await this.waitFor(collect, request.timeout_ms ?? 200, `${count} pulses on pins ${pins}`);
        return {
          pins,
          widths_us: per.map((p) => p.map((x) => Math.round(x.widthNs) / 1000)),
          periods_us: per.map((p) => p.map((x) => (x.periodNs === null ? null : Math.round(x.periodNs) / 1000))),
        };
      }
      case 'pulses_since': {
        const pins = request.pins ?? board.servoPins;
        const since = request.since_ns ?? 0;
        return {
          pins,
          nanos: board.nanos,
          widths_us: pins.map((pin) => board.capture.pulsesSince(pin, since).map((x) => Math.round(x.widthNs) / 1000)),
        };
      }
      case 'reset':
        board.requestReset('requested by the test');
        await this.waitFor(() => board.pendingReset === null, 1000, 'reset');
        return { resets: board.resets };
      case 'cut_flash': {
        const op = request.op ?? 'any';
        if (!['erase', 'program', 'any'].includes(op)) throw new Error(`unknown flash op '${op}'`);
        board.flashServices.armCut(op, request.nth ?? 1, request.bytes ?? 0);
        return {};
      }
      case 'flash_timing':
        board.flashServices.setTiming(request.timing);
        return {};
      case 'cut_status': {
        const cut = board.flashServices.cut;
        return { armed: !!cut && !cut.fired, fired: !!cut?.fired };
      }
      case 'flash_read': {
        const bytes = board.readFlash(request.offset, request.length);
        return { hex: Buffer.from(bytes).toString('hex') };
      }
      case 'rtt':
        board.drainRtt();
        await this.logs.settle();
        return { hex: Buffer.from(this.logs.rttBytes()).toString('hex'), lines: this.logs.rttLines() };
      case 'busy_cycles': {
        const windows = request.windows ?? 10;
        const windowUs = request.window_us ?? 20000;
        const cycles = [];
        const resetsAtStart = board.resets;
        let last = board.mcu.core.cycles;
        await new Promise((resolve) => {
          const tick = () => {
            const now = board.mcu.core.cycles;
            cycles.push(now - last);
            last = now;
            if (cycles.length >= windows || board.halted || board.resets !== resetsAtStart) resolve();
            else board.after(windowUs, tick);
          };
          board.after(windowUs, tick);
        });
        if (board.resets !== resetsAtStart) throw new Error('the board reset during the measurement');
        return { window_us: windowUs, cycles };
      }
      case 'probe': {
        const probe = board.addProbe(request.symbol);
        return { functions: probe.functions.map((f) => f.name) };
      }
      case 'probe_stats': {
        const probe = board.probes.get(request.symbol);
        if (!probe) throw new Error(`no probe on '${request.symbol}'`);
        const stats = probe.stats();
        if (request.clear) probe.clear();
        return stats;
      }
      case 'probe_calls': {
        const probe = board.probes.get(request.symbol);
        if (!probe) throw new Error(`no probe on '${request.symbol}'`);
        return probe.callsSince(request.since_ns ?? 0);
      }
      case 'call':
        if (!Array.isArray(request.args)) throw new Error("'args' must be a list of argument lists");
        return board.call(request.symbol, request.args);
      case 'quit':
        setImmediate(() => this.logs.quit());
        return {};
      default:
        throw new Error(`unknown command '${request.cmd}'`);
    }
  }
}
