//! Experiments on top of a calibration run: how DETMAX compares with random
//! selections of the same size, how O1 and the error fall with the number
//! of poses, what a few gross measurement errors among the fitted poses
//! cost a fit, and how the calibration does on the grid and off it.

use nalgebra::Vector3;

use crate::calib::analysis::detmax::{DetmaxOptions, detmax, random_design};
use crate::calib::fit::pipeline::{CandidateBlocks, Choice, Inputs, OptionResult, RunSettings};
use crate::calib::fit::validate::validate;
use crate::calib::progress::{Progress, Silent, par_map};
use crate::calib::results::figures::{ErrorPoint, GridErrors, O1Point, RandomBaseline};
use crate::calib::run::{Calibration, Request};
use crate::calib::{CalibError, ModelOption};
use lrmcal_core::dataset::Measurement;

/// Random set `s` of a comparison is drawn with seed `RANDOM_SEED + s`.
pub const RANDOM_SEED: u64 = 1000;

/// Selection sizes of the O1 sweep.
pub const O1_SIZES: [usize; 9] = [10, 15, 20, 30, 40, 50, 60, 80, 100];

/// Selection sizes of the error sweep: from fewer poses than any elastic
/// model needs to the demo's 60.
pub const ERROR_SIZES: [usize; 8] = [10, 15, 20, 25, 30, 40, 50, 60];

/// DETMAX random starts per size of the error sweep (the runs themselves use more).
pub const ERROR_SWEEP_STARTS: usize = 4;

/// The middle value of `v` (the upper one of the two middle values when
/// their number is even); NaN when empty.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// O1 of `sets` random selections of `n` of the candidates analysed in
/// `blocks`, drawn as [`random_baseline`] draws them.
pub fn random_o1(blocks: &CandidateBlocks, n: usize, sets: usize) -> Vec<f64> {
    (0..sets)
        .map(|s| {
            blocks
                .observability(&random_design(
                    blocks.blocks.len(),
                    n,
                    RANDOM_SEED + s as u64,
                ))
                .o1
        })
        .collect()
}

/// Calibrates `result`'s option on `calibration` from `sets` random
/// selections of as many candidates as it selected (every other setting as
/// `settings` say, no cross-load check), validates each on the rest, and
/// compares O1 and the mean validation error with `result`'s own. One
/// progress unit per set.
pub fn random_baseline(
    calibration: &Calibration,
    result: &OptionResult,
    sets: usize,
    settings: &RunSettings,
    progress: &dyn Progress,
) -> Result<RandomBaseline, CalibError> {
    let candidates = &calibration.inputs().candidates;
    let n = result.selection.poses.len();
    progress.begin("random selections: identify + validate", sets as u64);
    let mut means = Vec::new();
    for s in 0..sets {
        let chosen = random_design(candidates.len(), n, RANDOM_SEED + s as u64);
        let random = RunSettings {
            identify_load_kg: result.identify_load_kg,
            other_load_kg: None,
            choice: Choice::Given(chosen.iter().map(|&c| candidates[c].id).collect()),
            ..settings.clone()
        };
        // A random set may be rank deficient, or its fit refused: that is a
        // loss for random selection.
        let mean = match calibration.option(result.option(), &random, &Silent) {
            Ok(r) => r.held_out()?.after.mean_m,
            Err(_) => f64::INFINITY,
        };
        means.push(mean);
        progress.advance(1);
    }
    progress.end();
    Ok(RandomBaseline {
        option: result.option(),
        sets,
        poses: n,
        detmax_o1: result.selection.observability.o1,
        random_o1_median: median(random_o1(&result.selection.candidates, n, sets)),
        detmax_mean_m: result.held_out()?.after.mean_m,
        random_mean_median_m: median(means),
    })
}

/// One fit on clean measurements and on the same measurements with a few of
/// the fitted poses displaced (gross errors, as a tracker that jumped).
#[derive(Clone, Debug, PartialEq)]
pub struct OutlierTrial {
    /// The fitted poses whose measurement was displaced.
    pub displaced: Vec<u32>,
    /// Mean held-out error of the fit on the clean measurements, m.
    pub clean_mean_m: f64,
    /// Mean held-out error of the fit on the displaced measurements, m
    /// (held-out measurements are clean in both).
    pub contaminated_mean_m: f64,
    /// The fitted poses the contaminated fit named as outliers.
    pub named: Vec<u32>,
}

/// Calibrates `option` from `request`'s measurements as `settings` say,
/// then again on the same poses with the fitted measurements of `count` of
/// them (spread over the selection) moved by `offset_m` in the measurement
/// frame (as a tracker that jumped), and compares the held-out errors.
pub fn outlier_trial(
    request: &Request,
    option: ModelOption,
    settings: &RunSettings,
    count: usize,
    offset_m: Vector3<f64>,
) -> Result<OutlierTrial, CalibError> {
    let calibration = Calibration::open(request)?;
    let clean = calibration.option(option, settings, &Silent)?;
    let chosen = clean.pose_ids();
    let stride = (chosen.len() / count.max(1)).max(1);
    let displaced: Vec<u32> = chosen.iter().step_by(stride).take(count).copied().collect();
    let load = settings.identify_load_kg;
    let moved: Vec<_> = request
        .measurements
        .iter()
        .filter(|m| m.load_kg == load)
        .map(|m| {
            let mut m = *m;
            if displaced.contains(&m.pose.id) {
                m.position += offset_m;
            }
            m
        })
        .collect();
    let dirty = Calibration::open(&Request {
        measurements: &moved,
        load_kg: Some(load),
        ..request.clone()
    })?;
    let dirty = dirty.option(
        option,
        &RunSettings {
            choice: Choice::Given(chosen),
            other_load_kg: None,
            ..settings.clone()
        },
        &Silent,
    )?;
    Ok(OutlierTrial {
        clean_mean_m: clean.held_out()?.after.mean_m,
        contaminated_mean_m: dirty.held_out()?.after.mean_m,
        named: dirty.identified.outliers.iter().map(|o| o.pose).collect(),
        displaced,
    })
}

/// O1 of DETMAX selections (two starts each) of each of `sizes` poses, per
/// option of `results`, over the candidates they analysed; sizes that cannot
/// determine the option's parameters, or exceed the candidates, are skipped.
/// One progress unit per option and size.
pub fn o1_vs_poses(
    results: &[OptionResult],
    sizes: &[usize],
    progress: &dyn Progress,
) -> Result<Vec<O1Point>, CalibError> {
    progress.begin(
        "O1 against the number of poses",
        (results.len() * sizes.len()) as u64,
    );
    let mut out = Vec::new();
    for r in results {
        let blocks = &r.selection.candidates;
        for &n in sizes {
            progress.advance(1);
            if blocks.fewest_poses() > n || n > blocks.blocks.len() {
                continue;
            }
            let d = detmax(
                &blocks.blocks,
                &DetmaxOptions {
                    n,
                    starts: 2,
                    ..Default::default()
                },
                &Silent,
            )?;
            out.push(O1Point {
                option: r.option(),
                poses: n,
                o1: blocks.observability(&d.chosen).o1,
            });
        }
    }
    progress.end();
    Ok(out)
}

/// The error of each of `results`' options calibrated on `calibration`
/// from DETMAX selections of each of `sizes` poses as `settings` say (every
/// other setting as in the runs, [`ERROR_SWEEP_STARTS`] starts, no
/// cross-load check), validated as [`grid_and_off_grid`] does. A size a run
/// already selected is that run; the others reuse its candidates' analysis,
/// or one with a coarser knot grid when the poses cannot carry its
/// parameters; a size too small even for the coarsest has no calibration
/// (`CandidateBlocks::selects_for`). The sizes run on every core; one
/// progress unit per option and size.
pub fn error_vs_poses(
    calibration: &Calibration,
    results: &[&OptionResult],
    settings: &RunSettings,
    sizes: &[usize],
    grid_size: usize,
    off_grid: &[Measurement],
    progress: &dyn Progress,
) -> Result<Vec<ErrorPoint>, CalibError> {
    let tasks: Vec<(&OptionResult, usize)> = results
        .iter()
        .flat_map(|r| sizes.iter().map(move |&n| (*r, n)))
        .collect();
    progress.begin("error against the number of poses", tasks.len() as u64);
    let points = par_map(
        &tasks,
        |&(r, n)| {
            let option = r.option();
            let point = |run: Result<OptionResult, CalibError>| {
                let errors = run.and_then(|run| {
                    let errors =
                        grid_and_off_grid(calibration.inputs(), &run, grid_size, off_grid)?;
                    Ok((run.knots.map(|k| k.chosen), errors))
                });
                match errors {
                    Ok((knots, errors)) => ErrorPoint {
                        option,
                        poses: n,
                        knots,
                        errors: Some(errors),
                        failure: None,
                    },
                    Err(e) => ErrorPoint {
                        option,
                        poses: n,
                        knots: None,
                        errors: None,
                        failure: Some(e.to_string()),
                    },
                }
            };
            if r.selection.poses.len() == n {
                return point(Ok(r.clone()));
            }
            let run_settings = RunSettings {
                choice: Choice::Detmax(DetmaxOptions {
                    n,
                    starts: ERROR_SWEEP_STARTS,
                    ..Default::default()
                }),
                other_load_kg: None,
                ..settings.clone()
            };
            point(calibration.option(option, &run_settings, &Silent))
        },
        progress,
    );
    progress.end();
    points.ok_or_else(|| CalibError::Empty {
        what: "calibrate from fewer poses: a run failed".into(),
    })
}

/// `result`'s calibration validated on its held-out candidates whose ids are
/// below `grid_size` (the grid's; random candidates come after) and on the
/// measurements `off_grid`.
pub fn grid_and_off_grid(
    inputs: &Inputs,
    result: &OptionResult,
    grid_size: usize,
    off_grid: &[Measurement],
) -> Result<GridErrors, CalibError> {
    let grid_ids = inputs
        .held_out(&result.pose_ids())
        .into_iter()
        .filter(|&id| (id as usize) < grid_size);
    let grid = inputs.measurements.of(grid_ids, result.identify_load_kg);
    Ok(GridErrors {
        option: result.option(),
        grid: validate(&inputs.nominal, &result.identified.rig, &grid)?.after,
        off_grid: validate(&inputs.nominal, &result.identified.rig, off_grid)?.after,
    })
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;
    use crate::calib::testing::{calibrate_in_arm_frame, elastic_run, elastic_settings};

    /// Counts what the engine reports.
    #[derive(Default)]
    struct Count {
        steps: Cell<usize>,
        announced: Cell<u64>,
        done: Cell<u64>,
        ended: Cell<usize>,
    }

    impl Progress for Count {
        fn begin(&self, _label: &str, len: u64) {
            self.steps.set(self.steps.get() + 1);
            self.announced.set(self.announced.get() + len);
        }
        fn advance(&self, units: u64) {
            self.done.set(self.done.get() + units);
        }
        fn end(&self) {
            self.ended.set(self.ended.get() + 1);
        }
    }

    #[test]
    fn median_is_the_upper_middle_value() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 3.0);
        assert!(median(Vec::new()).is_nan());
    }

    /// Sizes that cannot determine the parameters or exceed the candidates
    /// are skipped; every size is reported as progress.
    #[test]
    fn o1_sweep_covers_the_feasible_sizes() {
        let (nominal, _, all) = elastic_run();
        let r = calibrate_in_arm_frame(&nominal, &all, ModelOption::Elastic, &elastic_settings())
            .unwrap();
        // Two poses give 6 coordinates, too few for the kept compliances and a margin of 3.
        assert!(r.selection.candidates.identifiability.kept.len() > 3);
        let count = Count::default();
        let points = o1_vs_poses(std::slice::from_ref(&r), &[2, 5, 10, 40], &count).unwrap();
        let sizes: Vec<usize> = points.iter().map(|p| p.poses).collect();
        assert_eq!(sizes, [5, 10]);
        assert!(
            points
                .iter()
                .all(|p| p.option == ModelOption::Elastic && p.o1 > 0.0)
        );
        assert_eq!(
            (
                count.steps.get(),
                count.announced.get(),
                count.done.get(),
                count.ended.get()
            ),
            (1, 4, 4, 1)
        );
    }

    /// Each option and size gets a point: the run's own size is the run,
    /// another size a calibration of its own, a size too small for the
    /// parameters a failure that says so; every one is reported as progress.
    #[test]
    fn error_sweep_calibrates_each_size_or_says_why_not() {
        let (nominal, _, all) = elastic_run();
        let calibration = Calibration::open(&Request::new(&nominal, &all)).unwrap();
        let settings = elastic_settings();
        let r = calibration
            .option(ModelOption::Elastic, &settings, &Silent)
            .unwrap();
        let count = Count::default();
        // No candidate is off the grid here: the off-grid set is some of the measurements.
        let points = error_vs_poses(
            &calibration,
            &[&r],
            &settings,
            &[1, 6, 10],
            usize::MAX,
            &all[..5],
            &count,
        )
        .unwrap();
        let sizes: Vec<usize> = points.iter().map(|p| p.poses).collect();
        assert_eq!(sizes, [1, 6, 10]);
        let too_few = &points[0];
        assert!(
            too_few.errors.is_none() && too_few.knots.is_none(),
            "{too_few:?}"
        );
        assert!(
            too_few
                .failure
                .as_ref()
                .is_some_and(|f| f.contains("1 poses")),
            "{too_few:?}"
        );
        for p in &points[1..] {
            let e = p.errors.as_ref().expect("calibrated");
            // Exact data: every calibration that can be made predicts exactly.
            assert!(e.grid.mean_m < 1e-6 && e.off_grid.mean_m < 1e-6, "{p:?}");
            assert_eq!((p.option, p.failure.as_ref()), (ModelOption::Elastic, None));
        }
        // The run's own size is the run itself.
        assert_eq!(
            points[2].errors.as_ref().unwrap().grid,
            grid_and_off_grid(calibration.inputs(), &r, usize::MAX, &all[..5])
                .unwrap()
                .grid
        );
        assert_eq!(
            (count.steps.get(), count.announced.get(), count.done.get()),
            (1, 3, 3)
        );
    }

    /// On exact data any full-rank random set identifies the arm exactly, and
    /// DETMAX's O1 is at least the random sets' median.
    #[test]
    fn random_baseline_compares_like_with_like() {
        let (nominal, _, all) = elastic_run();
        let calibration = Calibration::open(&Request::new(&nominal, &all)).unwrap();
        let settings = elastic_settings();
        let r = calibration
            .option(ModelOption::Elastic, &settings, &Silent)
            .unwrap();
        let count = Count::default();
        let b = random_baseline(&calibration, &r, 3, &settings, &count).unwrap();
        assert_eq!((b.option, b.sets, b.poses), (ModelOption::Elastic, 3, 10));
        assert_eq!(b.detmax_o1, r.selection.observability.o1);
        assert_eq!(
            b.random_o1_median,
            median(random_o1(&r.selection.candidates, 10, 3))
        );
        assert!(b.detmax_o1 >= b.random_o1_median, "{b:?}");
        assert!(b.random_mean_median_m < 1e-6, "{b:?}");
        assert_eq!((count.announced.get(), count.done.get()), (3, 3));
    }
}
