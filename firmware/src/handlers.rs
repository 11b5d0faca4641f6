//! One function per endpoint of the `protocol` table, called by the table in
//! `dispatch.rs`. Each checks its input completely before it changes
//! anything, so a refused request leaves the board as it was.
//!
//! Joints and channels: moves, `motion/home` and attaching all drive the
//! arm's joints' channels, `0..joints`; a move must give one target per
//! joint (`TargetCount` otherwise); attaching, or a raw pulse on, a channel
//! past the last joint is refused (`UnusedChannel`): it stays limp. Detaching
//! any channel is allowed (one past the last joint is limp already; like any
//! detach, it stops a running motion).

use heapless::Vec;
use protocol::calibration::MAX_CALIBRATION_LEN;
use protocol::frame::crc32;
use protocol::{
    CHUNK_LEN, Calibration, CompensationMode, CompensationReport, Faults, Response, Status, Timing,
    WireError,
};

use crate::app::{Channel, Reply, SystemAction, Transfer};
use crate::motion::{PlanError, Profile};
use crate::{CHANNELS, Device, FlashStorage, PerChannel, ServoBus};

/// `link/hello`: the versions, first thing after connecting.
pub(crate) fn hello<B: ServoBus, F: FlashStorage>(d: &Device<B, F>) -> Reply {
    Ok(Response::Hello(d.device_info()))
}

/// `status/get`; clears the flags that latch until read.
pub(crate) fn status<B: ServoBus, F: FlashStorage>(d: &mut Device<B, F>) -> Reply {
    let mut faults = d.faults;
    faults.set(Faults::NO_CALIBRATION, d.active.is_none());
    d.faults.set(Faults::LIMIT_CLAMPED, false);
    d.faults.set(Faults::FRAMES_DROPPED, false);
    Ok(Response::Status(Status {
        device: d.device_info(),
        calibration: d.active.as_ref().map(|a| a.info),
        mode: d.mode,
        compensation: d
            .active
            .as_ref()
            .map_or(CompensationReport::default(), |a| a.compensator.report()),
        payload_kg: d.payload_kg,
        // The servos still move while a correction fades in, though no motion runs.
        moving: d.moving || d.settling,
        targets_rad: d.motion.end(),
        nominal_rad: d.position,
        pulses_us: d.channels.map(Channel::pulse_us),
        faults,
        frames_dropped: d.frames_dropped,
        uptime_ms: d.now_us.saturating_sub(d.boot_us) / 1000,
    }))
}

/// The joint angle a channel under `servo/raw` is at, from its pulse.
fn angle_of_raw<B: ServoBus, F: FlashStorage>(d: &Device<B, F>, channel: usize, pulse: u16) -> f32 {
    let curve = &d.curve(channel).curve;
    let [lo, hi] = d.limits()[channel];
    let a = curve.angle(f32::from(pulse));
    if a.is_finite() {
        a.clamp(lo, hi)
    } else {
        d.position[channel]
    }
}

/// Drives `channel` from the motion again; a channel under raw tuning
/// takes over the position its pulse gave.
fn hold<B: ServoBus, F: FlashStorage>(d: &mut Device<B, F>, channel: usize) {
    d.channels[channel] = match d.channels[channel] {
        Channel::Limp => Channel::Held(None),
        Channel::Held(last) => Channel::Held(last),
        Channel::Raw(p) => {
            d.position[channel] = angle_of_raw(d, channel, p);
            Channel::Held(Some(p))
        }
    };
}

/// `motion/move`: attach every joint and start a move; one target per joint.
pub(crate) fn move_to<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    targets: PerChannel<f32>,
    timing: Timing,
) -> Reply {
    d.ensure_idle()?;
    let joints = d.joints();
    if targets.len() != joints {
        return Err(WireError::TargetCount);
    }
    if !targets.iter().all(|t| t.is_finite()) {
        return Err(WireError::NotFinite);
    }
    let limits = d.limits();
    if targets
        .iter()
        .zip(&limits)
        .any(|(t, [lo, hi])| t < lo || t > hi)
    {
        return Err(WireError::OutOfRange);
    }
    let mut start = d.position;
    for (i, s) in start.iter_mut().enumerate() {
        if let Channel::Raw(p) = d.channels[i] {
            *s = angle_of_raw(d, i, p);
        }
    }
    let max_s = d.config.max_duration_ms as f32 / 1000.0;
    let profile = Profile::plan(start, targets, d.now_us, timing, d.motion_limits(), max_s)
        .map_err(|e| match e {
            PlanError::NotFinite => WireError::NotFinite,
            PlanError::OutOfRange => WireError::OutOfRange,
        })?;
    for i in 0..joints {
        hold(d, i);
    }
    d.position = start;
    d.motion = profile;
    d.moving = true;
    if let Some(a) = d.active.as_mut() {
        a.compensator.start_move();
    }
    Ok(Response::Done)
}

/// `motion/home`: a move to the calibration's home pose.
pub(crate) fn home<B: ServoBus, F: FlashStorage>(d: &mut Device<B, F>, timing: Timing) -> Reply {
    move_to(d, d.home(), timing)
}

/// The channels a request names among the first `count`: one, or all for
/// `None`. A channel past the board's is out of range; one past `count` (a
/// board's channel with no joint on it) is unused.
fn channels(channel: Option<u8>, count: usize) -> Result<core::ops::Range<usize>, WireError> {
    match channel.map(usize::from) {
        None => Ok(0..count),
        Some(c) if c < count => Ok(c..c + 1),
        Some(c) if c < CHANNELS => Err(WireError::UnusedChannel),
        Some(_) => Err(WireError::OutOfRange),
    }
}

/// `servo/attach`: hold at the current position; refused mid-motion, where
/// holding would be an abrupt stop. Only the arm's joints' channels: all of
/// them for `None`, and one past the last joint is refused.
pub(crate) fn attach<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    channel: Option<u8>,
) -> Reply {
    let range = channels(channel, d.joints())?;
    d.ensure_idle()?;
    for i in range {
        hold(d, i);
    }
    d.motion = Profile::hold(d.position);
    Ok(Response::Done)
}

/// `servo/detach`: stops any motion (a limp joint cannot follow it) and, at
/// once rather than at the next servo frame, the pulses. Any of the board's
/// channels, or all of them.
pub(crate) fn detach<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    channel: Option<u8>,
) -> Reply {
    for i in channels(channel, CHANNELS)? {
        d.channels[i] = Channel::Limp;
        d.bus.set_pulse(i, None);
    }
    d.motion = Profile::hold(d.position);
    d.moving = false;
    if let Some(a) = &mut d.active {
        a.compensator.reset();
    }
    Ok(Response::Done)
}

/// `servo/raw`: a clamped raw pulse on one joint's channel, on the servo at
/// once (as `servo/detach` stops the pulses at once), not at the next frame.
pub(crate) fn raw_pulse<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    channel: u8,
    pulse_us: u16,
) -> Reply {
    let i = channels(Some(channel), d.joints())?.start;
    d.ensure_idle()?;
    let [lo, hi] = d.config.pulse_range_us;
    let applied = pulse_us.clamp(lo, hi);
    d.channels[i] = Channel::Raw(applied);
    d.bus.set_pulse(i, Some(applied));
    Ok(Response::Pulse {
        applied_us: applied,
    })
}

/// `comp/payload`.
pub(crate) fn set_payload<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    mass_kg: f32,
) -> Reply {
    if !mass_kg.is_finite() {
        return Err(WireError::NotFinite);
    }
    if !(0.0..=d.config.max_payload_kg).contains(&mass_kg) {
        return Err(WireError::OutOfRange);
    }
    d.payload_kg = mass_kg;
    Ok(Response::Done)
}

/// `comp/mode`: refused while moving, since the correction would appear mid-path.
pub(crate) fn set_compensation<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    mode: CompensationMode,
) -> Reply {
    if mode != CompensationMode::Off && d.active.is_none() {
        return Err(WireError::NoCalibration);
    }
    d.ensure_idle()?;
    d.mode = mode;
    if let Some(a) = &mut d.active {
        a.compensator.reset();
    }
    Ok(Response::Done)
}

/// `calib/begin`: a new upload replaces any unfinished one.
pub(crate) fn calibration_begin<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    len: u32,
    crc: u32,
) -> Reply {
    let len = len as usize;
    if len == 0 || len > MAX_CALIBRATION_LEN {
        return Err(WireError::OutOfRange);
    }
    d.transfer = Some(Transfer {
        len,
        crc,
        received: 0,
        buf: [0; MAX_CALIBRATION_LEN],
    });
    Ok(Response::CalibrationAck { received: 0 })
}

/// `calib/chunk`: a chunk may repeat bytes already received (a retry) but not leave a gap.
pub(crate) fn calibration_chunk<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    offset: u32,
    data: &[u8],
) -> Reply {
    let t = d.transfer.as_mut().ok_or(WireError::NoTransfer)?;
    let offset = offset as usize;
    let end = offset.checked_add(data.len()).ok_or(WireError::BadChunk)?;
    if offset > t.received || end > t.len {
        return Err(WireError::BadChunk);
    }
    t.buf[offset..end].copy_from_slice(data);
    t.received = t.received.max(end);
    Ok(Response::CalibrationAck {
        received: t.received as u32,
    })
}

/// `calib/commit`: the whole upload is checked, stored, read back and only then applied.
pub(crate) fn calibration_commit<B: ServoBus, F: FlashStorage>(d: &mut Device<B, F>) -> Reply {
    let t = d.transfer.as_ref().ok_or(WireError::NoTransfer)?;
    if t.received < t.len {
        return Err(WireError::TransferIncomplete);
    }
    d.ensure_idle()?;
    let bytes = &t.buf[..t.len];
    if crc32(bytes) != t.crc {
        d.transfer = None;
        return Err(WireError::CalibrationCrc);
    }
    let Some(calibration) = Calibration::decode(bytes) else {
        d.transfer = None;
        return Err(WireError::CalibrationInvalid);
    };
    let stored = d.storage.store(bytes);
    d.transfer = None;
    let Ok(sequence) = stored else {
        // Only the slot not in use was touched; the calibration in use stays.
        d.faults.set(Faults::FLASH_FAILED, true);
        return Err(WireError::Flash);
    };
    d.faults.set(Faults::FLASH_FAILED, false);
    d.switch_calibration(Some((calibration, sequence)));
    Ok(Response::CalibrationStored(
        d.active.as_ref().map(|a| a.info).ok_or(WireError::Flash)?,
    ))
}

/// `calib/read`.
pub(crate) fn calibration_read<B: ServoBus, F: FlashStorage>(
    d: &mut Device<B, F>,
    offset: u32,
) -> Reply {
    let (len, crc) = d.storage.active_payload().ok_or(WireError::NoCalibration)?;
    let mut chunk = [0u8; CHUNK_LEN];
    let n = d
        .storage
        .read_payload(offset as usize, &mut chunk)
        .map_err(|_| WireError::OutOfRange)?;
    let data = Vec::from_slice(&chunk[..n]).map_err(|_| WireError::OutOfRange)?;
    Ok(Response::CalibrationData {
        len_bytes: len,
        crc,
        offset,
        data,
    })
}

/// `calib/erase`: back to nominal curves, compensation off.
pub(crate) fn calibration_erase<B: ServoBus, F: FlashStorage>(d: &mut Device<B, F>) -> Reply {
    d.ensure_idle()?;
    let erased = d.storage.erase();
    if erased.is_err() {
        d.faults.set(Faults::FLASH_FAILED, true);
        // Whatever survived the failed erase is what a reboot would find; run on that.
        let report = d.storage.load();
        let survivor = report.loaded.map(|l| (l.calibration, l.sequence));
        if survivor.is_none() {
            d.mode = CompensationMode::Off;
        }
        d.switch_calibration(survivor);
        return Err(WireError::Flash);
    }
    d.switch_calibration(None);
    d.mode = CompensationMode::Off;
    Ok(Response::Done)
}

/// `sys/bootloader`: the binary reboots once the reply has gone out.
pub(crate) fn reboot_to_bootloader<B: ServoBus, F: FlashStorage>(d: &mut Device<B, F>) -> Reply {
    d.pending = Some(SystemAction::RebootToBootloader);
    Ok(Response::Done)
}
