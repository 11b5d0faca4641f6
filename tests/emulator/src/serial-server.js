//! Bridges the emulated board's USB serial port to a TCP socket on the loopback interface.
//!
//! The host opens `socket://127.0.0.1:PORT` and talks to the board exactly as to a USB serial
//! port. One client at a time: a new connection replaces the old one. A chip reset drops the
//! connection, as a real board's USB port disappears when it resets; the host reconnects.

import { createServer } from 'node:net';

/** The TCP end of the board's serial port. */
export class SerialServer {
  /** @param {import('./board.js').Board} board @param {(line:string)=>void} log */
  constructor(board, log) {
    this.board = board;
    this.log = log;
    this.client = null;
    this.server = createServer((socket) => this.accept(socket));
    board.on('serial', (bytes) => this.client?.write(bytes));
    board.on('reset', () => this.drop('board reset'));
    board.on('halted', () => this.drop('board halted'));
  }

  /** Listens on 127.0.0.1 (port 0 = any free port); resolves to the port. */
  listen(port) {
    return new Promise((resolve, reject) => {
      this.server.once('error', reject);
      this.server.listen(port, '127.0.0.1', () => resolve(this.server.address().port));
    });
  }

  accept(socket) {
    if (this.board.halted) {
      socket.destroy();
      return;
    }
    this.drop('replaced by a new connection');
    socket.setNoDelay(true);
    this.client = socket;
    socket.on('data', (bytes) => {
      if (!this.board.writeSerial(bytes)) {
        this.log('serial input overflow: host bytes dropped (the board is not reading)');
      }
    });
    const gone = () => {
      if (this.client === socket) this.client = null;
    };
    socket.on('close', gone);
    socket.on('error', gone);
  }

  drop(why) {
    if (!this.client) return;
    this.log(`serial client disconnected: ${why}`);
    this.client.destroy();
    this.client = null;
  }

  close() {
    this.drop('emulator stopping');
    this.server.close();
  }
}
