//! One calibration run, as `lrmcal identify` asks for it: a [`Request`]
//! (the nominal arm, every measurement read, the options, how poses are
//! chosen and the arm placed) in, one [`Run`] out (the registration, each
//! option's result, the report, the calibration files). The command line
//! reads the files, makes one call and writes and prints what comes back.
//!
//! The steps, in order: the load to fit (the file's only one, or the one
//! asked for), each target seen in enough poses, registration of the arm in
//! the measurement frame on the first target's rows (or the arm file's base
//! kept), the measurements carried into the arm's frame and checked for
//! plausibility and against the candidates, the poses chosen, then per
//! option the candidates' analysis, the structure check and the fit
//! (`fit::pipeline`), and the fit refused when it leaves the arm worse
//! than it started (`fit::guard`). With several options, one the measurements cannot
//! determine is skipped with its reason and the others are still fitted.

use model::Arm;

use super::analysis::detmax::DetmaxOptions;
use super::analysis::identifiability::Structures;
use super::fit::checks::{check_in_candidates, check_measured, identification_load};
use super::fit::guard;
use super::fit::identify::IdentifyOptions;
use super::fit::model_choice;
use super::fit::pipeline::{
    CandidateBlocks, Choice, Inputs, OptionResult, RunSettings, calibrate_blocks,
};
use super::fit::registration::{
    Gravity, Registration, check_plausible_registered, check_registered_count, register,
};
use super::fit::tool_only::retaught;
use super::parameters::params::ParamKey;
use super::parameters::targets::Targets;
use super::progress::Progress;
use super::results::export::registered_calibration_file;
use super::results::report::{RegistrationReport, Report};
use super::{CalibError, ModelOption};
use lrmcal_core::dataset::{Measurement, Pose, loads_of, poses_under};
use lrmcal_core::io::calibration_file::CalibrationFile;

/// Which measured poses the fit uses.
#[derive(Clone, Debug, PartialEq)]
pub enum PoseChoice {
    /// `n` poses chosen by DETMAX (D-optimal for each option).
    Detmax {
        /// How many poses.
        n: usize,
        /// Random starts.
        starts: usize,
    },
    /// The poses of a list, named `file` in messages.
    Listed {
        /// Pose ids.
        ids: Vec<u32>,
        /// The list's file, for messages.
        file: String,
    },
    /// Every measured pose.
    All,
}

/// Where the arm stands in the measurement frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Placement {
    /// Found from the measurements ([`register`]).
    Register(Gravity),
    /// The arm file's base: the measurements are in its world frame.
    Keep(Gravity),
}

/// What to calibrate, from what.
#[derive(Clone, Debug)]
pub struct Request<'a> {
    /// The nominal arm, as its file describes it.
    pub nominal: &'a Arm<f64>,
    /// Where the nominal arm came from, for the report.
    pub arm_origin: String,
    /// Every measurement read, every target and load.
    pub measurements: &'a [Measurement],
    /// The measurement file, for messages and the report.
    pub measurements_file: String,
    /// The load to fit, kg; `None`: the file's only load.
    pub load_kg: Option<f64>,
    /// Candidate poses every measured pose must be one of, if given.
    pub candidates: Option<&'a [Pose]>,
    /// How the poses to fit are chosen.
    pub poses: PoseChoice,
    /// The model options, in order.
    pub options: Vec<ModelOption>,
    /// Where the arm stands.
    pub placement: Placement,
    /// How the fit runs.
    pub identify: IdentifyOptions,
}

/// Everything a run gives back.
#[derive(Debug)]
pub struct Run {
    /// Where the arm was found (or kept) in the measurement frame.
    pub registration: Registration,
    /// The load fitted, kg.
    pub load_kg: f64,
    /// Each option fitted, in the order asked.
    pub results: Vec<OptionResult>,
    /// Each option that could not be fitted (only when several were asked for), with why.
    pub skipped: Vec<(ModelOption, CalibError)>,
    /// What the measured poses leave undetermined of an option fitted as a
    /// ladder of models (held at nominal, the fit goes on), per option.
    pub notes: Vec<(ModelOption, String)>,
    /// The machine-readable report.
    pub report: Report,
    /// One calibration file per result, in the measurement frame.
    pub files: Vec<CalibrationFile>,
}

/// The measurements a fit works from: the loads measured, the one fitted,
/// the targets seen and the rows under that load.
struct FitLoad {
    loads: Vec<f64>,
    load_kg: f64,
    targets: Targets,
    under_load: Vec<Measurement>,
}

impl FitLoad {
    /// The load `requested` (the file's only one when `None`) of `all`,
    /// read from `file`, each target seen in enough poses under it.
    fn of(all: &[Measurement], requested: Option<f64>, file: &str) -> Result<Self, CalibError> {
        if all.is_empty() {
            return Err(CalibError::Empty {
                what: format!("identify from {file}"),
            });
        }
        let loads = loads_of(all);
        let load_kg = identification_load(&loads, requested, file)?;
        let targets = Targets::of(all);
        let under_load: Vec<_> = all
            .iter()
            .filter(|m| m.load_kg == load_kg)
            .copied()
            .collect();
        targets.check_poses(&under_load, file)?;
        Ok(Self {
            loads,
            load_kg,
            targets,
            under_load,
        })
    }
}

/// Re-teaches the tool points of `old` from `all` (read from `file`) under
/// the load `load_kg` (the file's only one when `None`), `old`'s arm held
/// fixed: after a tool change. The new file, and how many measurements it
/// was fitted to.
pub fn reteach(
    old: CalibrationFile,
    all: &[Measurement],
    load_kg: Option<f64>,
    file: &str,
    options: &IdentifyOptions,
) -> Result<(CalibrationFile, usize), CalibError> {
    let fit = FitLoad::of(all, load_kg, file)?;
    let count = fit.under_load.len();
    let cal = retaught(old, fit.targets, &fit.under_load, fit.load_kg, options)?;
    Ok((cal, count))
}

/// Runs the calibration `request` asks for; long steps report to `progress`.
pub fn calibrate(request: &Request, progress: &dyn Progress) -> Result<Run, CalibError> {
    let file = request.measurements_file.as_str();
    let all = request.measurements;
    let FitLoad {
        loads,
        load_kg: load,
        targets,
        ..
    } = FitLoad::of(all, request.load_kg, file)?;
    // The nominal arm knows the first target's tool point only: the others
    // may sit anywhere on the flange.
    let first: Vec<_> = all
        .iter()
        .filter(|m| targets.index(m.target) == Some(0))
        .copied()
        .collect();
    let registration = place(request, &first)?;
    // The fit runs in the arm file's world frame, where the base's angles
    // are small corrections; the files get the result in the measurement frame.
    let nominal = registration.arm_for_fit(request.nominal);
    let all = registration.to_arm_frame(all);
    check_plausible_registered(&nominal, &registration.to_arm_frame(&first), file)?;
    if let Some(candidates) = request.candidates {
        check_in_candidates(&all, candidates, file)?;
    }
    let measured = poses_under(&all, load);
    let choice = match &request.poses {
        PoseChoice::Detmax { n, starts } => Choice::Detmax(DetmaxOptions {
            n: *n,
            starts: *starts,
            ..Default::default()
        }),
        PoseChoice::Listed { ids, file: list } => {
            check_measured(ids, &measured, list, file, load)?;
            Choice::Given(ids.clone())
        }
        PoseChoice::All => Choice::Given(measured.iter().map(|p| p.id).collect()),
    };
    let settings = RunSettings {
        identify_load_kg: load,
        other_load_kg: loads.iter().copied().find(|l| *l != load),
        choice,
        identify: request.identify,
    };
    let registered = matches!(request.placement, Placement::Register(_));
    let inputs = Inputs::new(&nominal, &measured, &all);
    // Worked out once per option and spacing, for the candidates' analysis
    // and the check below alike.
    let structures = Structures::new(&inputs.nominal.arm, load);
    let mut results = Vec::new();
    let mut skipped = Vec::new();
    let mut notes = Vec::new();
    for &option in &request.options {
        let result = (|| {
            let blocks = CandidateBlocks::build_for(
                &inputs.nominal,
                option,
                &measured,
                &[load],
                settings.choice.poses(),
                &structures,
            )?;
            // The measured poses must identify what positions can reveal on
            // this arm at all. An option fitted as a ladder of models holds
            // an effect beyond the geometry they leave undetermined (a
            // spring, a knot) and lets the ladder judge the rest; the
            // geometry they must determine.
            if let (missing, Some(e)) = structures.missing(&blocks.identifiability)? {
                let beyond_geometry = missing.iter().all(|k| match k {
                    ParamKey::Arm(id) => !id.is_geometric(),
                    _ => true,
                });
                if model_choice::ladder(option).len() == 1 || !beyond_geometry {
                    return Err(e);
                }
                notes.push((option, e.to_string()));
            }
            if registered {
                let params = blocks.identifiability.kept.len();
                check_registered_count(settings.choice.poses(), params, option)?;
            }
            let result = calibrate_blocks(&inputs, blocks, &settings, progress)?;
            // No calibration worse than where the arm started reaches a file.
            guard::check(
                option,
                &inputs.nominal.arm,
                &result.identified,
                result.placement.as_ref(),
            )?;
            Ok(result)
        })();
        match result {
            Ok(r) => results.push(r),
            Err(e) if request.options.len() > 1 => skipped.push((option, e)),
            Err(e) => return Err(e),
        }
    }
    if results.is_empty() && !skipped.is_empty() {
        return Err(skipped.swap_remove(0).1);
    }
    let mut report = Report::new(
        request.arm_origin.clone(),
        measured.len(),
        load,
        serde_json::json!({ "source": file, "loads_kg": loads }),
        &results,
    );
    report.registration = registered.then(|| RegistrationReport::from(&registration));
    let files = results
        .iter()
        .map(|r| registered_calibration_file(&registration, registered, &nominal, r))
        .collect();
    Ok(Run {
        registration,
        load_kg: load,
        results,
        skipped,
        notes,
        report,
        files,
    })
}

/// Registers the arm on `first` (the first target's rows), or keeps the
/// file's base.
fn place(request: &Request, first: &[Measurement]) -> Result<Registration, CalibError> {
    let nominal = request.nominal;
    match request.placement {
        Placement::Keep(gravity) => {
            let g = match gravity {
                Gravity::Measured(g) => g,
                Gravity::LevelBase(_) => nominal.gravity_vector(),
            };
            Ok(Registration::identity(nominal, g))
        }
        Placement::Register(gravity) => register(nominal, first, gravity).map_err(|e| match e {
            CalibError::Registration { problem } => CalibError::Registration {
                problem: format!("{}: {problem}", request.measurements_file),
            },
            other => other,
        }),
    }
}
