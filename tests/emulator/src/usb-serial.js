//! The USB host side of the emulated board's CDC-ACM serial port, as a byte stream.
//!
//! rp2040js's `USBCDC` enumerates the device and hands us the bulk IN data. Its OUT path does
//! not suit embassy-usb: rp2040js clears `AVAILABLE` in an OUT endpoint's buffer control as soon
//! as the CPU arms the buffer and then completes the read with whatever the host has (often
//! nothing). embassy-usb treats a clear `AVAILABLE` as "a packet arrived" and re-reads the stale
//! buffer, so replies come back duplicated and one behind. Here an armed OUT buffer keeps
//! `AVAILABLE` set until host bytes exist; then `AVAILABLE` is cleared and `FULL` + length set in
//! one step, as the hardware does when a packet lands.

import { USBCDC } from 'rp2040js';

const EP0_OUT_BUFFER_CONTROL = 0x84;
const BUF_CTRL_AVAILABLE = 1 << 10;
/** Host bytes held while the board is not listening, at most (a real port would block). */
const MAX_PENDING = 1 << 20;

/** A CDC-ACM serial port on the emulated USB controller. */
export class UsbSerial {
  /**
   * @param {import('rp2040js').RP2040} mcu
   * @param {{onData:(bytes:Uint8Array)=>void, onConfigured:()=>void}} handlers
   */
  constructor(mcu, { onData, onConfigured }) {
    this.mcu = mcu;
    this.usb = mcu.usbCtrl;
    this.cdc = new USBCDC(this.usb);
    this.pending = [];
    this.pendingBytes = 0;
    /** OUT endpoint armed by the firmware and not yet given data: its max length. */
    this.armedLength = 0;
    this.configured = false;
    this.cdc.onDeviceConnected = () => {
      this.configured = true;
      onConfigured();
    };
    this.cdc.onSerialData = (buffer) => onData(buffer);

    const cdcRead = this.usb.onEndpointRead;
    this.usb.onEndpointRead = (endpoint, size) => {
      if (endpoint !== this.cdc.outEndpoint || endpoint < 0) {
        cdcRead(endpoint, size);
        return;
      }
      this.armedLength = size;
      this.setAvailable(endpoint, true);
      this.deliver();
    };
  }

  /** Queues bytes from the host; they reach the firmware as it arms its OUT buffer. */
  write(bytes) {
    if (this.pendingBytes + bytes.length > MAX_PENDING) return false;
    this.pending.push(Uint8Array.from(bytes));
    this.pendingBytes += bytes.length;
    this.deliver();
    return true;
  }

  /** Hands the armed OUT buffer one packet of pending host bytes, if both exist. */
  deliver() {
    const endpoint = this.cdc.outEndpoint;
    if (!this.configured || endpoint < 0 || this.armedLength === 0 || this.pendingBytes === 0) {
      return;
    }
    const packet = new Uint8Array(Math.min(this.armedLength, this.pendingBytes));
    let filled = 0;
    while (filled < packet.length) {
      const head = this.pending[0];
      const take = Math.min(head.length, packet.length - filled);
      packet.set(head.subarray(0, take), filled);
      filled += take;
      if (take === head.length) this.pending.shift();
      else this.pending[0] = head.subarray(take);
    }
    this.pendingBytes -= packet.length;
    this.armedLength = 0;
    this.setAvailable(endpoint, false);
    this.usb.finishRead(endpoint, packet);
  }

  setAvailable(endpoint, on) {
    const offset = EP0_OUT_BUFFER_CONTROL + endpoint * 8;
    const view = this.mcu.usbDPRAMView;
    const value = view.getUint32(offset, true);
    view.setUint32(offset, on ? value | BUF_CTRL_AVAILABLE : value & ~BUF_CTRL_AVAILABLE, true);
  }
}
