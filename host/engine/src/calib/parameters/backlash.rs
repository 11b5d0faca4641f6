//! The joints' backlash (`model::backlash`) as parameters of the fit.
//!
//! A joint with play of full width `w` stands `w/2` short of its command
//! when it arrived rising and `w/2` beyond it when it arrived falling. Which
//! way each joint arrived at each measurement follows from the order the
//! poses were visited (`lrmcal_core::dataset::visiting_order`), so the width is
//! identified from the same measurements as the rest: its column is the
//! joint-angle column times `-s/2` (`calib::joint_columns`).
//!
//! Unlike every other parameter, whether a width can be identified depends
//! on the visiting order, not on the poses: a joint that arrived the same
//! way at every fitted pose has a width indistinguishable from an offset of
//! its angle. So the widths are not among the candidates DETMAX selects
//! for; they join the fit afterwards ([`with_widths`]), each when the
//! measurements to be fitted show its joint arriving both ways and the rank
//! analysis over them keeps it.
//!
//! A fitted width is a physical quantity the board takes: the fit keeps it
//! between zero and [`FIT_MAX_RAD`] (its active set, `calib::identify`), so
//! the calibration always reaches the board; one wider than
//! [`PLAUSIBLE_MAX_RAD`] is flagged (`calib::summary::backlash`).

use crate::calib::analysis::identifiability::{RANK_TOLERANCE, TypicalErrors, joining};
use crate::calib::analysis::jacobian::jacobian;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::prior::{Prior, SERVO_CORRELATION_DEG};
use crate::calib::parameters::servo_knots::fit_start;
use crate::calib::{CalibError, ModelOption, Rig};
use lrmcal_core::dataset::Measurement;
use model::backlash::Approach;

/// Widest play a working hobby servo's joint has, rad (3°): wider means the
/// measurements of the joint disagree with each other or its gears are worn.
pub const PLAUSIBLE_MAX_RAD: f64 = 0.052_359_877_559_829_88;

/// Widest play the fit gives a joint, rad: the widest the bounds allow
/// (`model::bounds::MAX_BACKLASH_RAD`, 5°), kept inside by the fit's margin.
pub const FIT_MAX_RAD: f64 = model::bounds::MAX_BACKLASH_RAD * (1.0 - model::bounds::FIT_MARGIN);

/// Fewest fitted poses at which a joint must have arrived each way before
/// its width is fitted.
pub const MIN_EACH_WAY: usize = 3;

/// The width keys of every joint of an arm of `joints` joints.
pub fn keys(joints: usize) -> impl Iterator<Item = ParamKey> {
    (0..joints).map(|joint| ParamKey::Backlash { joint: joint as u8 })
}

/// `kept` (the option's parameters the candidates' analysis kept) with the
/// widths `measurements` identify appended, when `option` fits them: those
/// of the joints that arrived each way at [`MIN_EACH_WAY`] poses or more,
/// and that the rank analysis over the fitted samples keeps after `kept`
/// (after those of `kept` the poses alone must determine, for a fit under
/// a `prior`).
pub fn with_widths(
    nominal: &Rig,
    option: ModelOption,
    kept: &[ParamKey],
    measurements: &[Measurement],
    prior: bool,
) -> Result<Vec<ParamKey>, CalibError> {
    if !crate::calib::parameters::option::fits_backlash(option) {
        return Ok(kept.to_vec());
    }
    let samples = nominal.samples(measurements)?;
    let both_ways = |joint: usize| {
        let rising = samples
            .iter()
            .filter(|s| s.approach[joint] == Approach::Rising)
            .count();
        rising >= MIN_EACH_WAY && samples.len() - rising >= MIN_EACH_WAY
    };
    let widths: Vec<ParamKey> = keys(nominal.arm.joints.len())
        .enumerate()
        .filter(|(joint, _)| both_ways(*joint))
        .map(|(_, k)| k)
        .collect();
    if widths.is_empty() {
        return Ok(kept.to_vec());
    }
    // Under a prior the knots are determined by it too: a width is judged
    // against the columns of the parameters the poses alone must determine.
    let against: Vec<ParamKey> = match prior {
        true => {
            let start = fit_start(nominal, kept);
            // Which keys it holds, whatever the servo curves' correlation.
            let held = Prior::new(&start, &start, kept, SERVO_CORRELATION_DEG);
            kept.iter()
                .enumerate()
                .filter(|(c, _)| !held.as_ref().is_some_and(|p| p.holds(*c)))
                .map(|(_, k)| *k)
                .collect()
        }
        false => kept.to_vec(),
    };
    let ids: Vec<ParamKey> = against.iter().chain(&widths).copied().collect();
    let start = fit_start(nominal, &ids);
    let j = jacobian(&start, &ids, &samples)?;
    let joining = joining(
        &against,
        &widths,
        &j,
        &TypicalErrors::of_arm(&nominal.arm),
        RANK_TOLERANCE,
    );
    Ok(kept.iter().chain(&joining).copied().collect())
}
