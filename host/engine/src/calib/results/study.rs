//! The study `lrmcal demo` makes of one measured arm: every model option
//! calibrated from the same candidates, the cross-load check the other way
//! round, each calibration on the grid and off it, and the experiments
//! (DETMAX against random sets, O1 and the error against the number of
//! poses), in one report.

use crate::calib::fit::pipeline::{OptionResult, RunSettings};
use crate::calib::parameters::option::DEFAULT;
use crate::calib::progress::Progress;
use crate::calib::results::experiments::{
    ERROR_SIZES, O1_SIZES, error_vs_poses, grid_and_off_grid, o1_vs_poses, random_baseline,
};
use crate::calib::results::figures::GridErrors;
use crate::calib::results::report::Report;
use crate::calib::run::Calibration;
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
    /// Every option's run, in [`ModelOption::PAPER_STUDY`] order, but
    /// those refused.
    pub results: Vec<OptionResult>,
    /// The options whose fit was refused (it would leave the arm worse,
    /// or bend the geometry out of its physical range), with why: a user
    /// asking for them gets no calibration either.
    pub refused: Vec<(ModelOption, CalibError)>,
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

/// Studies the arm measured in the calibration `calibration` as `settings` say: every option
/// calibrated and validated on its held-out candidates (the grid's are those
/// with ids below `grid_size`) and on `off_grid`, ours again fitted under
/// the other load, then the experiments. The report names the arm by `arm`
/// and says how the measurements were made with `measurements`.
pub fn study(
    calibration: &Calibration,
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
    let mut results = Vec::new();
    let mut refused = Vec::new();
    for option in ModelOption::PAPER_STUDY {
        match calibration.option(option, run, progress) {
            Ok(r) => {
                r.held_out()?;
                results.push(r);
            }
            // The default is the study's subject: it must be made.
            Err(e @ CalibError::Refused { .. }) if option != DEFAULT => refused.push((option, e)),
            Err(e) => return Err(e),
        }
    }
    // The other direction of the cross-load check: fit under the other load,
    // validate under the first.
    let reverse = calibration.option(
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
        .map(|r| grid_and_off_grid(calibration.inputs(), r, grid_size, off_grid))
        .collect::<Result<Vec<GridErrors>, CalibError>>()?;
    let mut report = Report::new(
        arm,
        calibration.inputs().candidates.len(),
        run.identify_load_kg,
        measurements,
        results.iter().chain([&reverse]),
    );
    // The paper's comparison, on its model: a random set cannot determine
    // ours at all (its fits fail after long searches).
    let paper = run_of(&results, ModelOption::PaperElastoKinematic).ok();
    if let (Some(paper), true) = (paper, settings.compare_random > 0) {
        report.random_baseline = Some(random_baseline(
            calibration,
            paper,
            settings.compare_random,
            run,
            progress,
        )?);
    }
    report.o1_vs_poses = o1_vs_poses(&results, &O1_SIZES, progress)?;
    if settings.error_sweep {
        let swept: Vec<&OptionResult> = [paper, Some(run_of(&results, DEFAULT)?)]
            .into_iter()
            .flatten()
            .collect();
        report.error_vs_poses = error_vs_poses(
            calibration,
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
        refused,
        reverse,
        grid_errors,
        report,
    })
}
