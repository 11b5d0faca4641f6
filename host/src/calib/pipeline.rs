//! The stages chained as the demo (and `identify --select N`) run them for one
//! model option: rank analysis over the candidates, DETMAX selection,
//! identification on the selected poses, validation on the rest, and the
//! cross-load check.

use std::collections::HashMap;

use indicatif::ProgressBar;
use model::Arm;
use nalgebra::DMatrix;

use super::detmax::{Design, DetmaxOptions, detmax, log_det, split_blocks, stack};
use super::identifiability::{Identifiability, analyse_jacobian};
use super::identify::{Identified, IdentifyOptions, identify};
use super::jacobian::{JacobianOptions, jacobian};
use super::observability::{ColumnScale, Observability};
use super::validate::{Validation, validate};
use super::{CalibError, ModelOption, Sample};
use crate::dataset::{Measurement, Pose};

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
    /// Analyses `candidates` measured under each of `loads_kg` for `option` at `nominal`.
    pub fn build(
        nominal: &Arm<f64>,
        option: ModelOption,
        candidates: &[Pose],
        loads_kg: &[f64],
    ) -> Result<Self, CalibError> {
        if candidates.is_empty() || loads_kg.is_empty() {
            return Err(CalibError::Empty {
                what: "analyse the candidate poses".into(),
            });
        }
        let samples: Vec<Sample> = candidates
            .iter()
            .flat_map(|p| {
                loads_kg.iter().map(|&load_kg| Sample {
                    id: p.id,
                    q: p.q,
                    load_kg,
                })
            })
            .collect();
        let ids = option.candidates();
        let j = jacobian(nominal, &ids, &samples, &JacobianOptions::default())?;
        let identifiability = analyse_jacobian(option, &ids, &j);
        let cols: Vec<usize> = identifiability
            .kept
            .iter()
            .filter_map(|k| ids.iter().position(|p| p == k))
            .collect();
        let kept = j.select_columns(&cols);
        let scale = ColumnScale::from_jacobian(&kept, candidates.len());
        let blocks = split_blocks(&scale.apply(&kept), 3 * loads_kg.len());
        Ok(Self {
            identifiability,
            scale,
            blocks,
        })
    }

    /// O1..O5 of the candidate subset `chosen` (indices into the candidates).
    pub fn observability(&self, chosen: &[usize]) -> Observability {
        Observability::of_scaled(&stack(&self.blocks, chosen), chosen.len())
    }
}

/// A DETMAX selection for one option.
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

/// Chooses poses among `candidates` for `option`, measured under `loads_kg`.
pub fn select(
    nominal: &Arm<f64>,
    option: ModelOption,
    candidates: &[Pose],
    loads_kg: &[f64],
    choice: &Choice,
    progress: &ProgressBar,
) -> Result<Selection, CalibError> {
    let blocks = CandidateBlocks::build(nominal, option, candidates, loads_kg)?;
    let design = match choice {
        Choice::Detmax(options) => detmax(&blocks.blocks, options, progress)?,
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
    Ok(Selection {
        option,
        candidates: blocks,
        design,
        poses,
        observability,
    })
}

/// Measurements indexed by (pose id, load).
pub struct MeasurementIndex<'a> {
    map: HashMap<(u32, u64), &'a Measurement>,
}

impl<'a> MeasurementIndex<'a> {
    /// Indexes `measurements`.
    pub fn new(measurements: &'a [Measurement]) -> Self {
        Self {
            map: measurements
                .iter()
                .map(|m| ((m.pose.id, m.load_kg.to_bits()), m))
                .collect(),
        }
    }

    /// The measurements of `poses` under `load_kg` (poses without one are skipped).
    pub fn of(&self, poses: impl IntoIterator<Item = u32>, load_kg: f64) -> Vec<Measurement> {
        poses
            .into_iter()
            .filter_map(|p| self.map.get(&(p, load_kg.to_bits())).map(|m| **m))
            .collect()
    }
}

/// Everything the demo learns about one option.
#[derive(Clone, Debug)]
pub struct OptionResult {
    /// The selection.
    pub selection: Selection,
    /// The identification on the selected poses.
    pub identified: Identified,
    /// Validation on the other candidates under the identification load
    /// (none when every candidate was used for the fit).
    pub validation: Option<Validation>,
    /// Validation on the other candidates under the other load, if measured.
    pub cross_load: Option<(f64, Validation)>,
}

/// Selects, identifies and validates `option`: identification under
/// `identify_load_kg`, validation on every candidate not selected under the
/// same load and, when given, under `other_load_kg`.
#[allow(clippy::too_many_arguments)]
pub fn calibrate_option(
    nominal: &Arm<f64>,
    option: ModelOption,
    candidates: &[Pose],
    measurements: &[Measurement],
    identify_load_kg: f64,
    other_load_kg: Option<f64>,
    choice: &Choice,
    identify_options: &IdentifyOptions,
    progress: &ProgressBar,
) -> Result<OptionResult, CalibError> {
    let selection = select(
        nominal,
        option,
        candidates,
        &[identify_load_kg],
        choice,
        progress,
    )?;
    let index = MeasurementIndex::new(measurements);
    let chosen: Vec<u32> = selection.poses.iter().map(|p| p.id).collect();
    let fit_set = index.of(chosen.iter().copied(), identify_load_kg);
    if fit_set.len() < chosen.len() {
        return Err(CalibError::Empty {
            what: format!(
                "identify from the selected poses: only {} of {} have a measurement under {identify_load_kg} kg",
                fit_set.len(),
                chosen.len()
            ),
        });
    }
    let ids = selection.candidates.identifiability.kept.clone();
    let identified = identify(nominal, option, &ids, &fit_set, identify_options)?;
    let rest: Vec<u32> = candidates
        .iter()
        .map(|p| p.id)
        .filter(|id| !chosen.contains(id))
        .collect();
    let held_out = index.of(rest.iter().copied(), identify_load_kg);
    let validation = if held_out.is_empty() {
        None
    } else {
        Some(validate(nominal, &identified.arm, &held_out)?)
    };
    let cross_load = match other_load_kg.map(|load| (load, index.of(rest.iter().copied(), load))) {
        Some((load, set)) if !set.is_empty() => {
            Some((load, validate(nominal, &identified.arm, &set)?))
        }
        _ => None,
    };
    Ok(OptionResult {
        selection,
        identified,
        validation,
        cross_load,
    })
}
