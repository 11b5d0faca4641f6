//! The one calibration run of the project: a [`Request`] (the nominal arm,
//! every measurement read, the options, how poses are chosen and the arm
//! placed) in, one [`Run`] out (the registration, each option's result, the
//! report, the calibration files). `lrmcal identify` makes one call
//! ([`calibrate`]); the demo's study and its experiments open one
//! [`Calibration`] and fit options on it again (other poses, the other
//! load); `lrmcal select` plans one before anything is measured. No other
//! path assembles a fit, so what the demo reports is what a user gets.
//!
//! The steps, in order: the load to fit (the file's only one, or the one
//! asked for), each target seen in enough poses, registration of the arm in
//! the measurement frame on the first target's rows (or the arm file's base
//! kept), the measurements carried into the arm's frame and checked for
//! plausibility and against the candidates, the poses chosen, then per
//! option the candidates' analysis (built once per option, load and knot
//! spacing and reused by every later fit), the structure check and the fit
//! (`fit::pipeline`), and the fit refused when it leaves the arm worse than
//! it started (`fit::guard`). With several options, one the measurements
//! cannot determine is skipped with its reason and the others are still
//! fitted.

use std::sync::{Arc, Mutex, PoisonError};

use model::Arm;
use nalgebra::{Point3, Vector3};

use super::analysis::detmax::DetmaxOptions;
use super::analysis::identifiability::Structures;
use super::fit::checks::{check_in_candidates, check_measured, identification_load};
use super::fit::guard;
use super::fit::identify::IdentifyOptions;
use super::fit::model_choice;
use super::fit::pipeline::{
    CandidateBlocks, Choice, Inputs, OptionResult, RunSettings, Selection, calibrate_blocks,
};
use super::fit::registration::{
    Gravity, Registration, check_plausible_registered, check_registered_count, register,
};
use super::fit::tool_only::retaught;
use super::parameters::camera::RigCamera;
use super::parameters::params::ParamKey;
use super::parameters::servo_knots::KnotSpacing;
use super::parameters::targets::Targets;
use super::progress::Progress;
use super::results::export::registered_calibration_file;
use super::results::report::{RegistrationReport, Report};
use super::{CalibError, ModelOption, Rig};
use lrmcal_core::camera::{CameraSetup, Mount};
use lrmcal_core::dataset::{Measurement, Pose, TargetName, loads_of, poses_under};
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::param_key::LENS_FIELDS;

mod request;
pub use request::{CameraInput, Placement, PoseChoice, Request};

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
    Calibration::open(request)?.run(progress)
}

/// A calibration opened on a [`Request`]: the arm placed in the measurement
/// frame, the measurements checked and carried into the arm's frame, and
/// each option's candidates' analysis kept for every fit that reuses it.
/// The one way the project calibrates: `identify` runs the request's options
/// ([`Calibration::run`]), the demo's study and its experiments fit options
/// again on other poses and loads ([`Calibration::option`]), and `select`
/// chooses poses before anything is measured ([`Calibration::plan`],
/// [`Calibration::select`]) through the same analysis.
pub struct Calibration<'a> {
    request: Request<'a>,
    registration: Registration,
    loads: Vec<f64>,
    load_kg: f64,
    inputs: Inputs,
    structures: Mutex<Vec<Arc<Structures>>>,
    analyses: Mutex<Vec<(Analysed, Arc<CandidateBlocks>)>>,
}

/// What a candidates' analysis was built for.
#[derive(Clone, Debug, PartialEq)]
struct Analysed {
    option: ModelOption,
    loads: Vec<u64>,
    spacing: KnotSpacing,
}

impl<'a> Calibration<'a> {
    /// Places the arm and checks the measurements of `request`.
    pub fn open(request: &Request<'a>) -> Result<Self, CalibError> {
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
        // A board's first corner stands for the first target: the arm
        // registered with its tool point there. A camera on the flange is
        // registered by its centre, the tool frame's origin, where each
        // view puts it in the board's frame.
        let first_corner = match &request.camera {
            Some(camera) if camera.mount == Mount::EyeToHand => Some(
                camera
                    .corner(targets.name_at(0))
                    .ok_or_else(|| CalibError::Registration {
                        problem: format!("{file}: its first target is not a corner of the board"),
                    })?,
            ),
            _ => None,
        };
        let mut at_first = *request.nominal;
        if let Some(corner) = first_corner {
            at_first.tool.xyz = (request.nominal.tool.isometry() * Point3::from(corner))
                .coords
                .into();
        }
        let registration = place(request, &at_first, &first)?;
        // The fit runs in the arm file's world frame, where the base's angles
        // are small corrections; the files get the result in the measurement frame.
        let at_first = registration.arm_for_fit(&at_first);
        let mut nominal = registration.arm_for_fit(request.nominal);
        if let Some(corner) = first_corner {
            // The board's frame, turned as the setup tells it, moved so that
            // its first corner is where registration found it.
            let turn = request.nominal.tool.isometry().rotation;
            nominal.tool.xyz = (Vector3::from(at_first.tool.xyz) - turn * corner).into();
        }
        let all = registration.to_arm_frame(all);
        check_plausible_registered(&at_first, &registration.to_arm_frame(&first), file)?;
        if let Some(candidates) = request.candidates {
            check_in_candidates(&all, candidates, file)?;
        }
        let measured = poses_under(&all, load);
        let mut inputs = Inputs::new(&nominal, &measured, &all);
        if let Placement::Register(Gravity::LevelBase(g)) = request.placement {
            inputs.nominal.level_base = Some(g);
        }
        if let Some(camera) = &request.camera {
            let rig = &inputs.nominal;
            let on_board = (0..rig.targets.len())
                .map(|t| camera.corner(rig.targets.name_at(t)).unwrap_or_default());
            // What stands still is where registration found it: the
            // measurements' frame is its frame.
            let (corners, seeing) = camera.seen_by(on_board, registration.frame);
            inputs.nominal = Rig {
                level_base: rig.level_base,
                ..Rig::on_board(
                    rig.arm,
                    rig.targets.clone(),
                    corners,
                    RigCamera {
                        lens: camera.refine_lens.then_some([0.0; LENS_FIELDS.len()]),
                        ..seeing
                    },
                )
            };
        }
        Ok(Self {
            request: request.clone(),
            registration,
            loads,
            load_kg: load,
            inputs,
            structures: Mutex::new(Vec::new()),
            analyses: Mutex::new(Vec::new()),
        })
    }

    /// A calibration planned before anything is measured: `nominal` at
    /// `candidates`, to be measured under each of `loads_kg`, for
    /// [`Calibration::select`].
    pub fn plan(
        nominal: &'a Arm<f64>,
        candidates: &'a [Pose],
        loads_kg: &[f64],
    ) -> Result<Self, CalibError> {
        let Some(&load_kg) = loads_kg.first() else {
            return Err(CalibError::Empty {
                what: "analyse the candidate poses: no load to measure them under".into(),
            });
        };
        Ok(Self {
            request: Request::new(nominal, &[]).candidates(candidates),
            registration: Registration::identity(nominal, nominal.gravity_vector()),
            loads: loads_kg.to_vec(),
            load_kg,
            inputs: Inputs::new(nominal, candidates, &[]),
            structures: Mutex::new(Vec::new()),
            analyses: Mutex::new(Vec::new()),
        })
    }

    /// [`Calibration::plan`] for the camera of `setup`, where the setup
    /// tells it: every corner of the board a target seen at its pixel,
    /// what the arm carries its tool frame, gravity turning with the base
    /// as a level base's does (what `identify --camera` fits).
    pub fn plan_seen(
        nominal: &'a Arm<f64>,
        candidates: &'a [Pose],
        loads_kg: &[f64],
        setup: &CameraSetup,
    ) -> Result<Self, CalibError> {
        let mut plan = Self::plan(nominal, candidates, loads_kg)?;
        let camera = CameraInput::of_setup(setup);
        let names: Vec<TargetName> = camera.corners.iter().map(|(name, _)| *name).collect();
        let arm = Arm {
            rated_payload_kg: plan.inputs.nominal.arm.rated_payload_kg,
            ..camera.nominal_arm(nominal)
        };
        let still = match setup.mount {
            Mount::EyeToHand => setup.camera,
            Mount::EyeInHand => setup.board_pose,
        };
        let (corners, seeing) = camera.seen_by(
            camera.corners.iter().map(|(_, corner)| *corner),
            still.isometry().inverse(),
        );
        plan.inputs.nominal = Rig {
            level_base: Some(nominal.gravity_vector().norm()),
            ..Rig::on_board(arm, Targets::named_as(&names), corners, seeing)
        };
        plan.request.camera = Some(camera);
        Ok(plan)
    }

    /// Chooses poses for `option` among the candidates, analysed under
    /// every load of the plan (or the measured loads).
    pub fn select(
        &self,
        option: ModelOption,
        choice: &Choice,
        progress: &dyn Progress,
    ) -> Result<Selection, CalibError> {
        let blocks = self.analysis(option, &self.loads, choice.poses())?;
        Selection::choose((*blocks).clone(), &self.inputs.candidates, choice, progress)
    }

    /// Fits every option of the request on the poses it chose.
    pub fn run(&self, progress: &dyn Progress) -> Result<Run, CalibError> {
        let request = &self.request;
        let file = request.measurements_file.as_str();
        let load = self.load_kg;
        let measured = &self.inputs.candidates;
        let choice = match &request.poses {
            PoseChoice::Detmax { n, starts } => Choice::Detmax(DetmaxOptions {
                n: *n,
                starts: *starts,
                ..Default::default()
            }),
            PoseChoice::Listed { ids, file: list } => {
                check_measured(ids, measured, list, file, load)?;
                Choice::Given(ids.clone())
            }
            PoseChoice::All => Choice::Given(measured.iter().map(|p| p.id).collect()),
        };
        let settings = self.settings(choice);
        let mut results = Vec::new();
        let mut skipped = Vec::new();
        let mut notes = Vec::new();
        for &option in &request.options {
            match self.fit(option, &settings, progress) {
                Ok((r, note)) => {
                    notes.extend(note.map(|n| (option, n)));
                    results.push(r);
                }
                Err(e) if request.options.len() > 1 => skipped.push((option, e)),
                Err(e) => return Err(e),
            }
        }
        if results.is_empty() && !skipped.is_empty() {
            return Err(skipped.swap_remove(0).1);
        }
        let registered = self.registered();
        let mut report = Report::new(
            request.arm_origin.clone(),
            measured.len(),
            load,
            serde_json::json!({ "source": file, "loads_kg": self.loads }),
            &results,
        );
        report.registration = registered.then(|| RegistrationReport::from(&self.registration));
        let files = results
            .iter()
            .map(|r| {
                registered_calibration_file(
                    &self.registration,
                    registered,
                    &self.inputs.nominal.arm,
                    r,
                )
            })
            .collect();
        Ok(Run {
            registration: self.registration.clone(),
            load_kg: load,
            results,
            skipped,
            notes,
            report,
            files,
        })
    }

    /// How the request's options are fitted: under its load, checked
    /// against another measured load if there is one, on the poses `choice` takes.
    pub fn settings(&self, choice: Choice) -> RunSettings {
        RunSettings {
            identify_load_kg: self.load_kg,
            other_load_kg: self.loads.iter().copied().find(|l| *l != self.load_kg),
            choice,
            identify: self.request.identify,
        }
    }

    /// Fits `option` as `settings` say (another load, other poses than the
    /// request's), with every check of [`Calibration::run`].
    pub fn option(
        &self,
        option: ModelOption,
        settings: &RunSettings,
        progress: &dyn Progress,
    ) -> Result<OptionResult, CalibError> {
        self.fit(option, settings, progress).map(|(r, _)| r)
    }

    /// The candidates and measurements, in the arm file's world frame.
    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// Where the arm was found (or kept) in the measurement frame.
    pub fn registration(&self) -> &Registration {
        &self.registration
    }

    /// Whether the arm was registered in the measurement frame (rather
    /// than kept where its file says).
    fn registered(&self) -> bool {
        matches!(self.request.placement, Placement::Register(_))
    }

    /// [`Calibration::option`], with what the poses leave undetermined
    /// beyond the geometry of an option fitted as a ladder of models (held
    /// at nominal, the fit goes on).
    fn fit(
        &self,
        option: ModelOption,
        settings: &RunSettings,
        progress: &dyn Progress,
    ) -> Result<(OptionResult, Option<String>), CalibError> {
        let load = settings.identify_load_kg;
        let poses = settings.choice.poses();
        let blocks = self.analysis(option, &[load], poses)?;
        if matches!(settings.choice, Choice::Detmax(_)) && !blocks.selects_for(poses) {
            return Err(CalibError::TooFewPoses {
                poses,
                rows: poses * blocks.blocks.first().map_or(0, |b| b.nrows()),
                params: blocks.identifiability.kept.len(),
            });
        }
        // The measured poses must identify what positions can reveal on
        // this arm at all. An option fitted as a ladder of models holds an
        // effect beyond the geometry they leave undetermined (a spring, a
        // knot) and lets the ladder judge the rest; the geometry they must
        // determine.
        let mut note = None;
        if let (missing, Some(e)) = self.structures(load).missing(&blocks.identifiability)? {
            let beyond_geometry = missing.iter().all(|k| match k {
                ParamKey::Arm(id) => !id.is_geometric(),
                _ => true,
            });
            if model_choice::ladder(option).len() == 1 || !beyond_geometry {
                return Err(e);
            }
            note = Some(e.to_string());
        }
        if self.registered() {
            let params = blocks.identifiability.kept.len();
            // Each pose's targets (a block's rows are three a target), each
            // measured on the instrument's axes.
            let targets = blocks.blocks.first().map_or(1, |b| b.nrows() / 3);
            let coordinates = poses * targets * self.inputs.nominal.measured_axes();
            check_registered_count(poses, coordinates, params, option)?;
        }
        let result = calibrate_blocks(&self.inputs, (*blocks).clone(), settings, progress)?;
        // No calibration worse than where the arm started reaches a file.
        guard::check(
            option,
            &self.inputs.nominal.arm,
            &result.identified,
            result.placement.as_ref(),
        )?;
        Ok((result, note))
    }

    /// What the arm's structure identifies under `load_kg`, worked out once.
    fn structures(&self, load_kg: f64) -> Arc<Structures> {
        let mut known = self
            .structures
            .lock()
            .unwrap_or_else(PoisonError::into_inner);
        if let Some(s) = known.iter().find(|s| s.load_kg() == load_kg) {
            return s.clone();
        }
        let s = Arc::new(Structures::new(&self.inputs.nominal.arm, load_kg));
        known.push(s.clone());
        s
    }

    /// The candidates' analysis for `option` under `loads_kg` on the finest
    /// knot spacing whose parameters `poses` of the candidates can
    /// determine (an option without knots has one): coarser grids while a
    /// selection of `poses` is not made for the kept parameters
    /// ([`CandidateBlocks::selects_for`]) or, when all the candidates are
    /// to be fitted, they leave some of what the arm's structure identifies
    /// undetermined. The coarsest grid's when none will do: the checks of
    /// the fit then say why.
    fn analysis(
        &self,
        option: ModelOption,
        loads_kg: &[f64],
        poses: usize,
    ) -> Result<Arc<CandidateBlocks>, CalibError> {
        let structures = self.structures(loads_kg[0]);
        let mut spacing = KnotSpacing::FINEST;
        loop {
            let blocks = self.analysed(option, loads_kg, spacing)?;
            // When every candidate is fitted the analysis is over the fitted
            // poses themselves: they must determine all the structure allows.
            let carried = || {
                blocks.selects_for(poses)
                    && (poses < self.inputs.candidates.len()
                        || structures.check(&blocks.identifiability).is_ok())
            };
            match spacing.coarser() {
                Some(coarser) if blocks.identifiability.knots.is_some() && !carried() => {
                    spacing = coarser;
                }
                _ => return Ok(blocks),
            }
        }
    }

    /// The candidates' analysis for `option` under `loads_kg` on `spacing`,
    /// built the first time it is asked for.
    fn analysed(
        &self,
        option: ModelOption,
        loads_kg: &[f64],
        spacing: KnotSpacing,
    ) -> Result<Arc<CandidateBlocks>, CalibError> {
        let key = Analysed {
            option,
            loads: loads_kg.iter().map(|l| l.to_bits()).collect(),
            spacing,
        };
        let cached = |analyses: &Mutex<Vec<(Analysed, Arc<CandidateBlocks>)>>| {
            analyses
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .iter()
                .find(|(k, _)| *k == key)
                .map(|(_, b)| b.clone())
        };
        if let Some(blocks) = cached(&self.analyses) {
            return Ok(blocks);
        }
        // Built outside the lock: fits on other threads go on meanwhile.
        let blocks = Arc::new(CandidateBlocks::build_spaced(
            &self.inputs.nominal,
            option,
            spacing,
            &self.inputs.candidates,
            loads_kg,
        )?);
        let mut analyses = self.analyses.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some((_, b)) = analyses.iter().find(|(k, _)| *k == key) {
            return Ok(b.clone());
        }
        analyses.push((key, blocks.clone()));
        Ok(blocks)
    }
}

/// Registers the arm on `first` (the first target's rows), or keeps the
/// file's base.
/// Places `nominal` (the request's, its tool point at the first target)
/// as `request` says, on the first target's measurements `first`.
fn place(
    request: &Request,
    nominal: &Arm<f64>,
    first: &[Measurement],
) -> Result<Registration, CalibError> {
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
