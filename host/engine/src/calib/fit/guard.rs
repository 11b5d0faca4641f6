//! What a fit must show before a calibration is made of it: that it
//! converged, and that it leaves the arm no worse than it started. A
//! calibration file is what `push` sends to the board, so a fit that
//! diverged, or that meets its own poses worse than the nominal arm placed
//! (by more than an RMS of that many coordinates spreads by), or that
//! predicts the poses it leaves out worse than that (by more than a
//! standard error), or that moves the arm's geometry by more than any real
//! arm is off, is refused here with what happened and what to try.
//!
//! "Where it started" is the nominal arm placed: its base and tool points
//! fitted to the same poses, nothing of the arm itself
//! (`calib::model_choice`'s placement, what registration finds). Its
//! leave-one-out error is the bar for the fit's: both fits are judged on
//! the poses they leave out, so a fit with more parameters than the poses
//! carry loses even where its residual is small. Without that fit (no base
//! or tool point among the parameters) the bar is the nominal arm's
//! residual as the fit started.
//!
//! A richer model fitted robustly minimises Huber's cost, not the RMS: on
//! poses the placement already meets at the noise, its RMS may come out a
//! hair above the placement's. The residual check allows the sampling
//! spread of an RMS of `N` coordinates, `RMS / √(2N)` (3 % of it from 150
//! points), far below what a fit that went astray adds (56 mm against
//! 3.9 on the TIAGo data).

use crate::calib::fit::identify::Identified;
use crate::calib::fit::model_choice::paired;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::real_arm::{LENGTH_FRACTION_OF_REACH, MAX_TWIST_RAD};
use crate::calib::{CalibError, ModelOption};
use model::params::ParamPart;
use model::{Arm, JointKind};

/// Refuses `fit` of `option` on `nominal` when it did not converge, made
/// the arm worse than `placement` (the nominal arm placed on the same
/// poses) or than it started, or moved its geometry past a physical size
/// (module docs).
pub fn check(
    option: ModelOption,
    nominal: &Arm<f64>,
    fit: &Identified,
    placement: Option<&Identified>,
) -> Result<(), CalibError> {
    let d = &fit.diagnostics;
    // A simpler model is the way out, unless the option is already the
    // geometry alone: then the arm's other effects may be what it bends to.
    let simpler = if matches!(option, ModelOption::Kinematic | ModelOption::PaperKinematic) {
        "the geometry alone may be bending to effects it does not have (springs, servo curves): try the default option, elasto-kinematic-servo"
    } else {
        "try a simpler model: --option kinematic"
    };
    let refuse = |what: String, first: &str| CalibError::Refused {
        option: option.name().into(),
        what,
        advice: format!("{first}, or {simpler}."),
    };
    let mm = |m: f64| format!("{:.2} mm", m * 1e3);
    if !d.converged {
        return Err(refuse(
            format!(
                "the fit did not converge ({}), ending at {} residual RMS where it started at {}",
                d.termination,
                mm(d.rms_after_m),
                mm(d.rms_before_m)
            ),
            "Measure more poses (or let `lrmcal select` choose them)",
        ));
    }
    // What the fit must beat: the nominal arm placed on the same poses (its
    // residual, and its leave-one-out errors measurement by measurement:
    // worse by more than the standard error of the difference), or without
    // a placement the nominal arm's residual.
    let (bar, bar_rms, worse, bar_loo) = match placement {
        Some(p) => {
            let p = &p.diagnostics;
            let (difference, se) = paired(&d.loo_errors_m, &p.loo_errors_m);
            (
                "the nominal arm placed (its base and tool points fitted)",
                p.rms_after_m,
                difference > se,
                p.loo_mean_m + se,
            )
        }
        None => (
            "the nominal arm",
            d.rms_before_m,
            d.loo_mean_m > d.rms_before_m,
            d.rms_before_m,
        ),
    };
    let coordinates = fit.fit_residual.count * fit.rig.measured_axes();
    let spread = bar_rms / (2.0 * coordinates.max(1) as f64).sqrt();
    if d.rms_after_m > bar_rms + spread {
        return Err(refuse(
            format!(
                "the fit meets its own poses worse than {bar} ({} residual RMS against {})",
                mm(d.rms_after_m),
                mm(bar_rms)
            ),
            "Check the measurements against the poses (the same order, the arm's joint signs)",
        ));
    }
    if worse || !d.loo_mean_m.is_finite() {
        return Err(refuse(
            format!(
                "the fit predicts the fitted poses left out worse than {bar} (leave-one-out mean error {} against {}): the poses do not carry this model",
                mm(d.loo_mean_m),
                mm(bar_loo)
            ),
            "Measure more poses",
        ));
    }
    match beyond_size(nominal, fit) {
        Some(what) => Err(refuse(
            what,
            "Check that the arm file is this arm (its joint signs and zero angles), measure more poses",
        )),
        None => Ok(()),
    }
}

/// What of `fit` moves `nominal`'s geometry further than any real arm of
/// its size is off (a length by a tenth of its reach, a twist by 10°), if
/// anything: the measurements do not pin what moved so far.
pub fn beyond_size(nominal: &Arm<f64>, fit: &Identified) -> Option<String> {
    let mm = |m: f64| format!("{:.2} mm", m * 1e3);
    let reach = crate::ik::reach_m(nominal);
    for e in &fit.estimates {
        let ParamKey::Arm(id) = e.id else { continue };
        let ParamPart::Dh { joint, field } = id.part() else {
            continue;
        };
        let slides = nominal.joints[joint].kind == JointKind::Prismatic;
        let size = match field {
            // A slide's `d` is its zero, like a turn's `theta`.
            1 if slides => None,
            1 | 2 if e.error.abs() > LENGTH_FRACTION_OF_REACH * reach => Some(mm(e.error)),
            3 | 4 if e.error.abs() > MAX_TWIST_RAD => Some(format!("{:.1}°", e.error.to_degrees())),
            _ => None,
        };
        if let Some(size) = size {
            return Some(format!(
                "the fit moves {id} by {size}, more than any arm of this size is off (lengths {} at most, twists {:.0}°): the measurements do not pin it",
                mm(LENGTH_FRACTION_OF_REACH * reach),
                MAX_TWIST_RAD.to_degrees()
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::fit::identify::Estimate;
    use crate::calib::testing::{fitted as fit, key, test_arm};

    fn estimate(name: &str, error: f64) -> Estimate {
        Estimate {
            id: key(name),
            error,
            value: error,
            std: Some(1e-4),
            weak: false,
        }
    }

    #[test]
    fn a_fit_that_helps_passes() {
        let arm = test_arm();
        let good = fit(true, 4e-3, 1e-3, 1.5e-3, vec![estimate("j2.a", 2e-3)]);
        assert!(check(ModelOption::Kinematic, &arm, &good, None).is_ok());
        // A joint's zero may be a spline tooth off.
        let zero = fit(true, 4e-3, 1e-3, 1.5e-3, vec![estimate("j2.theta", 0.25)]);
        assert!(check(ModelOption::Kinematic, &arm, &zero, None).is_ok());
    }

    #[test]
    fn diverged_worse_and_overfitted_fits_are_refused_with_their_figures() {
        let arm = test_arm();
        let o = ModelOption::ElastoKinematicServo;
        let message = |f: Identified| check(o, &arm, &f, None).unwrap_err().to_string();
        // The TIAGo split that ended at 56 mm after registration left 3.9 mm.
        let diverged = message(fit(false, 3.9e-3, 56.3e-3, 1.156, vec![]));
        assert!(
            diverged.contains("did not converge (LostPatience)")
                && diverged.contains("56.30 mm")
                && diverged.contains("3.90 mm")
                && diverged.contains("no calibration was written"),
            "{diverged}"
        );
        let worse = message(fit(true, 3.9e-3, 4.1e-3, 4.5e-3, vec![]));
        assert!(
            worse.contains("worse than the nominal arm (4.10 mm"),
            "{worse}"
        );
        let overfitted = message(fit(true, 4.1e-3, 1.7e-3, 5.6e-3, vec![]));
        assert!(
            overfitted.contains("leave-one-out mean error 5.60 mm"),
            "{overfitted}"
        );
        // Beside the placement: judged on the poses both leave out.
        let placed = fit(true, 40e-3, 3.2e-3, 3.9e-3, vec![]);
        let loses = fit(true, 40e-3, 2.0e-3, 4.2e-3, vec![]);
        let e = check(o, &arm, &loses, Some(&placed))
            .unwrap_err()
            .to_string();
        // Its bar: 3.9 mm and the standard error of the difference.
        assert!(
            e.contains("worse than the nominal arm placed")
                && e.contains("leave-one-out mean error 4.20 mm against 3.9"),
            "{e}"
        );
        let level = fit(true, 40e-3, 2.0e-3, 3.9e-3, vec![]);
        assert!(check(o, &arm, &level, Some(&placed)).is_ok());
        // A residual a hair above the placement's, within what an RMS of
        // 300 coordinates spreads by (4 %), is no sign of trouble; beyond, it is.
        let hair = fit(true, 40e-3, 3.3e-3, 3.9e-3, vec![]);
        assert!(check(o, &arm, &hair, Some(&placed)).is_ok());
        let above = fit(true, 40e-3, 3.4e-3, 3.9e-3, vec![]);
        let e = check(o, &arm, &above, Some(&placed))
            .unwrap_err()
            .to_string();
        assert!(e.contains("3.40 mm residual RMS against 3.20 mm"), "{e}");
        let far = message(fit(
            true,
            4e-3,
            1e-3,
            1.5e-3,
            vec![estimate("j3.alpha", 0.3)],
        ));
        assert!(
            far.contains("moves j3.alpha by 17.2°") && far.contains("--option kinematic"),
            "{far}"
        );
        // The geometry alone is sent to the richer model instead.
        let kinematic = check(
            ModelOption::Kinematic,
            &arm,
            &fit(true, 4e-3, 1e-3, 1.5e-3, vec![estimate("j5.alpha", -0.23)]),
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(
            kinematic.contains("try the default option, elasto-kinematic-servo"),
            "{kinematic}"
        );
        // The base and the tool point may be anywhere: registration found them.
        let base = fit(true, 4e-3, 1e-3, 1.5e-3, vec![estimate("base.x", 0.5)]);
        assert!(check(o, &arm, &base, None).is_ok());
    }
}
