//! The pose ids of a file's rows: each (pose, load, target) measured once,
//! and every row of a pose id at the same joint values.

use std::collections::HashMap;

use model::PerJoint;

use super::row::Row;
use crate::dataset::TargetName;
use crate::error::{InputError, Problem};

/// Tracks pose ids across rows: each (pose, load, target) once, and one configuration per id.
#[derive(Default)]
pub struct PoseBook {
    seen_load: HashMap<(u32, Option<u64>, Option<TargetName>), u64>,
    seen_q: HashMap<u32, (PerJoint<f64>, u64)>,
}

impl PoseBook {
    /// Records a row (`load_kg` None: the file has no loads) measuring
    /// `target`; errors if its (pose, load, target) was seen, or its pose id
    /// had other angles.
    pub fn record(
        &mut self,
        row: &Row<'_>,
        pose: u32,
        q: &PerJoint<f64>,
        load_kg: Option<f64>,
        target: Option<TargetName>,
    ) -> Result<(), InputError> {
        let key = (pose, load_kg.map(f64::to_bits), target);
        if let Some(&first_line) = self.seen_load.get(&key) {
            let problem = match load_kg {
                Some(load_kg) => Problem::DuplicatePose {
                    pose,
                    load_kg,
                    first_line,
                },
                None => Problem::DuplicatePoseId { pose, first_line },
            };
            return Err(row.error("pose", problem));
        }
        self.seen_load.insert(key, row.line);
        match self.seen_q.get(&pose) {
            // Angles parsed from the same text are bit-identical; a tolerance
            // only forgives a tool that rounds differently between rows.
            Some((q0, first_line)) if q0.iter().zip(q).any(|(a, b)| (a - b).abs() > 1e-9) => {
                Err(row.error(
                    "pose",
                    Problem::InconsistentPose {
                        pose,
                        first_line: *first_line,
                    },
                ))
            }
            Some(_) => Ok(()),
            None => {
                self.seen_q.insert(pose, (*q, row.line));
                Ok(())
            }
        }
    }
}
