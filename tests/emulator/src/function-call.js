//! Calls one function of the firmware on the emulated core, between two instructions of
//! whatever the board is doing, and puts the core back as it was: registers, flags, interrupt
//! mask and cycle counter. For testing leaf routines (the soft-float arithmetic) on the real
//! binary: the arguments go in r0..r3, the result comes from r0, the stack is the free space
//! below the interrupted code's stack pointer, and interrupts are masked during the call.

/** Where the call returns: an address in the ROM that the called code never runs. */
const RETURN = 0x100;
/** Instructions one call may take before it counts as not returning. */
const MAX_INSTRUCTIONS = 100_000;

/**
 * Calls the function at `address` once per argument list.
 * @param {import('rp2040js').RP2040} mcu
 * @param {number} address
 * @param {number[][]} argLists up to four 32-bit arguments each
 * @returns {{results: number[], cycles: number[]}} r0 and the cycles of each call
 */
export function callFunction(mcu, address, argLists) {
  const core = mcu.core;
  const saved = {
    registers: core.registers.slice(),
    apsr: core.APSR,
    pm: core.PM,
    cycles: core.cycles,
  };
  const results = [];
  const cycles = [];
  try {
    core.PM = true;
    for (const args of argLists) {
      if (args.length > 4) throw new Error(`at most four register arguments, got ${args.length}`);
      args.forEach((value, i) => {
        core.registers[i] = value;
      });
      core.LR = RETURN | 1;
      core.PC = address & ~1;
      core.SP = saved.registers[13];
      const start = core.cycles;
      let count = 0;
      while (core.PC !== RETURN) {
        if (++count > MAX_INSTRUCTIONS) {
          throw new Error(`the function at 0x${address.toString(16)} did not return within ${MAX_INSTRUCTIONS} instructions`);
        }
        core.executeInstruction();
      }
      results.push(core.registers[0] >>> 0);
      cycles.push(core.cycles - start);
    }
  } finally {
    core.registers.set(saved.registers);
    core.APSR = saved.apsr;
    core.PM = saved.pm;
    core.cycles = saved.cycles;
  }
  return { results, cycles };
}
