//! The stages of one model option's calibration, which the one calibration
//! run (`calib::run`) chains for every caller: rank analysis over the
//! candidates, pose selection (DETMAX or given), identification on the
//! selected poses, validation on the rest, and the cross-load check.
//!
//! The candidates' analysis ([`CandidateBlocks`]: the Jacobian over every
//! candidate) is the costly part; the run builds it once per option, load
//! and knot spacing, and it is carried in the result, so what follows
//! (checks, experiments, reports) reuses it.

use std::collections::{HashMap, HashSet};

use model::Arm;
use nalgebra::DMatrix;

use crate::calib::analysis::detmax::{Design, DetmaxOptions, detmax, log_det, split_blocks, stack};
use crate::calib::analysis::identifiability::{
    Identifiability, RANK_TOLERANCE, TypicalErrors, analyse_jacobian,
};
use crate::calib::analysis::jacobian::jacobian;
use crate::calib::analysis::observability::{ColumnScale, Observability};
use crate::calib::fit::choice::{ChosenFit, KnotChoice, ModelChoice};
use crate::calib::fit::grow::grow;
use crate::calib::fit::identify::{Identified, IdentifyOptions};
use crate::calib::fit::model_choice::Ladder;
use crate::calib::fit::validate::{LoadValidation, Validation, reprojection_errors_px, validate};
use crate::calib::parameters::camera::RigCamera;
use crate::calib::parameters::option::candidates as option_candidates;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::KnotSpacing;
use crate::calib::parameters::targets::Targets;
use crate::calib::progress::Progress;
use crate::calib::{CalibError, ModelOption, Rig, Sample};
use lrmcal_core::dataset::{Measurement, Pose, from_home};
use lrmcal_core::io::calibration_file::ErrorStats;

/// The column-scaled Jacobian blocks of a candidate set, one per pose, over the
/// identifiable parameters of one option.
#[derive(Clone, Debug)]
pub struct CandidateBlocks {
    /// The rank analysis that chose the columns.
    pub identifiability: Identifiability,
    /// The column scale (fixed over the candidates).
    pub scale: ColumnScale,
    /// One `3·loads × m` block per candidate pose.
    pub blocks: Vec<DMatrix<f64>>,
}

impl CandidateBlocks {
    /// Analyses `candidates` measured under each of `loads_kg` for `option`
    /// at `nominal`, every target of the rig at every pose: the columns are
    /// the further targets' tool points and the option's candidates (servo
    /// knots on the finest grid), a pose's block has the rows of all its
    /// targets.
    pub fn build(
        nominal: &Rig,
        option: ModelOption,
        candidates: &[Pose],
        loads_kg: &[f64],
    ) -> Result<Self, CalibError> {
        Self::build_spaced(nominal, option, KnotSpacing::FINEST, candidates, loads_kg)
    }

    /// [`CandidateBlocks::build`] with the servo knots on the grid of `spacing`.
    pub fn build_spaced(
        nominal: &Rig,
        option: ModelOption,
        spacing: KnotSpacing,
        candidates: &[Pose],
        loads_kg: &[f64],
    ) -> Result<Self, CalibError> {
        if candidates.is_empty() || loads_kg.is_empty() {
            return Err(CalibError::Empty {
                what: "analyse the candidate poses".into(),
            });
        }
        // Analysed in the canonical order, so that the rank analysis, the
        // column scale and every block come out bit for bit the same however
        // the file orders its rows; the blocks are then put back in the
        // caller's order.
        let order = canonical_order(candidates);
        let targets = nominal.targets.len();
        let samples: Vec<Sample> = order
            .iter()
            .map(|&i| &candidates[i])
            .flat_map(|p| {
                loads_kg.iter().flat_map(move |&load_kg| {
                    (0..targets).map(move |target| Sample {
                        id: p.id,
                        q: p.q,
                        load_kg,
                        target,
                        // No backlash is analysed here (`calib::backlash`).
                        approach: from_home(p.q.len()),
                    })
                })
            })
            .collect();
        // The further targets' tool points come first: each is unknown
        // (the nominal arm has no idea where the target sits), so what they
        // are confounded with (the arm's own tool point, frame 6's
        // translation) is what the rank analysis removes.
        let mut ids = nominal.tool_keys();
        ids.extend(nominal.camera.iter().flat_map(RigCamera::lens_keys));
        ids.extend(option_candidates(option, &nominal.arm, spacing));
        let j = jacobian(nominal, &ids, &samples)?;
        let identifiability = analyse_jacobian(
            option,
            &ids,
            &j,
            &TypicalErrors::of_arm(&nominal.arm),
            RANK_TOLERANCE,
        );
        // The kept parameters are a subsequence of the candidates, in order.
        let cols: Vec<usize> = ids
            .iter()
            .enumerate()
            .filter(|(_, k)| identifiability.kept.contains(k))
            .map(|(c, _)| c)
            .collect();
        let kept = j.select_columns(&cols);
        let scale = ColumnScale::from_jacobian(&kept, candidates.len());
        let mut blocks = vec![DMatrix::zeros(0, 0); candidates.len()];
        for (block, &i) in split_blocks(&scale.apply(&kept), 3 * loads_kg.len() * targets)
            .into_iter()
            .zip(&order)
        {
            blocks[i] = block;
        }
        Ok(Self {
            identifiability,
            scale,
            blocks,
        })
    }

    /// The option analysed.
    pub fn option(&self) -> ModelOption {
        self.identifiability.option
    }

    /// The fewest poses whose rows can determine the kept parameters, with
    /// three rows to spare: `3·loads·targets·n ≥ m + 3`.
    pub fn fewest_poses(&self) -> usize {
        let rows = self.blocks.first().map_or(3, |b| b.nrows()).max(1);
        (self.identifiability.kept.len() + 3).div_ceil(rows)
    }

    /// Whether a selection of `poses` poses is made for these parameters:
    /// when they are servo knots, the poses must determine them with a
    /// quarter to spare ([`CandidateBlocks::fewest_poses`]); a design that
    /// needs every pose to pin the finest curves is poor for the coarser
    /// ones the fit will then choose (`calib::knot_choice`).
    pub fn selects_for(&self, poses: usize) -> bool {
        match self.identifiability.knots {
            Some(_) => 5 * self.fewest_poses() <= 4 * poses,
            None => self.fewest_poses() <= poses,
        }
    }

    /// O1..O5 of the candidate subset `chosen` (indices into the candidates).
    pub fn observability(&self, chosen: &[usize]) -> Observability {
        Observability::of_scaled(&stack(&self.blocks, chosen), chosen.len())
    }
}

/// A pose selection for one option.
#[derive(Clone, Debug)]
pub struct Selection {
    /// The option.
    pub option: ModelOption,
    /// The candidates' analysis.
    pub candidates: CandidateBlocks,
    /// The design found.
    pub design: Design,
    /// The selected poses.
    pub poses: Vec<Pose>,
    /// Observability indices of the selection.
    pub observability: Observability,
}

/// How the poses to identify from are chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum Choice {
    /// D-optimal selection by DETMAX.
    Detmax(DetmaxOptions),
    /// The poses with these ids, as given by the user.
    Given(Vec<u32>),
}

impl Choice {
    /// How many poses it takes.
    pub fn poses(&self) -> usize {
        match self {
            Self::Detmax(d) => d.n,
            Self::Given(ids) => ids.len(),
        }
    }
}

impl Selection {
    /// Chooses among `candidates`, whose analysis is `blocks`; a DETMAX
    /// choice reports one progress unit per start.
    pub fn choose(
        blocks: CandidateBlocks,
        candidates: &[Pose],
        choice: &Choice,
        progress: &dyn Progress,
    ) -> Result<Self, CalibError> {
        let design = match choice {
            Choice::Detmax(options) => {
                progress.begin(
                    &format!("{}: DETMAX starts", blocks.option()),
                    options.starts.max(1) as u64,
                );
                // DETMAX sees the candidates in the canonical order: its
                // random starts and its ties then pick the same poses
                // whatever the order of the rows they were read from.
                let order = canonical_order(candidates);
                let canonical: Vec<DMatrix<f64>> =
                    order.iter().map(|&i| blocks.blocks[i].clone()).collect();
                let design = detmax(&canonical, options, progress);
                progress.end();
                let mut design = design?;
                design.chosen = design.chosen.iter().map(|&c| order[c]).collect();
                design.chosen.sort_unstable();
                design
            }
            Choice::Given(ids) => {
                let chosen = ids
                    .iter()
                    .map(|id| {
                        candidates.iter().position(|p| p.id == *id).ok_or_else(|| {
                            CalibError::PoseNotInCandidates {
                                pose: *id,
                                file: "the pose selection".into(),
                                detail: "no candidate (measured pose) has this id".into(),
                            }
                        })
                    })
                    .collect::<Result<Vec<usize>, _>>()?;
                let log_det = log_det(&blocks.blocks, &chosen);
                Design {
                    chosen,
                    log_det,
                    excursions: 0,
                    start_log_dets: vec![log_det],
                }
            }
        };
        let observability = blocks.observability(&design.chosen);
        let poses = design.chosen.iter().map(|&c| candidates[c]).collect();
        Ok(Self {
            option: blocks.option(),
            candidates: blocks,
            design,
            poses,
            observability,
        })
    }
}

/// The candidates' indices sorted by joint angles (joint 1 first), then by
/// pose id: an order that depends on the set of poses only, not on the order
/// of the rows they were read from.
pub fn canonical_order(candidates: &[Pose]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| {
        let (a, b) = (&candidates[a], &candidates[b]);
        a.q.iter()
            .zip(&b.q)
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
            .then(a.id.cmp(&b.id))
    });
    order
}

/// Measurements indexed by (pose id, load), each key with the measurements
/// of all its targets.
pub struct MeasurementIndex {
    map: HashMap<(u32, u64), Vec<Measurement>>,
}

impl MeasurementIndex {
    /// Indexes `measurements`.
    pub fn new(measurements: &[Measurement]) -> Self {
        let mut map: HashMap<(u32, u64), Vec<Measurement>> = HashMap::new();
        for m in measurements {
            map.entry((m.pose.id, m.load_kg.to_bits()))
                .or_default()
                .push(*m);
        }
        Self { map }
    }

    /// The measurements of `poses` under `load_kg`, every target's, in pose
    /// order (poses without one are skipped).
    pub fn of(&self, poses: impl IntoIterator<Item = u32>, load_kg: f64) -> Vec<Measurement> {
        poses
            .into_iter()
            .filter_map(|p| self.map.get(&(p, load_kg.to_bits())))
            .flatten()
            .copied()
            .collect()
    }
}

/// What the runs of one calibration work from: the nominal arm with the
/// measured targets, the candidate poses selection chooses among, and every
/// measurement, indexed once.
pub struct Inputs {
    /// The nominal arm and the measurements' targets (further targets'
    /// tool points start at the arm's).
    pub nominal: Rig,
    /// The candidate poses, in order (a selection's indices point here).
    pub candidates: Vec<Pose>,
    /// The measurements by (pose, load).
    pub measurements: MeasurementIndex,
}

impl Inputs {
    /// Indexes `measurements` of `candidates` for `nominal`, whose rated
    /// payload is raised to the heaviest load measured ([`rated_for`]).
    pub fn new(nominal: &Arm<f64>, candidates: &[Pose], measurements: &[Measurement]) -> Self {
        let nominal = Arm {
            rated_payload_kg: rated_for(nominal, measurements),
            ..*nominal
        };
        Self {
            nominal: Rig::new(nominal, Targets::of(measurements)),
            candidates: candidates.to_vec(),
            measurements: MeasurementIndex::new(measurements),
        }
    }

    /// The ids of the candidates not in `chosen` (pose ids), in candidate order.
    pub fn held_out(&self, chosen: &[u32]) -> Vec<u32> {
        let chosen: HashSet<u32> = chosen.iter().copied().collect();
        self.candidates
            .iter()
            .map(|p| p.id)
            .filter(|id| !chosen.contains(id))
            .collect()
    }
}

/// The rated payload of a calibration of `nominal` from `measurements`, kg:
/// the arm's own, or the heaviest load measured if that is more. The bounds
/// of the springs (`model::bounds`) hold up to it: a calibration is made for
/// at least the loads it was measured under.
pub fn rated_for(nominal: &Arm<f64>, measurements: &[Measurement]) -> f64 {
    measurements
        .iter()
        .map(|m| m.load_kg)
        .fold(nominal.rated_payload_kg, f64::max)
}

/// How one option is calibrated.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSettings {
    /// The load whose measurements are fitted and validated on, kg.
    pub identify_load_kg: f64,
    /// Another measured load to validate on (the cross-load check), kg.
    pub other_load_kg: Option<f64>,
    /// How the poses are chosen.
    pub choice: Choice,
    /// How the fit runs.
    pub identify: IdentifyOptions,
}

/// Everything one option's run learns.
#[derive(Clone, Debug)]
pub struct OptionResult {
    /// The load the fit used, kg.
    pub identify_load_kg: f64,
    /// The selection, with the candidates' analysis.
    pub selection: Selection,
    /// The identification on the selected poses.
    pub identified: Identified,
    /// How the servo curves' knot spacing was chosen, for an option that fits them.
    pub knots: Option<KnotChoice>,
    /// How the model was chosen, for an option fitted as a ladder of them.
    pub model: Option<ModelChoice>,
    /// The nominal arm placed (base and tool points only) on the same
    /// poses: where the arm started; `None` when that fit failed.
    pub placement: Option<Identified>,
    /// Validation on the other candidates under the identification load
    /// (none when every candidate was used for the fit).
    pub validation: Option<Validation>,
    /// Validation on the other candidates under the other load, if measured.
    pub cross_load: Option<LoadValidation>,
    /// A camera's reprojection errors at the fitted corners, px (the
    /// statistics' `_m` fields hold pixels here); `None` for a tracker.
    pub fit_px: Option<ErrorStats>,
}

impl OptionResult {
    /// The option.
    pub fn option(&self) -> ModelOption {
        self.selection.option
    }

    /// The parameters the rank analysis removed and the refresh did not
    /// fit: held at their nominal values.
    pub fn held(&self) -> Vec<ParamKey> {
        self.selection
            .candidates
            .identifiability
            .removed_ids()
            .into_iter()
            .filter(|k| !self.identified.estimates.iter().any(|e| e.id == *k))
            .collect()
    }

    /// Ids of the poses the fit used.
    pub fn pose_ids(&self) -> Vec<u32> {
        self.selection.poses.iter().map(|p| p.id).collect()
    }

    /// The validation on held-out poses, which a run over every candidate does not have.
    pub fn held_out(&self) -> Result<&Validation, CalibError> {
        self.validation.as_ref().ok_or_else(|| CalibError::Empty {
            what: format!(
                "validate the {} calibration: every candidate was selected, none is left to validate on",
                self.option()
            ),
        })
    }
}

/// The "before" of a validation: the nominal arm, with the further targets'
/// tool points as `fitted` found them (a nominal arm has no idea where they
/// are, and the comparison is about what calibrating the arm bought).
pub fn nominal_with_fitted_targets(nominal: &Rig, fitted: &Rig) -> Rig {
    Rig {
        tools: fitted.tools.clone(),
        ..nominal.clone()
    }
}

/// Selects, identifies and validates over `inputs` as `settings` say, from
/// the candidates' analysis `blocks` (built under the identification load).
/// Only the one calibration run (`calib::run`) calls it.
pub(crate) fn calibrate_blocks(
    inputs: &Inputs,
    blocks: CandidateBlocks,
    settings: &RunSettings,
    progress: &dyn Progress,
) -> Result<OptionResult, CalibError> {
    let load = settings.identify_load_kg;
    let selection = Selection::choose(blocks, &inputs.candidates, &settings.choice, progress)?;
    let chosen: Vec<u32> = selection.poses.iter().map(|p| p.id).collect();
    let fit_set = inputs.measurements.of(chosen.iter().copied(), load);
    let measured = fit_set
        .iter()
        .map(|m| m.pose.id)
        .collect::<HashSet<u32>>()
        .len();
    if measured < chosen.len() {
        return Err(CalibError::Empty {
            what: format!(
                "identify from the selected poses: only {measured} of {} have a measurement under {load} kg",
                chosen.len()
            ),
        });
    }
    inputs
        .nominal
        .targets
        .check_poses(&fit_set, &format!("the {} selected poses", chosen.len()))?;
    let Ladder {
        chosen: ChosenFit {
            identified,
            knots,
            model,
        },
        placement,
    } = grow(
        &inputs.nominal,
        selection.option,
        &selection.candidates.identifiability.kept,
        &fit_set,
        &settings.identify,
    )?;
    let rest = inputs.held_out(&chosen);
    let held_out = inputs.measurements.of(rest.iter().copied(), load);
    let before = nominal_with_fitted_targets(&inputs.nominal, &identified.rig);
    let validation = if held_out.is_empty() {
        None
    } else {
        Some(validate(&before, &identified.rig, &held_out)?)
    };
    let cross_load = match settings
        .other_load_kg
        .map(|load| (load, inputs.measurements.of(rest.iter().copied(), load)))
    {
        Some((load_kg, set)) if !set.is_empty() => Some(LoadValidation {
            load_kg,
            validation: validate(&before, &identified.rig, &set)?,
        }),
        _ => None,
    };
    let fit_px = match identified.rig.camera {
        Some(_) => Some(ErrorStats::of(&reprojection_errors_px(
            &identified.rig,
            &fit_set,
        )?)),
        None => None,
    };
    Ok(OptionResult {
        identify_load_kg: load,
        selection,
        identified,
        knots,
        model,
        placement: placement.map(|p| p.identified),
        validation,
        cross_load,
        fit_px,
    })
}
