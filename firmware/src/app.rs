//! The application's context: the [`Device`] with everything the board
//! knows, its start-up, the servo frame, and the few rules every handler
//! shares ([`Device::ensure_idle`], the limits and curves in force).
//!
//! Backlash: a joint with play rests half the play short of its command on
//! the side it came from ([`model::backlash`]). The servo frame follows the
//! way each joint's command moves and sends it half the play further that
//! way, so the joint stops where it was meant to. Offsetting in the direction
//! of motion adds no motion and no time, and works up to the joint limits
//! (where the offset command is clamped, reported as `LIMIT_CLAMPED`);
//! approaching every target from one side would overshoot and come back,
//! which costs a reversal per move and room beyond the limits. The offset
//! changes at the correction's bounded rate. `docs/METHOD.md` gives the reasons.
//!
//! Joints and channels (crate docs): the arm in force has [`Device::joints`]
//! joints, the calibration's or [`CHANNELS`] without one; the per-joint state
//! (positions, corrections, commands) has one value per joint, and every
//! channel past the last joint is `Channel::Limp` whatever happens. A
//! calibration of another size refits that state (`Device::switch_calibration`).
//!
//! This module imports neither the handlers nor the dispatch table: the
//! handlers (`handlers.rs`) work on the [`Device`] defined here, and the
//! table (`dispatch.rs`) names the handlers, so the modules form a line
//! `app` ← `handlers` ← `dispatch` with no way back.

use model::PerJoint;
use model::backlash::{self, Approach, ApproachTracker};
use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::PROTOCOL_VERSION;
use protocol::{
    Calibration, CalibrationInfo, CompensationMode, DeviceInfo, Faults, Response, WireError,
};

use crate::compensator::Compensator;
use crate::float::ordered;
use crate::motion::{MotionLimits, Profile};
use crate::servo::{self, PreparedCurve, pulse_for};
use crate::storage::Storage;
use crate::{CHANNELS, Config, FlashStorage, PerChannel, ServoBus};

/// A command that changes by less than this from one frame to the next has settled, rad.
const SETTLED_RAD: f32 = 1e-6;

/// A joint's command must go back by more than this before the board takes
/// it to arrive the other way, rad: about one step of the 1 µs pulse (2.3e-3
/// rad on the data-sheet curve), so a change the servo can hardly see, such
/// as the compensation settling after a move, does not throw the offset to
/// the other side. Ignoring a smaller reversal costs at most this much.
const APPROACH_DEAD_BAND_RAD: f32 = 2e-3;

/// What a handler answers: the response, or the error the host gets instead.
pub(crate) type Reply = Result<Response, WireError>;

/// What the binary must do after a reply has gone out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SystemAction {
    /// Reboot into the RP2040 ROM's USB (UF2) bootloader.
    RebootToBootloader,
}

/// The calibration in use, prepared: what the servo frame and the handlers
/// need of it (its two arms live on in the compensator's chains and the
/// curves and limits below, and in flash for `calib/read`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Active {
    /// The pose `motion/home` goes to, one angle per joint, rad.
    pub home_rad: PerChannel<f32>,
    pub info: CalibrationInfo,
    pub compensator: Compensator,
    /// The calibrated arm's joints, on channels `0..joints`.
    pub joints: usize,
    /// The calibrated servo curves, ready for the servo frame; past the last
    /// joint (channels never driven) the uncalibrated curve.
    pub curves: [PreparedCurve; CHANNELS],
    /// The joint ranges in force: the calibration's, cut to the hard range
    /// (worked out once, not per servo frame), rad; the default range past
    /// the last joint.
    pub limits: [[f32; 2]; CHANNELS],
    /// Each joint's backlash offset arriving rising and falling, rad (worked
    /// out once: the servo frame only picks one); none past the last joint.
    pub play_offsets: [[f32; 2]; CHANNELS],
}

/// What one servo channel does, with the pulse it puts out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Channel {
    /// No pulses: the servo is limp (at power-on, after `servo/detach`, and
    /// always past the arm's last joint).
    Limp,
    /// Driven by the motion and the compensation; the pulse of the last
    /// servo frame, µs (`None` until the first frame after attaching).
    Held(Option<u16>),
    /// Under `servo/raw` (servo tuning): this pulse, µs, whatever the motion does.
    Raw(u16),
}

impl Channel {
    /// The pulse on the servo now, µs, 0 for none (as `status/get` reports it).
    pub(crate) fn pulse_us(self) -> u16 {
        match self {
            Self::Limp | Self::Held(None) => 0,
            Self::Held(Some(us)) | Self::Raw(us) => us,
        }
    }
}

/// A calibration upload in progress.
#[derive(Clone, Debug)]
pub(crate) struct Transfer {
    pub len: usize,
    pub crc: u32,
    pub received: usize,
    pub buf: [u8; MAX_CALIBRATION_LEN],
}

/// The board: servo outputs, calibration storage, motion and compensation.
///
/// The binary calls [`Device::handle_frame`] for every frame that arrives and
/// [`Device::servo_frame`] every 20 ms. Neither waits on anything but the
/// flash (only `calib/commit` and `calib/erase` write it); neither panics.
pub struct Device<B, F> {
    pub(crate) config: Config,
    pub(crate) bus: B,
    pub(crate) storage: Storage<F>,
    pub(crate) active: Option<Active>,
    pub(crate) mode: CompensationMode,
    pub(crate) payload_kg: f32,
    pub(crate) motion: Profile,
    /// Nominal joint angles of the last servo frame, rad, one per joint.
    pub(crate) position: PerChannel<f32>,
    pub(crate) moving: bool,
    /// Whether the correction is still fading towards the wanted one, or the
    /// compensation still converging (the servos still move although the
    /// motion is over).
    pub(crate) settling: bool,
    /// The compensated commands of the last servo frame, rad, one per joint.
    pub(crate) wanted: PerJoint<f32>,
    pub(crate) channels: [Channel; CHANNELS],
    pub(crate) faults: Faults,
    pub(crate) frames_dropped: u32,
    pub(crate) transfer: Option<Transfer>,
    pub(crate) boot_us: u64,
    pub(crate) now_us: u64,
    pub(crate) pending: Option<SystemAction>,
    /// Correction (command minus nominal) on the servos now, rad, one per joint.
    pub(crate) applied_correction: PerChannel<f32>,
    /// The way each joint's command last moved (the side of its play it rests on).
    pub(crate) approach: ApproachTracker<f32>,
    /// Backlash offset on the servos now, rad: half the calibration's play in
    /// the direction of motion, changing at the correction's bounded rate;
    /// one per joint.
    pub(crate) applied_play: PerChannel<f32>,
    /// Time of the last servo frame, µs.
    pub(crate) last_frame_us: u64,
    /// The servo curve without a calibration, ready for the servo frame.
    pub(crate) uncalibrated: PreparedCurve,
    /// The config's safe pulse range as floats, µs (converted once, not per servo frame).
    pub(crate) pulse_range_us: [f32; 2],
}

impl<B: ServoBus, F: FlashStorage> Device<B, F> {
    /// Starts the board at `now_us`: loads the calibration and makes every channel limp.
    pub fn new(bus: B, flash: F, config: Config, now_us: u64) -> Self {
        let mut storage = Storage::new(flash);
        let report = storage.load();
        let zeros = PerChannel::splat(CHANNELS, 0.0);
        let mut device = Self {
            config,
            bus,
            storage,
            active: None,
            mode: CompensationMode::Off,
            payload_kg: 0.0,
            motion: Profile::hold(zeros),
            position: zeros,
            moving: false,
            settling: false,
            wanted: PerJoint::splat(CHANNELS, 0.0),
            channels: [Channel::Limp; CHANNELS],
            faults: Faults::default(),
            frames_dropped: 0,
            transfer: None,
            boot_us: now_us,
            now_us,
            pending: None,
            applied_correction: zeros,
            // Every joint taken to rest at home having arrived rising (as the host's tracker does).
            approach: ApproachTracker::new(&zeros),
            applied_play: zeros,
            last_frame_us: now_us,
            uncalibrated: PreparedCurve::new(config.uncalibrated_curve),
            pulse_range_us: config.pulse_range_us.map(f32::from),
        };
        device.faults.set(Faults::STORAGE_DAMAGED, report.damaged);
        if let Some(loaded) = report.loaded {
            device.apply(loaded.calibration, loaded.sequence);
        }
        let joints = device.joints();
        device.position = device.home();
        device.wanted = PerJoint::splat(joints, 0.0);
        device.applied_correction = PerChannel::splat(joints, 0.0);
        device.applied_play = PerChannel::splat(joints, 0.0);
        device.approach = ApproachTracker::new(&device.position);
        device.motion = Profile::hold(device.position);
        for channel in 0..CHANNELS {
            device.bus.set_pulse(channel, None);
        }
        device
    }

    /// Gives back the servo bus and the flash (to "reboot" in tests).
    pub fn release(self) -> (B, F) {
        (self.bus, self.storage.into_flash())
    }

    /// The servo bus (to inspect a mock in tests).
    pub fn bus(&self) -> &B {
        &self.bus
    }

    /// The flash (to cut its power in tests).
    #[cfg(any(test, feature = "fuzz"))]
    pub fn flash_mut(&mut self) -> &mut F {
        self.storage.flash_mut()
    }

    /// What the binary must do next, once: call after the reply went out.
    pub fn take_action(&mut self) -> Option<SystemAction> {
        self.pending.take()
    }

    /// Refuses a request that would disturb a running motion (a jump, an
    /// abrupt stop, a correction appearing mid-path, a flash write stalling
    /// the servo frames): the one place `Busy` comes from.
    pub(crate) fn ensure_idle(&self) -> Result<(), WireError> {
        if self.moving {
            Err(WireError::Busy)
        } else {
            Ok(())
        }
    }

    /// Makes `calibration` (stored under `sequence`, checked: 1 to
    /// [`CHANNELS`] joints) the one in use.
    pub(crate) fn apply(&mut self, calibration: Calibration, sequence: u32) {
        let c = &self.config;
        let arm = &calibration.calibrated;
        let joints = arm.joint_count().min(CHANNELS);
        let mut compensator = Compensator::new(&calibration, c.compensation, c.max_correction_rad);
        if let Some(last) = &self.active {
            compensator.continue_from(&last.compensator);
        }
        self.active = Some(Active {
            info: CalibrationInfo {
                id: calibration.id,
                option: calibration.option,
                joints: joints as u8,
                sequence,
            },
            compensator,
            joints,
            curves: core::array::from_fn(|i| match arm.joints.get(i) {
                // `Calibration::check` refused a joint without a curve.
                Some(j) => j.servo.map_or(self.uncalibrated, PreparedCurve::new),
                None => self.uncalibrated,
            }),
            limits: servo::joint_limits(Some(arm), c.hard_limits_rad, c.default_limits_rad),
            play_offsets: core::array::from_fn(|i| match arm.joints.get(i) {
                Some(j) => [Approach::Rising, Approach::Falling]
                    .map(|way| backlash::command_for(0.0, j.backlash, way)),
                None => [0.0; 2],
            }),
            home_rad: calibration.home_rad,
        });
    }

    /// Replaces the calibration in use without a step on the servos: what the
    /// new curves would change in a driven joint's pulse is folded into the
    /// correction, which then fades out at the bounded rate. An arm of
    /// another size refits the per-joint state first ([`Device::fit_joints`]).
    pub(crate) fn switch_calibration(&mut self, next: Option<(Calibration, u32)>) {
        match next {
            Some((calibration, sequence)) => self.apply(calibration, sequence),
            None => self.active = None,
        }
        self.fit_joints();
        let joints = self.joints();
        for (i, [lo, hi]) in self.limits().into_iter().enumerate().take(joints) {
            let Channel::Held(Some(pulse)) = self.channels[i] else {
                continue;
            };
            let angle = self.curve(i).curve.angle(f32::from(pulse)).clamp(lo, hi);
            // The play offset on the servo stays and fades to the new calibration's on its own.
            let keep = angle - self.applied_play[i] - self.position[i];
            if keep.is_finite() {
                self.applied_correction[i] = keep;
            }
        }
    }

    /// The per-joint state fitted to the arm in force, after a calibration of
    /// another number of joints (or none) replaced the last: the joints both
    /// arms have keep their position, correction and play offset; a joint the
    /// last arm did not have, whose channel is limp, is taken to rest at the
    /// home pose (as at start-up) with no correction. The way each joint
    /// arrived starts afresh (rising, as at start-up), the motion holds, and
    /// every channel past the last joint goes limp at once.
    fn fit_joints(&mut self) {
        let joints = self.joints();
        if self.position.len() == joints {
            return;
        }
        let home = self.home();
        let kept = |v: &PerChannel<f32>, i: usize| v.get(i).copied();
        let position = PerChannel::from_fn(joints, |i| kept(&self.position, i).unwrap_or(home[i]));
        self.applied_correction =
            PerChannel::from_fn(joints, |i| kept(&self.applied_correction, i).unwrap_or(0.0));
        self.applied_play =
            PerChannel::from_fn(joints, |i| kept(&self.applied_play, i).unwrap_or(0.0));
        self.wanted = PerJoint::from_fn(joints, |i| match self.wanted.get(i) {
            Some(&w) => w,
            None => position[i],
        });
        self.position = position;
        self.approach = ApproachTracker::new(&position);
        self.motion = Profile::hold(position);
        for (i, channel) in self.channels.iter_mut().enumerate().skip(joints) {
            if *channel != Channel::Limp {
                *channel = Channel::Limp;
                self.bus.set_pulse(i, None);
            }
        }
    }

    /// The arm's joints, on channels `0..joints`: the calibration's arm, or
    /// one joint per channel without a calibration.
    pub fn joints(&self) -> usize {
        self.active.as_ref().map_or(CHANNELS, |a| a.joints)
    }

    /// The pose `motion/home` goes to and the one assumed at start-up, rad.
    pub(crate) fn home(&self) -> PerChannel<f32> {
        self.active
            .as_ref()
            .map_or(PerChannel::splat(CHANNELS, 0.0), |a| a.home_rad)
    }

    /// Joint ranges in force per channel, rad ([`servo::joint_limits`]; the
    /// default range past the arm's last joint).
    pub(crate) fn limits(&self) -> [[f32; 2]; CHANNELS] {
        match &self.active {
            Some(a) => a.limits,
            None => [self.config.default_limits_rad; CHANNELS],
        }
    }

    /// The servo curve in force on `channel`: the calibration's, or the data-sheet curve.
    pub(crate) fn curve(&self, channel: usize) -> &PreparedCurve {
        self.active
            .as_ref()
            .map_or(&self.uncalibrated, |a| &a.curves[channel])
    }

    pub(crate) fn motion_limits(&self) -> MotionLimits {
        MotionLimits {
            max_speed_rad_s: self.config.max_speed_rad_s,
            max_accel_rad_s2: self.config.max_accel_rad_s2,
        }
    }

    /// Versions and channels, for `link/hello` and `status/get`.
    pub(crate) fn device_info(&self) -> DeviceInfo {
        DeviceInfo {
            protocol: PROTOCOL_VERSION,
            firmware: self.config.firmware,
            channels: CHANNELS as u8,
        }
    }

    /// One servo frame at `now_us`: advance the motion, compensate, and put a
    /// pulse (or none) on every channel: the arm's joints', and none on the
    /// channels past its last joint.
    pub fn servo_frame(&mut self, now_us: u64) {
        self.now_us = now_us;
        let (q_nominal, done) = self.motion.at(now_us);
        self.position = q_nominal;
        self.moving = !done;
        let driven = self.channels.iter().any(|c| matches!(c, Channel::Held(_)));
        let (mode, payload) = (self.mode, self.payload_kg);
        let wanted = match &mut self.active {
            Some(a) if driven => a.compensator.step(&q_nominal, mode, payload),
            _ => PerJoint::from_fn(q_nominal.len(), |i| q_nominal[i]),
        };
        // Fade the correction towards the wanted one at a bounded rate; a limp
        // arm starts again from none.
        // At most 100 ms: a 32-bit conversion (the same float as a 64-bit
        // one, for half its cycles on the Cortex-M0+).
        let dt_us = now_us.saturating_sub(self.last_frame_us).min(100_000) as u32;
        let dt_s = dt_us as f32 * 1e-6;
        self.last_frame_us = now_us;
        let step = self.config.max_correction_rate_rad_s * dt_s;
        let mut settling = false;
        let command = PerChannel::from_fn(q_nominal.len(), |i| {
            let target = if driven {
                wanted[i] - q_nominal[i]
            } else {
                0.0
            };
            let delta = target - self.applied_correction[i];
            // A non-finite wish leaves the correction where it is.
            if delta.is_finite() {
                let (change, capped) = bounded(delta, step);
                self.applied_correction[i] += change;
                settling |= capped;
            }
            q_nominal[i] + self.applied_correction[i]
        });
        // Backlash: the joint rests on the side of its play it came from, half
        // the play short of the command; command half the play beyond, in the
        // way the command last moved. Held channels only: a limp joint follows nothing.
        let approach = self.approach.follow(&command, APPROACH_DEAD_BAND_RAD);
        let offsets = self.active.as_ref().map(|a| &a.play_offsets);
        let command = PerChannel::from_fn(command.len(), |i| {
            let offset = match (offsets, self.channels[i], approach[i]) {
                (Some(o), Channel::Held(_), Approach::Rising) => o[i][0],
                (Some(o), Channel::Held(_), Approach::Falling) => o[i][1],
                _ => 0.0,
            };
            // Holding on the same side, nothing changes: the frame's usual
            // case. (Both are finite: their difference is 0 only if they are equal.)
            if offset != self.applied_play[i] {
                let (change, capped) = bounded(offset - self.applied_play[i], step);
                self.applied_play[i] += change;
                settling |= capped;
            }
            command[i] + self.applied_play[i]
        });
        // One Newton step per frame: after a move the last steps still change
        // the command (while it moves, the motion keeps the board busy anyway).
        // An unchanged command (a settled solve's) needs no float arithmetic.
        let converging = done
            && wanted.iter().zip(&self.wanted).any(|(now, before)| {
                now.to_bits() != before.to_bits() && (now - before).abs() > SETTLED_RAD
            });
        self.wanted = wanted;
        let compensating = driven && mode != CompensationMode::Off;
        // A solve that has not ended (falling back and retrying, or started
        // afresh) may still move the servos although its command stands.
        let solving = compensating
            && done
            && self
                .active
                .as_ref()
                .is_some_and(|a| !a.compensator.settled());
        self.settling = settling || converging || solving;
        let fell_back = compensating
            && self
                .active
                .as_ref()
                .is_some_and(|a| a.compensator.fell_back());
        self.faults.set(Faults::COMPENSATION_FALLBACK, fell_back);
        let limits = self.limits();
        // Fields, not `self.curve()`: the channels change in the same loop.
        let curves = self.active.as_ref().map(|a| &a.curves);
        for (i, channel) in self.channels.iter_mut().enumerate() {
            let pulse = match (*channel, command.get(i)) {
                // Past the arm's last joint: limp, whatever asked otherwise
                // (no handler does).
                (_, None) => {
                    *channel = Channel::Limp;
                    None
                }
                (Channel::Limp, _) => None,
                (Channel::Raw(us), _) => Some(us),
                (Channel::Held(last), Some(&command)) => {
                    let pulse = match pulse_for(
                        curves.map_or(&self.uncalibrated, |c| &c[i]),
                        command,
                        limits[i],
                        self.pulse_range_us,
                    ) {
                        Some(p) => {
                            if p.clamped {
                                self.faults.set(Faults::LIMIT_CLAMPED, true);
                            }
                            Some(p.us)
                        }
                        // Never reached with finite targets; holding the last pulse is the safe answer.
                        None => last,
                    };
                    *channel = Channel::Held(pulse);
                    pulse
                }
            };
            self.bus.set_pulse(i, pulse);
        }
    }
}

/// `delta.clamp(-step, step)` and whether it had to be cut (`delta.abs() >
/// step`), for `delta` not NaN and `step >= 0`: one comparison, on the
/// bits, where those make four float comparisons, each a call on the
/// Cortex-M0+.
fn bounded(delta: f32, step: f32) -> (f32, bool) {
    if ordered(delta.abs()) > ordered(step) {
        (step.copysign(delta), true)
    } else {
        (delta, false)
    }
}

#[cfg(test)]
mod tests {
    use super::bounded;

    #[test]
    fn the_bound_is_clamp_and_says_when_it_cut() {
        let steps = [0.0f32, 1e-30, 1e-3, 0.01, 1.0, f32::INFINITY];
        for step in steps {
            for delta in crate::float::tests::specials() {
                let (change, cut) = bounded(delta, step);
                let clamped = delta.clamp(-step, step);
                assert_eq!(change.to_bits(), clamped.to_bits(), "{delta:e} by {step:e}");
                assert_eq!(cut, delta.abs() > step, "{delta:e} by {step:e}");
            }
        }
    }
}
