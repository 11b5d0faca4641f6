//! A stand-in for the XIP_CTRL block (0x14000000), which rp2040js does not model.
//!
//! embassy-rp's flash driver waits for `STREAM_CTR == 0` before a flash operation and drains
//! the stream FIFO while `STAT.FIFO_EMPTY` is clear; an unmodelled block reads as all ones and
//! both loops spin forever. This stub reports an idle XIP block: no stream in progress, FIFO
//! empty, cache flush done. Every other register keeps what was written to it.

import { BasePeripheral } from 'rp2040js';

const STAT = 0x08;
const STREAM_CTR = 0x18;
const STREAM_FIFO = 0x1c;
const STAT_FLUSH_READY = 1 << 0;
const STAT_FIFO_EMPTY = 1 << 1;

/** The index under which rp2040js looks a peripheral up: `(address >>> 14) << 2`. */
export const XIP_CTRL_KEY = (0x14000000 >>> 14) << 2;

/** An idle XIP_CTRL block. */
export class XipCtrlStub extends BasePeripheral {
  constructor(rp2040) {
    super(rp2040, 'XIP_CTRL');
    this.registers = new Map();
  }

  readUint32(offset) {
    switch (offset) {
      case STAT:
        return STAT_FLUSH_READY | STAT_FIFO_EMPTY;
      case STREAM_CTR:
        return 0;
      case STREAM_FIFO:
        return 0;
      default:
        return this.registers.get(offset) ?? 0;
    }
  }

  writeUint32(offset, value) {
    this.registers.set(offset, value >>> 0);
  }
}
