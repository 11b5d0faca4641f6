#!/usr/bin/env node
//! Starts the emulated lrmcal board: the real firmware ELF in rp2040js, its USB serial port on
//! `socket://127.0.0.1:PORT`, servo pulses and the firmware log on the terminal.
//!
//! For people: `node tests/emulator/bin/lrm-emulator.js` (after `npm ci` there and
//! `cargo firmware`), then in another terminal `lrmcal status --port socket://127.0.0.1:4040`.
//! For tests: `--control` adds the JSON-lines control channel of `src/control.js` on stdio.
//! For a parent process (`lrmcal emulator`): `--child` announces the port on stdout and stops
//! the board when stdin closes.

import { existsSync, readFileSync, renameSync, writeFileSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { parseArgs } from 'node:util';
import { Board } from '../src/board.js';
import { Control } from '../src/control.js';
import { DefmtDecoder, findDefmtPrint } from '../src/decoder.js';
import { Elf, ElfError } from '../src/elf.js';
import { FLASH_TIMINGS } from '../src/flash.js';
import { SerialServer } from '../src/serial-server.js';

const HERE = dirname(fileURLToPath(import.meta.url));
/** Where `cargo firmware` puts the ELF (under CARGO_TARGET_DIR when set, as cargo does). */
const DEFAULT_ELF = resolve(
  process.env.CARGO_TARGET_DIR ?? resolve(HERE, '../../../target'),
  'thumbv6m-none-eabi/release/firmware',
);
/** GPIOs of servos 1..6 (firmware/src/board: slices 1-3, channels A/B). */
const DEFAULT_SERVO_PINS = '2,3,4,5,6,7';
/** The board's flash chip (2 MiB, as memory.x says); saved images are this size. */
const FLASH_SIZE = 2 * 1024 * 1024;

const USAGE = `usage: lrm-emulator [options]

Runs the lrmcal firmware in an emulated RP2040 and serves its USB serial port on TCP.

options:
  --elf PATH          firmware ELF (default: ${DEFAULT_ELF})
  --port N            TCP port on 127.0.0.1 for the serial port (default 4040; 0 = any free)
  --flash FILE        keep the board's flash in FILE across runs (a calibration survives)
  --servo-pins LIST   GPIOs whose pulses are shown/measured (default ${DEFAULT_SERVO_PINS})
  --fast              run ahead of wall-clock time when idle (default: real time)
  --flash-timing T    how long the flash chip is busy per erase/program: typical (default),
                      max (the W25Q16JV datasheet's) or none (instantaneous)
  --control           JSON-lines control channel on stdin/stdout (for tests)
  --child             for a parent process: print {"event":"listening","port":N} on stdout,
                      stop (flash saved) when stdin closes
  --verbose           show the emulator's own warnings (unmodelled registers)
  -h, --help          this text

Build the firmware first:  cargo firmware   (= cargo build -p firmware --release --target thumbv6m-none-eabi)
Install the emulator once:  (cd tests/emulator && npm ci)
Then, e.g.:  lrmcal status --port socket://127.0.0.1:4040`;

function fail(message) {
  process.stderr.write(`lrm-emulator: ${message}\n`);
  process.exit(2);
}

let args;
try {
  args = parseArgs({
    options: {
      elf: { type: 'string', default: DEFAULT_ELF },
      port: { type: 'string', default: '4040' },
      flash: { type: 'string' },
      'servo-pins': { type: 'string', default: DEFAULT_SERVO_PINS },
      fast: { type: 'boolean', default: false },
      'flash-timing': { type: 'string', default: 'typical' },
      control: { type: 'boolean', default: false },
      child: { type: 'boolean', default: false },
      verbose: { type: 'boolean', default: false },
      help: { type: 'boolean', short: 'h', default: false },
    },
  }).values;
} catch (e) {
  fail(`${e.message}\n\n${USAGE}`);
}
if (args.help) {
  process.stdout.write(`${USAGE}\n`);
  process.exit(0);
}
const port = Number(args.port);
if (!Number.isInteger(port) || port < 0 || port > 65535) fail(`--port: expected 0..65535, got '${args.port}'`);
const servoPins = args['servo-pins'].split(',').map(Number);
if (servoPins.some((p) => !Number.isInteger(p) || p < 0 || p > 29)) {
  fail(`--servo-pins: expected GPIO numbers 0..29 separated by commas, got '${args['servo-pins']}'`);
}
if (!(args['flash-timing'] in FLASH_TIMINGS)) {
  fail(`--flash-timing: expected ${Object.keys(FLASH_TIMINGS).join(', ')}, got '${args['flash-timing']}'`);
}
if (args.control && args.child) fail('--control and --child both use stdin and stdout: choose one');
if (!existsSync(args.elf)) {
  fail(`no firmware ELF at ${args.elf}\nbuild it with: cargo firmware  (cargo build -p firmware --release --target thumbv6m-none-eabi)`);
}

let elf;
try {
  elf = Elf.load(args.elf);
} catch (e) {
  fail(e instanceof ElfError ? e.message : String(e));
}

// Logs go to stderr, so that stdout stays the control channel.
const log = (line) => process.stderr.write(`${line}\n`);
const emulatorLog = (line) => {
  if (args.verbose || !/Unimplemented peripheral|\] SEV$|\] Yield$/.test(line)) log(`emulator: ${line}`);
};

let flashImage = null;
if (args.flash && existsSync(args.flash)) {
  const saved = readFileSync(args.flash);
  if (saved.length !== FLASH_SIZE) fail(`${args.flash}: expected a ${FLASH_SIZE}-byte flash image, got ${saved.length} bytes`);
  flashImage = new Uint8Array(saved);
  // A newer firmware build replaces the program; the rest (the calibration slots) is kept.
  elf.writeFlash(flashImage);
  log(`flash loaded from ${args.flash}`);
}

let board;
try {
  board = new Board({
    elf,
    flash: flashImage,
    servoPins,
    realtime: !args.fast,
    flashTiming: args['flash-timing'],
    log: emulatorLog,
  });
} catch (e) {
  fail(`${args.elf}: ${e.message}`);
}

const rawRtt = [];
const rttLines = [];
/** Wall time of the decoder's last output: lines arrive from a child process, a little late. */
let lastDecoded = 0;
/** Resolves once the decoder has been quiet for a moment (at once without a decoder). */
function settle() {
  if (!decoder) return Promise.resolve();
  const start = Date.now();
  return new Promise((resolve) => {
    const check = () => {
      const now = Date.now();
      if ((now - lastDecoded > 150 && now - start > 150) || now - start > 2000) resolve();
      else setTimeout(check, 25);
    };
    check();
  });
}
const tool = findDefmtPrint();
let decoder = tool
  ? new DefmtDecoder(tool, args.elf, (line) => {
      rttLines.push(line);
      lastDecoded = Date.now();
      log(`firmware: ${line}`);
    })
  : null;
if (!tool) log('defmt-print not found (cargo install defmt-print): the firmware log is shown as raw defmt bytes');
board.on('rtt', (bytes) => {
  rawRtt.push(...bytes);
  if (decoder) decoder.write(bytes);
  else log(`firmware (defmt, raw): ${Buffer.from(bytes).toString('hex')}`);
});
board.on('reset', () => {
  // A reset restarts the defmt stream; a fresh decoder keeps its framing in step.
  if (decoder) {
    decoder.close();
    decoder = new DefmtDecoder(tool, args.elf, (line) => {
      rttLines.push(line);
      lastDecoded = Date.now();
      log(`firmware: ${line}`);
    });
  }
  saveFlash();
});

function saveFlash() {
  if (!args.flash) return;
  const tmp = join(dirname(resolve(args.flash)), `.${Date.now()}.flash.tmp`);
  writeFileSync(tmp, board.mcu.flash.subarray(0, FLASH_SIZE));
  renameSync(tmp, args.flash);
}

const server = new SerialServer(board, log);
let actualPort;
try {
  actualPort = await server.listen(port);
} catch (e) {
  fail(`cannot listen on 127.0.0.1:${port}: ${e.message}`);
}

function quit() {
  board.stop();
  saveFlash();
  server.close();
  decoder?.close();
  process.exit(0);
}
process.on('SIGINT', quit);
process.on('SIGTERM', quit);

if (args.control) {
  const control = new Control(board, { rttBytes: () => Uint8Array.from(rawRtt), rttLines: () => rttLines.slice(), settle, quit });
  control.event({ event: 'listening', port: actualPort, elf: args.elf, defmt_print: tool });
  control.listen();
} else {
  if (args.child) {
    process.stdout.write(`${JSON.stringify({ event: 'listening', port: actualPort })}\n`);
    // The parent closes our stdin to stop the board, or by exiting however it ends.
    process.stdin.on('end', quit);
    process.stdin.resume();
  } else {
    log(`emulated board running ${args.elf}`);
    log(`serial port: socket://127.0.0.1:${actualPort}   e.g.  lrmcal status --port socket://127.0.0.1:${actualPort}`);
    log('Ctrl-C stops the board' + (args.flash ? ` (flash saved to ${args.flash})` : ''));
  }
  board.on('configured', () => log('USB enumerated: the serial port is ready'));
  board.on('halted', ({ reason }) => log(`board stopped: ${reason}`));
  // Show the servo pulses whenever they change (once per second at most).
  let shown = '';
  setInterval(() => {
    const since = board.nanos - 40e6;
    const widths = servoPins.map((pin) => {
      const pulses = board.capture.pulsesSince(pin, since);
      return pulses.length ? (pulses[pulses.length - 1].widthNs / 1000).toFixed(1) : '-';
    });
    const line = widths.join(' ');
    if (line !== shown) {
      shown = line;
      log(`servo pulses (us), GPIO ${servoPins.join(',')}: ${line}`);
    }
  }, 1000);
}
board.start();
