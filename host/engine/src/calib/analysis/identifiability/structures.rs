//! What the arm's structure lets positions identify, worked out once per
//! option and knot spacing on the grid of every joint's levels, and the
//! refusal of a pose set that identifies less.

use std::sync::{Mutex, PoisonError};

use model::Arm;

use super::{Identifiability, analyse};
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::KnotSpacing;
use crate::calib::{CalibError, ModelOption, Sample};

/// What the arm's structure lets positions identify, worked out once per
/// option and knot spacing and kept for every later check of the same arm
/// and load: the parameters the -100/0/+100° grid of every joint identifies
/// (each level within the joint's limits; servo knots on the spacing
/// checked) is what positions can reveal at all.
pub struct Structures {
    nominal: Arm<f64>,
    load_kg: f64,
    known: Mutex<Vec<Structure>>,
}

/// The parameters the grid identifies for an option and knot spacing.
type Structure = ((ModelOption, KnotSpacing), Vec<ParamKey>);

impl Structures {
    /// The structures of `nominal` under `load_kg`, none worked out yet.
    pub fn new(nominal: &Arm<f64>, load_kg: f64) -> Self {
        Self {
            nominal: *nominal,
            load_kg,
            known: Mutex::new(Vec::new()),
        }
    }

    /// The load the structures are worked out under, kg.
    pub fn load_kg(&self) -> f64 {
        self.load_kg
    }

    /// Refuses a measured pose set that identifies fewer of
    /// `measured.option`'s parameters than the arm's structure allows.
    pub fn check(&self, measured: &Identifiability) -> Result<(), CalibError> {
        match self.missing(measured)? {
            (_, Some(e)) => Err(e),
            _ => Ok(()),
        }
    }

    /// The parameters the arm's structure identifies for
    /// `measured.option` that the measured poses leave undetermined, and
    /// the refusal [`Structures::check`] makes of them (`None` when none is
    /// missing).
    pub fn missing(
        &self,
        measured: &Identifiability,
    ) -> Result<(Vec<ParamKey>, Option<CalibError>), CalibError> {
        let spacing = measured.knots.unwrap_or(KnotSpacing::FINEST);
        let structural = self.kept(measured.option, spacing)?;
        // Compared over the rig's own parameters: further targets' tool points
        // are the measurements' own, the grid has none.
        let own_kept = measured
            .kept
            .iter()
            .filter(|p| !matches!(p, ParamKey::TargetTool { .. }))
            .count();
        if own_kept >= structural.len() {
            return Ok((Vec::new(), None));
        }
        let missing: Vec<ParamKey> = structural
            .iter()
            .filter(|p| !measured.kept.contains(p))
            .copied()
            .collect();
        let names: Vec<String> = missing.iter().map(|p| p.to_string()).collect();
        let refusal = CalibError::Unidentifiable {
            option: measured.option.name().into(),
            identified: own_kept,
            structural: structural.len(),
            missing: names.join(", "),
        };
        Ok((missing, Some(refusal)))
    }

    /// The parameters the grid identifies for `option` on `spacing`: worked
    /// out the first time they are asked for.
    fn kept(&self, option: ModelOption, spacing: KnotSpacing) -> Result<Vec<ParamKey>, CalibError> {
        if let Some((_, kept)) = self
            .known
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .iter()
            .find(|(k, _)| *k == (option, spacing))
        {
            return Ok(kept.clone());
        }
        // Each level within the joint's limits: the grid the arm can reach
        // (a slide's levels are its ends and its zero).
        let within = |mut q: model::PerJoint<f64>| {
            for (v, joint) in q.iter_mut().zip(self.nominal.joints.iter()) {
                *v = v.clamp(joint.limits[0], joint.limits[1]);
            }
            q
        };
        let grid: Vec<Sample> = crate::plan::Levels::paper()
            .grid(self.nominal.joints.len())
            .map(|p| Sample {
                id: p.id,
                q: within(p.q),
                load_kg: self.load_kg,
                target: 0,
                approach: lrmcal_core::dataset::from_home(p.q.len()),
            })
            .collect();
        let kept = analyse(&self.nominal, option, spacing, &grid)?.kept;
        self.known
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(((option, spacing), kept.clone()));
        Ok(kept)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::{small_samples, test_arm};

    /// One pose cannot identify what the grid identifies: the check names
    /// the parameters it leaves undetermined; the grid itself passes.
    #[test]
    fn a_pose_set_must_identify_what_the_grid_does() {
        let nominal = test_arm();
        let one = analyse(
            &nominal,
            ModelOption::Elastic,
            KnotSpacing::FINEST,
            &small_samples(1),
        )
        .unwrap();
        let structures = Structures::new(&nominal, 0.0663);
        let e = structures.check(&one).unwrap_err();
        assert!(
            matches!(e, CalibError::Unidentifiable { structural: 6, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("undetermined"), "{e}");
        let grid: Vec<Sample> = crate::plan::Levels::paper()
            .grid(6)
            .map(|p| Sample {
                id: p.id,
                q: p.q,
                load_kg: 0.0663,
                target: 0,
                approach: lrmcal_core::dataset::from_home(6),
            })
            .collect();
        let all = analyse(&nominal, ModelOption::Elastic, KnotSpacing::FINEST, &grid).unwrap();
        assert!(structures.check(&all).is_ok());
    }
}
