//! The model options: which parameters a calibration identifies, by the
//! names the files and the command line use. One type for both ends: the
//! host fits and writes it, the board stores it with the calibration and
//! shows it in `status` (the protocol re-exports it).

use serde::{Deserialize, Serialize};

/// Which parameters the calibration identified: the paper's three model
/// options and ours (`docs/METHOD.md`, "Model options").
///
/// The host's files write it by [`ModelOption::name`] (serde's kebab-case
/// names); postcard encodes the variant's index, so the names are not on the
/// wire. New variants go after the existing ones, so the indices of the old
/// ones stay what they were.
///
/// The board stores the option the calibration was identified with and shows
/// it in `status`; it compensates every option the same way, from the
/// calibrated arm the payload carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelOption {
    /// Geometric and elastic parameters: the geometry complete for every
    /// chain (standard DH, and Hayati's twist where two axes are parallel)
    /// and the compliances.
    ElastoKinematic,
    /// Geometric parameters only, complete for every chain.
    Kinematic,
    /// Compliances only (7).
    Elastic,
    /// Ours: the geometric and elastic parameters, plus each servo's
    /// curve between its tuned points (knot offsets), each joint's backlash
    /// (the width of its play) and each spring's softening.
    ElastoKinematicServo,
    /// The paper's elasto-kinematic model as the paper had it: plain DH
    /// (no twist of parallel axes) and the compliances (28 in the paper).
    PaperElastoKinematic,
    /// The paper's kinematic model as the paper had it: plain DH only (21
    /// in the paper).
    PaperKinematic,
}

impl ModelOption {
    /// The options `--option all` fits, worst model first: the paper's
    /// table order, then ours.
    pub const ALL: [ModelOption; 4] = [
        Self::Kinematic,
        Self::Elastic,
        Self::ElastoKinematic,
        Self::ElastoKinematicServo,
    ];

    /// The paper's three models with the paper's own parameters, then
    /// ours: what the demo compares, as the paper's table.
    pub const PAPER_STUDY: [ModelOption; 4] = [
        Self::PaperKinematic,
        Self::Elastic,
        Self::PaperElastoKinematic,
        Self::ElastoKinematicServo,
    ];

    /// Every option there is: [`ModelOption::ALL`], then the paper's plain-DH sets.
    pub const EVERY: [ModelOption; 6] = [
        Self::Kinematic,
        Self::Elastic,
        Self::ElastoKinematic,
        Self::ElastoKinematicServo,
        Self::PaperKinematic,
        Self::PaperElastoKinematic,
    ];

    /// The name used on the command line and in calibration files.
    pub fn name(self) -> &'static str {
        match self {
            Self::ElastoKinematic => "elasto-kinematic",
            Self::Kinematic => "kinematic",
            Self::Elastic => "elastic",
            Self::ElastoKinematicServo => "elasto-kinematic-servo",
            Self::PaperElastoKinematic => "paper-elasto-kinematic",
            Self::PaperKinematic => "paper-kinematic",
        }
    }

    /// The option called `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::EVERY.into_iter().find(|o| o.name() == name)
    }

    /// Whether the option fits the arm's geometry.
    pub fn fits_geometry(self) -> bool {
        self != Self::Elastic
    }

    /// Whether the option keeps the paper's plain DH parameters, without
    /// the twists of parallel axes.
    pub fn is_paper_dh(self) -> bool {
        matches!(self, Self::PaperKinematic | Self::PaperElastoKinematic)
    }
}

impl core::fmt::Display for ModelOption {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_names_round_trip_in_table_order() {
        let names = ModelOption::ALL.map(ModelOption::name);
        assert_eq!(
            names,
            [
                "kinematic",
                "elastic",
                "elasto-kinematic",
                "elasto-kinematic-servo"
            ]
        );
        for o in ModelOption::EVERY {
            assert_eq!(ModelOption::from_name(o.name()), Some(o));
        }
        assert_eq!(ModelOption::from_name("rigid"), None);
        assert_eq!(
            ModelOption::from_name("paper-kinematic"),
            Some(ModelOption::PaperKinematic)
        );
    }
}
