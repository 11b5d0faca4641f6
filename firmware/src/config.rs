//! Limits and tuning of the firmware, with the defaults the board runs on.

use model::{CompensationOptions, ServoCurve};
use protocol::FirmwareVersion;

/// Everything the firmware logic needs to be told once at start-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Reported in `status`.
    pub firmware: FirmwareVersion,
    /// No pulse outside `[min, max]` µs ever reaches a servo, whatever the calibration says.
    pub pulse_range_us: [u16; 2],
    /// The servo curve without a calibration.
    pub uncalibrated_curve: ServoCurve<f32>,
    /// Absolute joint range, rad: a calibration's limits are cut to it.
    pub hard_limits_rad: [f32; 2],
    /// Joint range without a calibration, rad (the servo's ±100° data-sheet span).
    pub default_limits_rad: [f32; 2],
    /// Top joint speed, rad/s.
    pub max_speed_rad_s: f32,
    /// Top joint acceleration, rad/s².
    pub max_accel_rad_s2: f32,
    /// Longest move accepted, ms.
    pub max_duration_ms: u32,
    /// Heaviest payload accepted, kg.
    pub max_payload_kg: f32,
    /// The board's cap on the calibration's largest corrections
    /// (`Calibration::max_correction_rad`): a compensation that moves a joint
    /// further than the smaller of the two from its nominal angle is treated
    /// as failed, rad.
    pub max_correction_rad: f32,
    /// How fast the correction on the servos may change, rad/s: switching
    /// compensation on or off, a new payload or a new calibration fade in
    /// instead of jerking the arm. Far above what a move itself needs.
    pub max_correction_rate_rad_s: f32,
    /// Tolerance and damping of the per-frame compensation step (one Newton
    /// step per servo frame: `max_iterations` is not used on the board).
    pub compensation: CompensationOptions<f32>,
}

impl Default for Config {
    /// 500–2500 µs, the data-sheet servo curve, ±150° hard and ±100° default limits, 1.5 rad/s, 4 rad/s²,
    /// 0.5 kg, corrections capped at 60° (`protocol::calibration::MAX_CORRECTION_RAD`) changing at most 0.5 rad/s,
    /// 5 µm tolerance.
    fn default() -> Self {
        Self {
            firmware: FirmwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
            pulse_range_us: model::servo::PULSE_RANGE_US,
            uncalibrated_curve: ServoCurve::nominal(),
            hard_limits_rad: [-150f32.to_radians(), 150f32.to_radians()],
            default_limits_rad: [-100f32.to_radians(), 100f32.to_radians()],
            max_speed_rad_s: 1.5,
            max_accel_rad_s2: 4.0,
            max_duration_ms: 600_000,
            max_payload_kg: 0.5,
            max_correction_rad: protocol::calibration::MAX_CORRECTION_RAD,
            max_correction_rate_rad_s: 0.5,
            // f32 carries ~0.05 µm at arm scale and the deflection solve stops at
            // ~4e-6 rad, so a few µm is the tightest tolerance f32 reaches reliably.
            compensation: CompensationOptions {
                tolerance_m: 5e-6,
                damping_m: 1e-6,
                max_iterations: 1,
                settle_rad: 1e-5,
            },
        }
    }
}
