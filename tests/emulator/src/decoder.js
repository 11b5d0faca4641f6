//! Turns the firmware's defmt-encoded RTT bytes into log lines with `defmt-print`, if installed.
//!
//! defmt sends a table index and binary arguments instead of text; the strings live in the ELF's
//! `.defmt` section. `defmt-print -e ELF` (crates.io: `cargo install defmt-print`) decodes a raw
//! stream on its stdin. Without it the harness keeps and shows the raw bytes as hex, which is
//! still enough to tell that the firmware logs (and to decode later with the same ELF).

import { spawn, spawnSync } from 'node:child_process';
import { existsSync } from 'node:fs';
import { homedir } from 'node:os';
import { join } from 'node:path';

/** Path of a usable `defmt-print`, or null. */
export function findDefmtPrint() {
  const candidates = [
    process.env.DEFMT_PRINT,
    'defmt-print',
    join(process.env.CARGO_HOME ?? join(homedir(), '.cargo'), 'bin', 'defmt-print'),
  ].filter(Boolean);
  for (const candidate of candidates) {
    if (candidate.includes('/') && !existsSync(candidate)) continue;
    const probe = spawnSync(candidate, ['--version'], { stdio: 'ignore' });
    if (probe.status === 0) return candidate;
  }
  return null;
}

/** A running decoder: feed raw bytes, get lines through `onLine`. */
export class DefmtDecoder {
  /** @param {string} tool @param {string} elfPath @param {(line:string)=>void} onLine */
  constructor(tool, elfPath, onLine) {
    this.child = spawn(tool, ['-e', elfPath, '--log-format', '{L} {s}'], {
      stdio: ['pipe', 'pipe', 'pipe'],
    });
    let rest = '';
    const take = (chunk) => {
      rest += chunk.toString();
      const lines = rest.split('\n');
      rest = lines.pop();
      for (const line of lines) if (line.trim()) onLine(line);
    };
    this.child.stdout.on('data', take);
    this.child.stderr.on('data', take);
    this.child.on('error', (e) => onLine(`defmt-print failed: ${e.message}`));
    this.child.stdin.on('error', () => {});
  }

  write(bytes) {
    this.child.stdin.write(bytes);
  }

  close() {
    this.child.stdin.end();
    this.child.kill();
  }
}
