//! The parameters each model option may fit: the paper's three and ours (the
//! option itself is `crate::io::model_option::ModelOption`).

use super::ModelOption;
use super::params::ParamKey;
use super::servo_knots;
use model::ParamId;

/// Candidate parameters of `option` before the identifiability analysis: all
/// 43 for elasto-kinematic, the 36 geometric ones for kinematic, the 7
/// compliances for elastic, and for elasto-kinematic-servo the 43 and the
/// knots of the six servo curves.
///
/// Compliances come first: when a compliance and a geometric parameter are
/// confounded, the rank analysis keeps the earlier one, and the elastic
/// parameters are the ones this project exists to identify. Servo knots come
/// last: a constant shift of a joint's knots is its `theta`, which the paper's
/// model already has, so the knot that only repeats it is the one removed.
pub fn candidates(option: ModelOption) -> Vec<ParamKey> {
    let compliances = ParamId::all().filter(|p| !p.is_geometric());
    let geometric = ParamId::all().filter(|p| p.is_geometric());
    let ids: Vec<ParamId> = match option {
        ModelOption::ElastoKinematic | ModelOption::ElastoKinematicServo => {
            compliances.chain(geometric).collect()
        }
        ModelOption::Kinematic => geometric.collect(),
        ModelOption::Elastic => compliances.collect(),
    };
    let knots = option
        .fits_servo_curves()
        .then(servo_knots::keys)
        .into_iter()
        .flatten();
    ids.into_iter().map(ParamKey::Arm).chain(knots).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidate_counts_are_43_36_7_and_97() {
        assert_eq!(candidates(ModelOption::ElastoKinematic).len(), 43);
        let ours = candidates(ModelOption::ElastoKinematicServo);
        assert_eq!(ours.len(), 43 + 6 * servo_knots::KNOTS);
        assert_eq!(ours[..43], candidates(ModelOption::ElastoKinematic)[..]);
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
