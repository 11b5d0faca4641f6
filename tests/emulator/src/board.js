//! One emulated board: an rp2040js chip with our ROM, the firmware in its flash, the USB serial
//! port, servo pulse capture, RTT log, flash services with fault injection, cycle probes, calls
//! of single functions, and a paced run loop. A chip reset builds a fresh chip and carries the
//! flash over, as a real reset (or power cycle) keeps the flash and nothing else.

import { EventEmitter } from 'node:events';
import { RP2040 } from 'rp2040js';
import { tickThroughNextAlarm } from './clock-step.js';
import { CycleProbe } from './cycle-probe.js';
import { FlashServices } from './flash.js';
import { callFunction } from './function-call.js';
import { PwmCapture } from './pwm-capture.js';
import { buildRom, FAULT_TRAP, LOOKUP_TRAP, ROM_CODE_END, serviceAddress, serviceName } from './rom.js';
import { RttReader } from './rtt.js';
import { UsbSerial } from './usb-serial.js';
import { XIP_CTRL_KEY, XipCtrlStub } from './xip.js';

/** Cortex-M0+ AIRCR (reset requests from `SCB::sys_reset`). */
const AIRCR_OFFSET = 0xd0c;
const AIRCR_SYSRESETREQ = 0x05fa0004;
/** Wall time one run-loop slice may take before yielding to Node's event loop. */
const SLICE_MS = 10;

/**
 * rp2040js logs through this; warnings go to our log, debug chatter is dropped.
 *
 * It also completes rp2040js's SEV, which only logs "SEV": on the chip SEV sets the event
 * register, so that the next WFE falls through. embassy's executor pends a task with SEV and
 * then sleeps with WFE; without the event a task spawned from thread mode would wait for an
 * unrelated interrupt. The log call is the one hook rp2040js gives at that instruction.
 */
function makeLogger(core, log) {
  return {
    debug() {},
    info(component, message) {
      if (component === 'CortexM0Core' && message === 'SEV') {
        core.eventRegistered = true;
        return;
      }
      log(`[${component}] ${message}`);
    },
    warn(component, message) {
      log(`[${component}] warning: ${message}`);
    },
    error(component, message) {
      log(`[${component}] error: ${message}`);
    },
  };
}

/**
 * The emulated board. Events: `configured` (USB enumerated), `serial` (bytes from the board),
 * `reset` ({reason}), `halted` ({reason}), `rtt` (raw defmt bytes).
 */
export class Board extends EventEmitter {
  /**
   * @param {object} options
   * @param {import('./elf.js').Elf} options.elf the firmware
   * @param {Uint8Array} [options.flash] a whole flash image to start from (else the ELF alone)
   * @param {number[]} options.servoPins GPIOs whose pulses are captured
   * @param {boolean} [options.realtime] never run ahead of wall-clock time (default true)
   * @param {string} [options.flashTiming] the flash chip's busy times (see FLASH_TIMINGS)
   * @param {(line:string)=>void} [options.log]
   */
  constructor({ elf, flash, servoPins, realtime = true, flashTiming = 'typical', log = () => {} }) {
    super();
    this.elf = elf;
    this.servoPins = servoPins;
    this.realtime = realtime;
    this.log = log;
    this.rom = buildRom();
    this.flashServices = new FlashServices(log, flashTiming);
    /** Emulated time the core still waits for the flash chip, ns (no instruction runs). */
    this.stallNanos = 0;
    /** Emulated time of the last flash erase's start, ns (null before the first). */
    this.lastEraseNanos = null;
    this.resets = 0;
    this.halted = null;
    this.running = false;
    this.probes = new Map();
    this.capture = new PwmCapture(servoPins, () => this.nanos);
    /** Emulated nanoseconds carried across chip resets, so time stays monotonic. */
    this.baseNanos = 0;
    this.timers = [];
    this.mcu = null;
    this.powerOn(flash ?? null);
  }

  /** Emulated time since power-on, in nanoseconds (continues across resets). */
  get nanos() {
    return this.baseNanos + this.mcu.clock.nanos;
  }

  /** Builds a chip, loads ROM and flash, and wires every hook. */
  powerOn(flashImage) {
    const mcu = new RP2040();
    mcu.logger = makeLogger(mcu.core, this.log);
    mcu.loadBootrom(this.rom); // resets the core (which reads our vectors) and erases flash
    if (flashImage) mcu.flash.set(flashImage);
    else this.elf.writeFlash(mcu.flash);
    if (mcu.flashView.getUint32(0, true) === 0xffffffff) {
      throw new Error(
        'flash is blank at 0x10000000: the ELF has no boot2 (link the firmware with embassy-rp\'s link-rp.x)',
      );
    }
    mcu.peripherals[XIP_CTRL_KEY] = new XipCtrlStub(mcu);
    mcu.core.reset(); // vectors are in ROM; reset again now that flash holds boot2

    mcu.onBreak = (code) => this.onBreak(code);
    const watchdog = mcu.peripherals[0x40058];
    watchdog.onWatchdogTrigger = () => this.requestReset('watchdog');
    const ppbWrite = mcu.ppb.writeUint32.bind(mcu.ppb);
    mcu.ppb.writeUint32 = (offset, value) => {
      if (offset === AIRCR_OFFSET && (value >>> 0) === AIRCR_SYSRESETREQ) {
        this.requestReset('SYSRESETREQ');
        return;
      }
      ppbWrite(offset, value);
    };

    this.mcu = mcu;
    this.serial = new UsbSerial(mcu, {
      onData: (bytes) => this.emit('serial', bytes),
      onConfigured: () => this.emit('configured'),
    });
    this.capture.attach(mcu);
    this.rtt = new RttReader(mcu, this.elf.symbol('_SEGGER_RTT'));
    this.pendingReset = null;
    for (const probe of this.probes.values()) probe.attach(mcu);
  }

  /** Resets the chip at the next instruction boundary; the flash survives. */
  requestReset(reason) {
    this.pendingReset = reason;
  }

  doReset(reason) {
    this.drainRtt();
    const flash = this.mcu.flash.slice();
    this.baseNanos += this.mcu.clock.nanos;
    this.resets += 1;
    this.stallNanos = 0;
    this.log(`chip reset (${reason}); flash kept`);
    this.powerOn(flash);
    this.halted = null;
    this.emit('reset', { reason });
  }

  halt(reason) {
    if (this.halted) return;
    this.drainRtt();
    this.halted = reason;
    this.log(`board halted: ${reason}`);
    this.emit('halted', { reason });
    // Time stops with the board: let every waiter look now (and see the halt) instead of never.
    const waiting = this.timers;
    this.timers = [];
    setImmediate(() => waiting.forEach((t) => t.fn()));
  }

  /** A BKPT/UDF: a ROM service if it sits in our ROM, else the firmware stopping (panic, fault). */
  onBreak(code) {
    const core = this.mcu.core;
    const pc = (core.PC - core.breakRewind) >>> 0;
    if (pc >= ROM_CODE_END) {
      this.halt(`firmware hit a breakpoint/UDF #${code} at 0x${pc.toString(16)} (panic or fault)`);
      return;
    }
    const r = core.registers;
    if (code === LOOKUP_TRAP) {
      const address = serviceAddress(r[1]);
      if (!address) {
        const name = String.fromCharCode(r[1] & 0xff, (r[1] >> 8) & 0xff);
        this.halt(`firmware looked up ROM function '${name}', which this ROM does not provide`);
      }
      r[0] = address;
      return;
    }
    if (code === FAULT_TRAP) {
      this.halt('HardFault/NMI before the firmware installed its vector table');
      return;
    }
    const name = serviceName(code);
    if (name === 'RE') this.lastEraseNanos = this.nanos;
    const outcome = this.flashServices.call(name, this.mcu, r);
    this.stallNanos += this.flashServices.takeBusy();
    if (outcome === 'reset') this.requestReset(`power cut during flash ${name}`);
    else if (outcome === 'usb-boot') this.halt('rebooted to the USB bootloader (reset_to_usb_boot)');
  }

  /** Adds a cycle probe on every function whose mangled name contains `part`. */
  addProbe(part) {
    const functions = this.elf.functionsMatching(part);
    if (functions.length === 0) throw new Error(`no function symbol contains '${part}'`);
    const probe = new CycleProbe(part, functions, () => this.nanos);
    probe.attach(this.mcu);
    this.probes.set(part, probe);
    return probe;
  }

  /** Calls the function named `name` once per argument list (see `function-call.js`). */
  call(name, argLists) {
    const address = this.elf.symbol(name);
    if (address === undefined) throw new Error(`no symbol named '${name}'`);
    return callFunction(this.mcu, address, argLists);
  }

  drainRtt() {
    if (!this.mcu) return;
    const bytes = this.rtt.poll();
    if (bytes.length) this.emit('rtt', bytes);
  }

  /** Reads `length` bytes of flash at an offset from its start. */
  readFlash(offset, length) {
    return this.mcu.flash.slice(offset, offset + length);
  }

  /** Host bytes for the USB serial port. */
  writeSerial(bytes) {
    return this.serial.write(bytes);
  }

  /** Calls `fn` once emulated time has advanced by `micros`. */
  after(micros, fn) {
    this.timers.push({ at: this.nanos + micros * 1000, fn });
  }

  start() {
    if (this.running) return;
    this.running = true;
    this.wallStart = performance.now();
    this.nanosAtStart = this.nanos;
    this.loop();
  }

  stop() {
    this.running = false;
  }

  /** Runs instructions for a slice of wall time, then yields to Node's event loop. */
  loop() {
    if (!this.running) return;
    const sliceEnd = performance.now() + SLICE_MS;
    let idle = false;
    while (performance.now() < sliceEnd && !idle) {
      const limit = this.realtime
        ? this.nanosAtStart + (performance.now() - this.wallStart) * 1e6
        : Infinity;
      idle = this.run(limit, 20000);
      this.drainRtt();
      this.fireTimers();
    }
    setTimeout(() => this.loop(), idle ? 1 : 0);
  }

  /** Executes up to `budget` instructions without passing `limitNanos`; true if it went idle. */
  run(limitNanos, budget) {
    for (let i = 0; i < budget; i++) {
      if (this.pendingReset) this.doReset(this.pendingReset);
      if (this.halted) return true;
      const m = this.mcu;
      if (this.stallNanos > 0 || m.core.waiting) {
        // No instruction runs: the core waits for the flash chip (time passes for timers and
        // PWM), or sleeps until its clock's next alarm. Either way time jumps to the next event,
        // a harness timer, or the wall-time limit, whichever comes first. Steps are measured
        // from now in the chip's own clock: absolute times carry the nanoseconds of earlier
        // resets, and their rounding could leave an alarm forever a fraction of a nanosecond
        // ahead of a step meant to reach it.
        const stalled = this.stallNanos > 0;
        const now = this.nanos;
        const toStallEnd = stalled ? this.stallNanos : Infinity;
        const toAlarm = !stalled && m.clock.nextAlarm ? Math.max(m.clock.nanosToNextAlarm, 0) : Infinity;
        const timerAt = this.timers.reduce((t, x) => Math.min(t, x.at), Infinity);
        const toTimer = timerAt - now;
        const toLimit = limitNanos - now;
        const step = Math.min(toStallEnd, toAlarm, toTimer, toLimit);
        if (step === Infinity) return true; // nothing will ever happen until a host byte
        // An overdue timer, or a limit already passed, makes the step negative: no time passes.
        const elapsed = Math.max(step, 0);
        if (step === toAlarm) tickThroughNextAlarm(m.clock);
        else if (elapsed > 0) m.clock.tick(elapsed);
        if (stalled) this.stallNanos = this.stallNanos - elapsed < 1 ? 0 : this.stallNanos - elapsed;
        if (step === toTimer) this.fireTimers(timerAt);
        else if (step === toLimit) return true;
      } else {
        if (this.nanos > limitNanos) return true;
        const cycles = m.core.executeInstruction();
        m.clock.tick((cycles * 1e9) / m.clkSys);
      }
    }
    return false;
  }

  /** Runs the harness timers due by `until` (default: now). */
  fireTimers(until = this.nanos) {
    const due = this.timers.filter((t) => t.at <= until);
    this.timers = this.timers.filter((t) => t.at > until);
    for (const t of due) t.fn();
  }
}
