//! How many knots the servo curves get: the spacing whose fit best predicts
//! the poses it leaves out.
//!
//! Each knot of our option's servo curves is a parameter the poses must
//! determine (`calib::servo_knots`). From many poses the finest grid (every
//! 25°) follows a servo's error best; from few, its knots take up the
//! measurements' noise and the fit predicts the poses it did not see worse
//! than a coarser curve would (on the bundled arm from 30 poses the finest
//! grid even bends a curve back on itself). So the fit is made on the
//! finest grid the candidates' analysis kept, then on coarser ones (every
//! 50°, every 100°) while their leave-one-out error (`calib::identify`: each
//! measurement's error in the fit without it) keeps dropping, and the best
//! is kept. A fit that fails (a curve that no longer maps angle to pulse
//! one-to-one, too few poses for its parameters) loses to any that does.
//!
//! The finest grid and the next coarser one are fitted side by side (two
//! cores): most fits stop there.
//!
//! Under a prior (`calib::parameters::prior`, ours), a curve's knots are
//! determined, by the poses where they see it and by the curve's smoothness
//! where they do not: the curves are fitted on the finest grid (every 25°)
//! whatever the grid the poses were chosen for, and on that one only. A
//! coarser grid is a stiffer curve, and how stiff the curves are is the
//! prior's correlation length, which the measurements' evidence chooses
//! (`calib::grow`); beside it a coarser grid's leave-one-out error only
//! adds the noise of its choice (on the second test arm from 20 poses,
//! every 100° had a leave-one-out error 0.06 mm below every 25°'s, and its
//! calibration missed the poses off the grid by 3.8 mm, every 25°'s by
//! 3.1 mm).

use crate::calib::CalibError;
use crate::calib::fit::choice::{ChosenFit, KnotChoice, KnotTrial};
use crate::calib::fit::identify::Identified;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::{KnotSpacing, respaced, spacing_of};

/// The knot spacing stage: `fit_on` (the stages after it) of `kept`; when
/// `kept` holds servo knots, of `kept` on each spacing tried, the one chosen
/// as the module docs say: the finest grid alone for a fit under a
/// `prior`, `kept`'s own and coarser ones otherwise.
pub fn choose(
    kept: &[ParamKey],
    prior: bool,
    fit_on: impl Fn(&[ParamKey]) -> Result<Identified, CalibError> + Sync,
) -> Result<ChosenFit, CalibError> {
    let finest = spacing_of(kept).map(|own| match prior {
        true => KnotSpacing::FINEST,
        false => own,
    });
    let Some(finest) = finest else {
        return Ok(ChosenFit {
            identified: fit_on(kept)?,
            knots: None,
            model: None,
        });
    };
    let fit_spaced = |spacing: KnotSpacing| fit_on(&respaced(kept, spacing));
    if prior {
        let fit = fit_spaced(finest);
        return Ok(ChosenFit {
            knots: Some(KnotChoice {
                chosen: finest,
                trials: vec![KnotTrial {
                    spacing: finest,
                    loo_mean_mm: fit.as_ref().ok().map(|f| f.diagnostics.loo_mean_m * 1e3),
                    failure: fit.as_ref().err().map(|e| e.to_string()),
                }],
            }),
            identified: fit?,
            model: None,
        });
    }
    let (first, second) = rayon::join(
        || fit_spaced(finest),
        || finest.coarser().map(|s| (s, fit_spaced(s))),
    );
    let mut fits = vec![(finest, first)];
    fits.extend(second);
    // Coarser still while the last fit failed or predicted better than the one before.
    while let Some(coarser) = fits.last().and_then(|(spacing, _)| spacing.coarser()) {
        let n = fits.len();
        let go_on = match (&fits[n - 1].1, n.checked_sub(2).map(|i| &fits[i].1)) {
            (Ok(last), Some(Ok(before))) => {
                last.diagnostics.loo_mean_m < before.diagnostics.loo_mean_m
            }
            _ => true,
        };
        if !go_on {
            break;
        }
        fits.push((coarser, fit_spaced(coarser)));
    }
    let trials = fits
        .iter()
        .map(|(spacing, fit)| KnotTrial {
            spacing: *spacing,
            loo_mean_mm: fit.as_ref().ok().map(|f| f.diagnostics.loo_mean_m * 1e3),
            failure: fit.as_ref().err().map(|e| e.to_string()),
        })
        .collect();
    let best = fits
        .iter()
        .enumerate()
        .filter_map(|(i, (_, fit))| fit.as_ref().ok().map(|f| (i, f.diagnostics.loo_mean_m)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i);
    // Every spacing failed: the coarsest's reason, the simplest curve's.
    let i = best.unwrap_or(fits.len() - 1);
    let (chosen, fit) = fits.swap_remove(i);
    Ok(ChosenFit {
        identified: fit?,
        knots: Some(KnotChoice { chosen, trials }),
        model: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::key;

    /// Knots respaced finer keep the held knot held and the other keys in
    /// their places; respaced coarser, only the coarser grid's.
    #[test]
    fn respacing_keeps_the_held_knot_and_the_other_keys() {
        let knot = |joint: u8, knot: u8| ParamKey::ServoKnot { joint, knot };
        // Every 100°: -100° and 0° fitted, +100° held.
        let kept = vec![key("k2"), knot(1, 0), knot(1, 4), key("j2.a")];
        let fine = respaced(&kept, KnotSpacing::Deg25);
        let expected: Vec<ParamKey> = std::iter::once(key("k2"))
            .chain((0..8).map(|k| knot(1, k)))
            .chain([key("j2.a")])
            .collect();
        assert_eq!(fine, expected);
        assert_eq!(respaced(&fine, KnotSpacing::Deg100), kept);
        assert_eq!(
            respaced(&fine, KnotSpacing::Deg50),
            [
                key("k2"),
                knot(1, 0),
                knot(1, 2),
                knot(1, 4),
                knot(1, 6),
                key("j2.a")
            ]
        );
        assert_eq!(respaced(&[key("k2")], KnotSpacing::Deg25), [key("k2")]);
    }
}
