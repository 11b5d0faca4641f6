//! The study `lrmcal demo` makes of one measured arm: every model option
//! calibrated from the same candidates, the cross-load check the other way
//! round, each calibration on the grid and off it, and the experiments
//! (DETMAX against random sets, O1 and the error against the number of
//! poses), in one report.

use crate::calib::fit::pipeline::{Inputs, OptionResult, RunSettings, calibrate_option};
use crate::calib::parameters::option::DEFAULT;
use crate::calib::progress::Progress;
use crate::calib::results::experiments::{
    ERROR_SIZES, GridErrors, O1_SIZES, error_vs_poses, grid_and_off_grid, o1_vs_poses,
    random_baseline,
};
use crate::calib::results::report::Report;
use crate::calib::{CalibError, ModelOption};
use lrmcal_core::dataset::Measurement;

/// What the study runs besides the calibrations.
#[derive(Clone, Debug, PartialEq)]
pub struct StudySettings {
    /// How every option is calibrated (its cross-load load is the one the
    /// reverse check fits with).
    pub run: RunSettings,
    /// Random selections to compare DETMAX with, on the paper's model; 0 for none.
    pub compare_random: usize,
    /// Whether to calibrate the paper's model and ours again from
    /// [`ERROR_SIZES`] poses.
    pub error_sweep: bool,
}

/// Everything the study learnt.
#[derive(Debug)]
pub struct Study {
    /// Every option's run, in [`ModelOption::ALL`] order.
    pub results: Vec<OptionResult>,
    /// Ours fitted under the other load and validated under the first.
    pub reverse: OptionResult,
    /// Each option's error on the held-out grid poses and off the grid.
    pub grid_errors: Vec<GridErrors>,
    /// The report: the runs (the reverse one last) and the experiments.
    pub report: Report,
}

impl Study {
    /// The run of `option`.
    pub fn result(&self, option: ModelOption) -> Result<&OptionResult, CalibError> {
        run_of(&self.results, option)
    }
}

/// The run of `option` among `results`.
fn run_of(results: &[OptionResult], option: ModelOption) -> Result<&OptionResult, CalibError> {
    results
        .iter()
        .find(|r| r.option() == option)
        .ok_or_else(|| CalibError::Empty {
            what: format!("run the {option} option"),
        })
}

/// Studies the arm measured in `inputs` as `settings` say: every option
/// calibrated and validated on its held-out candidates (the grid's are those
/// with ids below `grid_size`) and on `off_grid`, ours again fitted under
/// the other load, then the experiments. The report names the arm by `arm`
/// and says how the measurements were made with `measurements`.
pub fn study(
    inputs: &Inputs,
    grid_size: usize,
    off_grid: &[Measurement],
    settings: &StudySettings,
    (arm, measurements): (String, serde_json::Value),
    progress: &dyn Progress,
) -> Result<Study, CalibError> {
    let run = &settings.run;
    let Some(other_load_kg) = run.other_load_kg else {
        return Err(CalibError::Empty {
            what: "check across loads: the study needs measurements under two loads".into(),
        });
    };
    let results = ModelOption::PAPER_STUDY
        .iter()
        .map(|&option| {
            let r = calibrate_option(inputs, option, run, progress)?;
            r.held_out()?;
            Ok(r)
        })
        .collect::<Result<Vec<OptionResult>, CalibError>>()?;
    // The other direction of the cross-load check: fit under the other load,
    // validate under the first.
    let reverse = calibrate_option(
        inputs,
        DEFAULT,
        &RunSettings {
            identify_load_kg: other_load_kg,
            other_load_kg: Some(run.identify_load_kg),
            ..run.clone()
        },
        progress,
    )?;
    let grid_errors = results
        .iter()
        .map(|r| grid_and_off_grid(inputs, r, grid_size, off_grid))
        .collect::<Result<Vec<GridErrors>, CalibError>>()?;
    let mut report = Report::new(
        arm,
        inputs.candidates.len(),
        run.identify_load_kg,
        measurements,
        results.iter().chain([&reverse]),
    );
    // The paper's comparison, on its model: a random set cannot determine
    // ours at all (its fits fail after long searches).
    let paper = run_of(&results, ModelOption::PaperElastoKinematic)?;
    if settings.compare_random > 0 {
        report.random_baseline = Some(random_baseline(
            inputs,
            paper,
            settings.compare_random,
            &run.identify,
            progress,
        )?);
    }
    report.o1_vs_poses = o1_vs_poses(&results, &O1_SIZES, progress)?;
    if settings.error_sweep {
        let swept = [paper, run_of(&results, DEFAULT)?];
        report.error_vs_poses = error_vs_poses(
            inputs,
            &swept,
            run,
            &ERROR_SIZES,
            grid_size,
            off_grid,
            progress,
        )?;
    }
    Ok(Study {
        results,
        reverse,
        grid_errors,
        report,
    })
}
