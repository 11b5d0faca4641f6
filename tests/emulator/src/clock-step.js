//! Moving rp2040js's clock to an event without floating-point rounding stopping it short.
//!
//! The clock counts fractional nanoseconds (a wall-time pacing limit is fractional), and
//! `clock.tick(alarm.nanos - clock.nanos)` can land a fraction of a nanosecond before the alarm,
//! which then does not fire. A loop that sleeps "until the next alarm" would ask for that tiny
//! step again and again and never get there. This helper always arrives.

/** Ticks `clock` just far enough that its next alarm fires (now, if it is already due). */
export function tickThroughNextAlarm(clock) {
  const alarm = clock.nextAlarm;
  if (!alarm) return;
  let delta = Math.max(alarm.nanos - clock.nanos, 0);
  while (clock.nanos + delta < alarm.nanos) delta += Number.EPSILON * alarm.nanos;
  clock.tick(delta);
}
