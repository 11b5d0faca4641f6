//! The parameters each of the paper's three model options may fit (the option
//! itself is `protocol::ModelOption`, the board stores it too).

use model::ParamId;
use protocol::ModelOption;

use super::params::ParamKey;

/// Candidate parameters of `option` before the identifiability analysis: all
/// 43 for elasto-kinematic, the 36 geometric ones for kinematic, the 7
/// compliances for elastic.
///
/// Compliances come first: when a compliance and a geometric parameter are
/// confounded, the rank analysis keeps the earlier one, and the elastic
/// parameters are the ones this project exists to identify.
pub fn candidates(option: ModelOption) -> Vec<ParamKey> {
    let compliances = ParamId::all().filter(|p| !p.is_geometric());
    let geometric = ParamId::all().filter(|p| p.is_geometric());
    let ids: Vec<ParamId> = match option {
        ModelOption::ElastoKinematic => compliances.chain(geometric).collect(),
        ModelOption::Kinematic => geometric.collect(),
        ModelOption::Elastic => compliances.collect(),
    };
    ids.into_iter().map(ParamKey::Arm).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidate_counts_are_43_36_7() {
        assert_eq!(candidates(ModelOption::ElastoKinematic).len(), 43);
        assert_eq!(candidates(ModelOption::Kinematic).len(), 36);
        assert_eq!(candidates(ModelOption::Elastic).len(), 7);
        assert!(
            candidates(ModelOption::Elastic)
                .iter()
                .all(|k| k.lower_bound() == Some(0.0))
        );
        assert_eq!(
            candidates(ModelOption::ElastoKinematic)[..7],
            candidates(ModelOption::Elastic)[..]
        );
    }
}
