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
//! rung within one standard error of the best one is kept (the usual
//! one-standard-error rule: a richer model must predict better by more
//! than the measurements can tell apart). The placement is the exception:
//! it is kept only where it predicts best. It is not a smaller model of the
//! arm but the drawing taken as exact, which no arm built is; and where the
//! one-standard-error rule kept it on real data (the TIAGo set's 5-fold
//! splits), the geometry fitted predicted the poses left out better in
//! most folds (docs/METHOD.md). The rungs are fitted to the same
//! measurements, so they are compared measurement by measurement: the
//! standard error is that of the mean difference of their leave-one-out
//! errors, which the poses' own spread (a hard pose is hard for every
//! model) does not blur. A rung whose fit fails, does not converge or
//! bends the geometry past any real arm's size (`calib::guard::beyond_size`)
//! loses to any that does not: the default falls back to a simpler model
//! rather than refusing. The calibration keeps the option asked for (its file,
//! its name on the board); what the ladder chose is reported beside it.
//!
//! The placement is fitted for every option, in or out of its ladder: it
//! is where the arm starts, the bar `calib::guard` holds every calibration
//! to. The paper's own sets (`paper-kinematic`, `paper-elasto-kinematic`)
//! and the options of one effect (`kinematic`, `elastic`) are otherwise
//! fitted as they are.

use crate::calib::fit::choice::{ChosenFit, ModelChoice, ModelTrial, Rung};
use crate::calib::parameters::params::ParamKey;
use crate::calib::{CalibError, ModelOption};
use model::params::ParamPart;
use rayon::prelude::*;

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
/// compliances too for elasto-kinematic; all of them for ours. A camera's
/// lens, when refined, is the instrument's: every rung fits it.
pub fn keys_for(rung: Rung, kept: &[ParamKey]) -> Vec<ParamKey> {
    kept.iter()
        .copied()
        .filter(|key| match rung {
            Rung::Placement => match key {
                ParamKey::Arm(id) => {
                    matches!(id.part(), ParamPart::Base { .. } | ParamPart::Tool { .. })
                }
                ParamKey::TargetTool { .. } | ParamKey::Lens { .. } => true,
                _ => false,
            },
            Rung::Model(ModelOption::Kinematic) => match key {
                ParamKey::Arm(id) => id.is_geometric(),
                ParamKey::TargetTool { .. } | ParamKey::Lens { .. } => true,
                _ => false,
            },
            Rung::Model(ModelOption::ElastoKinematic) => matches!(
                key,
                ParamKey::Arm(_) | ParamKey::TargetTool { .. } | ParamKey::Lens { .. }
            ),
            Rung::Model(_) => true,
        })
        .collect()
}

/// The mean of `a − b` and its standard error, measurement by measurement.
pub fn paired(a: &[f64], b: &[f64]) -> (f64, f64) {
    let n = a.len().min(b.len()).max(1) as f64;
    let d: Vec<f64> = a.iter().zip(b).map(|(a, b)| a - b).collect();
    let mean = d.iter().sum::<f64>() / n;
    let variance = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (variance / n).sqrt())
}

/// Which of `trials` (each rung's leave-one-out errors, measurement by
/// measurement, simplest first; `None` for a rung that failed) to keep,
/// and each rung's standard error against the best: the best rung when it
/// is one of the first `only_best` (the placement: kept only where it
/// predicts best), else the first rung from there whose mean difference
/// from the best rung's errors is within its standard error. `None` when
/// every rung failed.
pub fn pick(trials: &[Option<Vec<f64>>], only_best: usize) -> (Option<usize>, Vec<Option<f64>>) {
    let mean = |e: &Vec<f64>| e.iter().sum::<f64>() / e.len().max(1) as f64;
    let best = trials
        .iter()
        .enumerate()
        .filter_map(|(i, t)| t.as_ref().map(|e| (i, mean(e))))
        .filter(|(_, m)| m.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1));
    let Some((best, _)) = best else {
        return (None, vec![None; trials.len()]);
    };
    let best_errors = trials[best].as_ref().expect("the best rung has errors");
    let against: Vec<Option<(f64, f64)>> = trials
        .iter()
        .map(|t| {
            t.as_ref()
                .filter(|e| mean(e).is_finite())
                .map(|e| paired(e, best_errors))
        })
        .collect();
    let chosen = if best < only_best {
        Some(best)
    } else {
        (only_best..against.len())
            .find(|&i| against[i].is_some_and(|(difference, se)| difference <= se))
    };
    (
        chosen,
        against.iter().map(|d| d.map(|(_, se)| se)).collect(),
    )
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
/// parameters of `kept`), the rungs side by side, and keeps one (module
/// docs); the placement is fitted too when the ladder has no such rung. A
/// rung of which `flaw` says something (the geometry bent past a real
/// arm's size) is no candidate, like one that did not converge. An option
/// of one rung keeps that rung's fit, or its failure.
pub fn choose(
    option: ModelOption,
    kept: &[ParamKey],
    fit: impl Fn(Rung, &[ParamKey]) -> Result<ChosenFit, CalibError> + Sync,
    flaw: impl Fn(&ChosenFit) -> Option<String>,
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
    // A rung that adds nothing to the one before (no spring the poses
    // show) is the same fit: the richer keeps its place on the ladder only
    // where it adds parameters of its own.
    let mut fitted: Vec<Rung> = Vec::new();
    for rung in rungs {
        let adds = fitted.last().is_none_or(|before| {
            keys_for(rung, kept) != keys_for(*before, kept)
                || rung == Rung::Model(ModelOption::ElastoKinematicServo)
        });
        if adds {
            fitted.push(rung);
        }
    }
    let mut fits: Vec<(Rung, Result<ChosenFit, CalibError>)> = fitted
        .into_par_iter()
        .map(|rung| (rung, fit_rung(rung)))
        .collect();
    // A rung that did not converge is no candidate: its error says nothing;
    // nor is one with a flaw.
    let flaws: Vec<Option<String>> = fits
        .iter()
        .map(|(_, f)| f.as_ref().ok().and_then(&flaw))
        .collect();
    let errors: Vec<Option<Vec<f64>>> = fits
        .iter()
        .zip(&flaws)
        .map(|((_, f), flaw)| {
            f.as_ref()
                .ok()
                .filter(|f| f.identified.diagnostics.converged && flaw.is_none())
                .map(|f| f.identified.diagnostics.loo_errors_m.clone())
        })
        .collect();
    let placements = usize::from(fits.first().is_some_and(|(r, _)| *r == Rung::Placement));
    let (picked, se) = pick(&errors, placements);
    let trials = fits
        .iter()
        .zip(&errors)
        .zip(&se)
        .zip(flaws)
        .map(|((((rung, f), e), se), flaw)| ModelTrial {
            model: *rung,
            parameters: f.as_ref().map_or(0, |f| f.identified.estimates.len()),
            loo_mean_mm: e
                .as_ref()
                .map(|e| 1e3 * e.iter().sum::<f64>() / e.len().max(1) as f64),
            loo_se_mm: se.map(|se| se * 1e3),
            failure: match f {
                Err(e) => Some(e.to_string()),
                Ok(f) if !f.identified.diagnostics.converged => Some(format!(
                    "did not converge ({})",
                    f.identified.diagnostics.termination
                )),
                Ok(_) => flaw,
            },
        })
        .collect();
    let placement = match fits.iter().find(|(rung, _)| *rung == Rung::Placement) {
        Some((_, f)) => f.as_ref().ok().cloned(),
        None if placed => fit_rung(Rung::Placement).ok(),
        None => None,
    };
    // Every rung failed: the option's own reason.
    let i = picked.unwrap_or(fits.len() - 1);
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
        let chosen = |t: &[Option<Vec<f64>>]| pick(t, 0).0;
        // The richer one 0.02 lower on average, but by +0.2 on one pose and
        // -0.2 on the next: no better than the noise, so the simpler one.
        let simple = vec![1.0; 10];
        let wobbly: Vec<f64> = (0..10)
            .map(|k| if k % 2 == 0 { 1.18 } else { 0.78 })
            .collect();
        assert_eq!(chosen(&[Some(simple.clone()), Some(wobbly)]), Some(0));
        // The richer one lower on every pose, if only by a little: better.
        let steady: Vec<f64> = (0..10).map(|k| 0.97 - 0.001 * k as f64).collect();
        assert_eq!(chosen(&[Some(simple.clone()), Some(steady)]), Some(1));
        // Three rungs: the middle one as good as the best.
        let best = vec![0.5; 10];
        assert_eq!(
            chosen(&[Some(vec![2.0; 10]), Some(best.clone()), Some(best.clone())]),
            Some(1)
        );
        // A failed or undetermined rung loses to any that fits.
        assert_eq!(chosen(&[None, Some(vec![3.0; 4])]), Some(1));
        assert_eq!(
            chosen(&[Some(vec![f64::INFINITY, 1.0]), Some(vec![3.0, 3.0])]),
            Some(1)
        );
        assert_eq!(chosen(&[None, None]), None);
        // The placement (the first rung here) is kept only where it is the
        // best: the wobbly geometry, within the noise, wins over it, and a
        // spring rung as good as the geometry does not.
        let placed = |t: &[Option<Vec<f64>>]| pick(t, 1).0;
        let wobbly: Vec<f64> = (0..10)
            .map(|k| if k % 2 == 0 { 1.18 } else { 0.78 })
            .collect();
        assert_eq!(
            placed(&[Some(simple.clone()), Some(wobbly.clone())]),
            Some(1)
        );
        assert_eq!(
            placed(&[Some(simple.clone()), Some(wobbly.clone()), Some(wobbly)]),
            Some(1)
        );
        assert_eq!(
            placed(&[Some(vec![0.9; 10]), Some(simple.clone())]),
            Some(0)
        );
        assert_eq!(placed(&[Some(simple.clone()), None]), Some(0));
        // The paired difference and its standard error.
        let (d, se) = paired(&[2.0, 4.0], &[1.0, 1.0]);
        assert_eq!((d, se), (2.0, 1.0));
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

    #[test]
    fn a_rung_with_a_flaw_gives_way_to_the_next_simpler() {
        use crate::calib::testing::fitted;
        let kept: Vec<ParamKey> = ["k2", "base.x", "j2.a"].iter().map(|n| key(n)).collect();
        // Each richer rung predicts better; ours bends its geometry.
        let fit = |rung: Rung, _: &[ParamKey]| {
            let loo = match rung {
                Rung::Placement => 4e-3,
                Rung::Model(ModelOption::Kinematic) => 3e-3,
                Rung::Model(ModelOption::ElastoKinematic) => 2e-3,
                Rung::Model(_) => 1e-3,
            };
            Ok(ChosenFit {
                identified: fitted(true, 5e-3, loo / 2.0, loo, vec![]),
                knots: None,
                model: None,
            })
        };
        let bent = |f: &ChosenFit| {
            (f.identified.diagnostics.loo_mean_m < 1.5e-3).then(|| "bent".to_string())
        };
        let ladder = choose(ModelOption::ElastoKinematicServo, &kept, fit, bent).unwrap();
        let choice = ladder.chosen.model.unwrap();
        assert_eq!(choice.chosen, Rung::Model(ModelOption::ElastoKinematic));
        let ours = choice.trials.last().unwrap();
        assert_eq!(ours.failure.as_deref(), Some("bent"));
        assert_eq!(ours.loo_mean_mm, None);
        // Without the flaw, ours.
        let ladder = choose(ModelOption::ElastoKinematicServo, &kept, fit, |_| None).unwrap();
        assert_eq!(
            ladder.chosen.model.unwrap().chosen,
            Rung::Model(ModelOption::ElastoKinematicServo)
        );
    }
}
