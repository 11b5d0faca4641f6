//! How much model the measurements carry: the option's effects, added one
//! at a time, while they predict the poses the fit leaves out better.
//!
//! An effect the arm does not have (springs on a rigid industrial arm,
//! servo curves that are as their data sheet says) still gets parameters
//! in a richer option, and those take up the measurements' noise: the fit
//! meets its own poses more closely and predicts others worse. So an
//! option that adds effects to the geometry is fitted as a ladder of
//! models, simplest first: for ours the nominal arm placed (its base and
//! tool points only, what registration finds), the geometry
//! (`kinematic`), then with the springs (`elasto-kinematic`), then ours
//! with the servo curves, their knot spacing, the play and the springs'
//! softening; for elasto-kinematic its geometry, then the springs. Each
//! rung's leave-one-out error (each fitted measurement's error in the fit
//! without it, `calib::identify`) says how well it predicts; the simplest
//! rung within one standard error of the best one's mean is kept (the usual
//! one-standard-error rule: a richer model must predict better by more
//! than the measurements can tell apart). A rung whose fit fails loses to
//! any that does. The calibration keeps the option asked for (its file,
//! its name on the board); what the ladder chose is reported beside it.
//!
//! The placement is fitted for every option, in or out of its ladder: it
//! is where the arm starts, the bar `calib::guard` holds every calibration
//! to. The paper's own sets (`paper-kinematic`, `paper-elasto-kinematic`)
//! and the options of one effect (`kinematic`, `elastic`) are otherwise
//! fitted as they are.

use serde::{Deserialize, Serialize};

use crate::calib::fit::knot_choice::ChosenFit;
use crate::calib::parameters::params::ParamKey;
use crate::calib::{CalibError, ModelOption};
use model::params::ParamPart;

/// A rung of the ladder: a model of the arm, by what it fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Rung {
    /// The nominal arm placed: its base and tool points only.
    Placement,
    /// The effects of a model option.
    #[serde(untagged)]
    Model(#[serde(with = "lrmcal_core::io::model_option")] ModelOption),
}

impl std::fmt::Display for Rung {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Rung::Placement => f.write_str("placement"),
            Rung::Model(option) => write!(f, "{option}"),
        }
    }
}

/// One rung of the ladder as fitted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelTrial {
    /// The rung.
    pub model: Rung,
    /// Parameters the rung's fit ended with; 0 when it failed.
    pub parameters: usize,
    /// Mean leave-one-out error of its fit, mm; `None` when it failed.
    pub loo_mean_mm: Option<f64>,
    /// Standard error of that mean, mm (the errors' deviation over the
    /// square root of their count).
    pub loo_se_mm: Option<f64>,
    /// Why its fit failed, if it did.
    pub failure: Option<String>,
}

/// The rung kept and every rung fitted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelChoice {
    /// The model the calibration holds.
    pub chosen: Rung,
    /// Every rung, simplest first.
    pub trials: Vec<ModelTrial>,
}

/// The rungs `option` is fitted as, simplest first, `option` last.
pub fn ladder(option: ModelOption) -> Vec<Rung> {
    let model = Rung::Model;
    match option {
        ModelOption::ElastoKinematic => vec![model(ModelOption::Kinematic), model(option)],
        ModelOption::ElastoKinematicServo => vec![
            Rung::Placement,
            model(ModelOption::Kinematic),
            model(ModelOption::ElastoKinematic),
            model(option),
        ],
        _ => vec![model(option)],
    }
}

/// The parameters of `kept` (an analysis of the option asked for) that
/// `rung` fits: the base and the tool points for the placement, the
/// geometry and the further targets' tool points for kinematic, and the
/// compliances too for elasto-kinematic; all of them for ours.
pub fn keys_for(rung: Rung, kept: &[ParamKey]) -> Vec<ParamKey> {
    kept.iter()
        .copied()
        .filter(|key| match rung {
            Rung::Placement => match key {
                ParamKey::Arm(id) => {
                    matches!(id.part(), ParamPart::Base { .. } | ParamPart::Tool { .. })
                }
                ParamKey::TargetTool { .. } => true,
                _ => false,
            },
            Rung::Model(ModelOption::Kinematic) => match key {
                ParamKey::Arm(id) => id.is_geometric(),
                ParamKey::TargetTool { .. } => true,
                _ => false,
            },
            Rung::Model(ModelOption::ElastoKinematic) => {
                matches!(key, ParamKey::Arm(_) | ParamKey::TargetTool { .. })
            }
            Rung::Model(_) => true,
        })
        .collect()
}

/// Which of `trials` (mean and standard error of each rung's leave-one-out
/// error, simplest first; `None` for a rung that failed) to keep: the first
/// whose mean is within one standard error of the best mean. `None` when
/// every rung failed.
pub fn pick(trials: &[Option<(f64, f64)>]) -> Option<usize> {
    let (best_mean, best_se) = trials
        .iter()
        .flatten()
        .filter(|(mean, _)| mean.is_finite())
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .copied()?;
    trials
        .iter()
        .position(|t| t.is_some_and(|(mean, _)| mean <= best_mean + best_se))
}

/// An option's fit with the placement it is held to.
#[derive(Clone, Debug)]
pub struct Ladder {
    /// The fit kept, reporting the option asked for as its option, the
    /// ladder in [`ChosenFit::model`].
    pub chosen: ChosenFit,
    /// The nominal arm placed, fitted to the same measurements
    /// (`calib::guard`'s bar); `None` when that fit failed.
    pub placement: Option<ChosenFit>,
}

/// Fits each rung of `option`'s ladder with `fit` (its rung and its
/// parameters of `kept`) and keeps one (module docs); the placement is
/// fitted too when the ladder has no such rung. An option of one rung
/// keeps that rung's fit, or its failure.
pub fn choose(
    option: ModelOption,
    kept: &[ParamKey],
    fit: impl Fn(Rung, &[ParamKey]) -> Result<ChosenFit, CalibError>,
) -> Result<Ladder, CalibError> {
    // A placement with nothing to place (the base kept, no tool point among
    // the parameters) is the nominal arm itself: no fit, no rung.
    let placed = !keys_for(Rung::Placement, kept).is_empty();
    let rungs: Vec<Rung> = ladder(option)
        .into_iter()
        .filter(|r| placed || *r != Rung::Placement)
        .collect();
    let fit_rung = |rung: Rung| fit(rung, &keys_for(rung, kept));
    if rungs.len() == 1 {
        return Ok(Ladder {
            chosen: fit(rungs[0], kept)?,
            placement: placed.then(|| fit_rung(Rung::Placement).ok()).flatten(),
        });
    }
    let mut fits: Vec<(Rung, Result<ChosenFit, CalibError>)> = Vec::new();
    for rung in rungs {
        // A rung that adds nothing to the one before (no spring the poses
        // show) is the same fit: the richer keeps its place on the ladder
        // only where it adds parameters of its own.
        let adds = fits.last().is_none_or(|(before, _)| {
            keys_for(rung, kept) != keys_for(*before, kept)
                || rung == Rung::Model(ModelOption::ElastoKinematicServo)
        });
        if adds {
            fits.push((rung, fit_rung(rung)));
        }
    }
    let samples = |f: &ChosenFit| f.identified.fit_residual.count.max(1) as f64;
    let summary: Vec<Option<(f64, f64)>> = fits
        .iter()
        .map(|(_, f)| {
            f.as_ref().ok().map(|f| {
                let d = &f.identified.diagnostics;
                (d.loo_mean_m, d.loo_sd_m / samples(f).sqrt())
            })
        })
        .collect();
    let trials = fits
        .iter()
        .zip(&summary)
        .map(|((rung, f), s)| ModelTrial {
            model: *rung,
            parameters: f.as_ref().map_or(0, |f| f.identified.estimates.len()),
            loo_mean_mm: s.map(|(mean, _)| mean * 1e3),
            loo_se_mm: s.map(|(_, se)| se * 1e3),
            failure: f.as_ref().err().map(|e| e.to_string()),
        })
        .collect();
    let placement = match fits.iter().find(|(rung, _)| *rung == Rung::Placement) {
        Some((_, f)) => f.as_ref().ok().cloned(),
        None if placed => fit_rung(Rung::Placement).ok(),
        None => None,
    };
    // Every rung failed: the option's own reason.
    let i = pick(&summary).unwrap_or(fits.len() - 1);
    let (chosen, fit) = fits.swap_remove(i);
    let mut fit = fit?;
    fit.identified.option = option;
    fit.model = Some(ModelChoice { chosen, trials });
    Ok(Ladder {
        chosen: fit,
        placement,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::key;

    #[test]
    fn the_simpler_model_is_kept_unless_the_richer_predicts_better() {
        // Kinematic 1.00 ± 0.05, elasto-kinematic 0.98: within one standard
        // error of the best, so the simpler one.
        assert_eq!(pick(&[Some((1.00, 0.05)), Some((0.98, 0.04))]), Some(0));
        // The richer one better by more than its standard error.
        assert_eq!(pick(&[Some((1.00, 0.05)), Some((0.50, 0.04))]), Some(1));
        // Three rungs: the middle one within reach of the best.
        assert_eq!(
            pick(&[Some((2.0, 0.1)), Some((0.62, 0.05)), Some((0.60, 0.03))]),
            Some(1)
        );
        // A failed or undetermined rung loses to any that fits.
        assert_eq!(pick(&[None, Some((3.0, 0.2))]), Some(1));
        assert_eq!(
            pick(&[Some((f64::INFINITY, f64::INFINITY)), Some((3.0, 0.2))]),
            Some(1)
        );
        assert_eq!(pick(&[None, None]), None);
    }

    #[test]
    fn each_rung_fits_its_effects_of_the_kept_parameters() {
        let kept: Vec<ParamKey> = [
            "k2",
            "base.x",
            "tool.z",
            "j2.beta",
            "j3.servo[2]",
            "j3.backlash",
        ]
        .iter()
        .map(|n| key(n))
        .chain([ParamKey::TargetTool { target: 1, axis: 0 }])
        .collect();
        let names = |m| {
            keys_for(m, &kept)
                .iter()
                .map(|k| k.name().into_owned())
                .collect::<Vec<_>>()
        };
        assert_eq!(names(Rung::Placement), ["base.x", "tool.z", "tool[1].x"]);
        assert_eq!(
            names(Rung::Model(ModelOption::Kinematic)),
            ["base.x", "tool.z", "j2.beta", "tool[1].x"]
        );
        assert_eq!(
            names(Rung::Model(ModelOption::ElastoKinematic)),
            ["k2", "base.x", "tool.z", "j2.beta", "tool[1].x"]
        );
        assert_eq!(
            keys_for(Rung::Model(ModelOption::ElastoKinematicServo), &kept),
            kept
        );
        assert_eq!(ladder(ModelOption::PaperElastoKinematic).len(), 1);
        assert_eq!(
            ladder(ModelOption::ElastoKinematicServo),
            [
                Rung::Placement,
                Rung::Model(ModelOption::Kinematic),
                Rung::Model(ModelOption::ElastoKinematic),
                Rung::Model(ModelOption::ElastoKinematicServo)
            ]
        );
        // The rung's name in the report: the placement's or the option's.
        assert_eq!(
            serde_json::to_string(&[Rung::Placement, Rung::Model(ModelOption::Kinematic)]).unwrap(),
            r#"["placement","kinematic"]"#
        );
    }
}
