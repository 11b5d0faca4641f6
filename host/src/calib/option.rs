//! The three model options of the paper and the error parameters each may fit.

use std::fmt;
use std::str::FromStr;

use model::ParamId;
use serde::{Deserialize, Serialize};

/// Which part of the model is calibrated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelOption {
    /// Geometry and compliances together (all 43 candidates).
    ElastoKinematic,
    /// Geometry only (36 candidates); compliances stay at their nominal values.
    Kinematic,
    /// Compliances only (7 candidates); geometry stays nominal.
    Elastic,
}

impl ModelOption {
    /// Every option, in the order the paper's table lists them (worst model first).
    pub const ALL: [ModelOption; 3] = [
        ModelOption::Kinematic,
        ModelOption::Elastic,
        ModelOption::ElastoKinematic,
    ];

    /// The stable name used on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Self::ElastoKinematic => "elasto-kinematic",
            Self::Kinematic => "kinematic",
            Self::Elastic => "elastic",
        }
    }

    /// Candidate error parameters before the identifiability analysis.
    ///
    /// Compliances come first: when a compliance and a geometric parameter are
    /// confounded, the rank analysis keeps the earlier one, and the elastic
    /// parameters are the ones this project exists to identify.
    pub fn candidates(self) -> Vec<ParamId> {
        let compliances = ParamId::all().filter(|p| !p.is_geometric());
        let geometric = ParamId::all().filter(|p| p.is_geometric());
        match self {
            Self::ElastoKinematic => compliances.chain(geometric).collect(),
            Self::Kinematic => geometric.collect(),
            Self::Elastic => compliances.collect(),
        }
    }
}

impl fmt::Display for ModelOption {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ModelOption {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|o| o.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown model option `{s}`: expected elasto-kinematic, kinematic or elastic"
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidate_counts_are_43_36_7() {
        assert_eq!(ModelOption::ElastoKinematic.candidates().len(), 43);
        assert_eq!(ModelOption::Kinematic.candidates().len(), 36);
        assert_eq!(ModelOption::Elastic.candidates().len(), 7);
        for o in ModelOption::ALL {
            assert_eq!(o.name().parse::<ModelOption>(), Ok(o));
        }
        assert!(
            "rigid"
                .parse::<ModelOption>()
                .unwrap_err()
                .contains("elasto-kinematic")
        );
    }
}
