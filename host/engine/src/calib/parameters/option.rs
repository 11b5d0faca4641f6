//! The parameters each model option may fit: the paper's three and ours
//! (the option itself is [`model::ModelOption`], re-exported as
//! `calib::ModelOption`), and which option is the default.

use crate::calib::ModelOption;
use crate::calib::parameters::params::ParamKey;
use crate::calib::parameters::servo_knots::{self, KnotSpacing};
use model::params::ParamPart;
use model::{Arm, ParamId};

/// The option `lrmcal identify` fits unless told otherwise; the demo's
/// positioning figure calls its calibration "ours".
pub const DEFAULT: ModelOption = ModelOption::ElastoKinematicServo;

/// Whether `option` fits the servo curves' knot offsets (`calib::servo_knots`)
/// and the springs' softenings ([`refresh_candidates`]): ours only.
pub fn fits_servo_curves(option: ModelOption) -> bool {
    option == ModelOption::ElastoKinematicServo
}

/// Whether `option` fits the joints' backlash widths (`calib::backlash`): ours only.
pub fn fits_backlash(option: ModelOption) -> bool {
    option == ModelOption::ElastoKinematicServo
}

/// Candidate parameters of `option` before the identifiability analysis:
/// for the paper's own sets (`paper-elasto-kinematic`, `paper-kinematic`)
/// the 43 and the 36 geometric ones of plain DH as the paper had them; for
/// elasto-kinematic and kinematic the same and Hayati's twist of every link
/// whose two joint axes are parallel ([`parallel_twists`]), which makes the
/// geometry complete for every chain; the 7 compliances for elastic; for
/// elasto-kinematic-servo the elasto-kinematic ones and the knots of
/// `arm`'s servo curves on the grid of `spacing` (its softenings:
/// [`refresh_candidates`]).
///
/// The order is a preference: when parameters are confounded, the rank
/// analysis keeps the earlier one. Compliances come first, as the elastic
/// parameters are the ones this project exists to identify. Then the base
/// frame and the tool frame, then the joints' DH parameters, base to tip.
///
/// Why the frames before the DH parameters: the base frame's six numbers
/// and the tool frame's translation are coordinates of the base pose and of
/// the tool point in frame 6, so every base pose and every tool point has
/// values; the fit can reach any of them. The DH parameters confounded with
/// them at the nominal arm (`j1.d`, `j1.theta` with the base's height and
/// yaw, `j6.theta`, `j6.d`, `j6.a`, `j6.alpha` with the tool point) are so
/// only to first order: `j6.theta`, `j6.a`, `j6.d` with the file's tool
/// point held cannot bring the point nearer joint 6's axis than the file's
/// offset across `x6` (its `y` when `alpha6` is zero), so a true point 4 mm
/// off the axis stays out of reach when the file says 11 mm.
///
/// Servo knots and backlash widths come last: a constant shift of a joint's
/// knots is its `theta` (the base yaw for joint 1), which the paper's model
/// already has, so the knot that only repeats it is the one removed.
pub fn candidates(option: ModelOption, arm: &Arm<f64>, spacing: KnotSpacing) -> Vec<ParamKey> {
    let compliances = ParamId::of(arm).filter(|p| !p.is_geometric());
    let is_frame =
        |p: &ParamId| matches!(p.part(), ParamPart::Base { .. } | ParamPart::Tool { .. });
    let frames = ParamId::of(arm).filter(is_frame);
    let dh = ParamId::of(arm).filter(move |p| p.is_geometric() && !is_frame(p));
    let geometric = frames.chain(dh);
    let twists = parallel_twists(arm);
    let ids: Vec<ParamId> = match option {
        ModelOption::PaperElastoKinematic => compliances.chain(geometric).collect(),
        ModelOption::ElastoKinematic | ModelOption::ElastoKinematicServo => {
            compliances.chain(geometric).chain(twists).collect()
        }
        ModelOption::PaperKinematic => geometric.collect(),
        ModelOption::Kinematic => geometric.chain(twists).collect(),
        ModelOption::Elastic => compliances.collect(),
    };
    let knots = fits_servo_curves(option)
        .then(|| servo_knots::keys(arm, spacing))
        .into_iter()
        .flatten();
    ids.into_iter().map(ParamKey::Arm).chain(knots).collect()
}

/// How near 0 or π a link's twist `alpha` is for its two joint axes to be
/// parallel, rad: arms read from a URDF have their nearly parallel axes
/// made exactly parallel within 1e-5 rad.
const PARALLEL_RAD: f64 = 1e-5;

/// Hayati's twist `beta` of every link of `arm` whose two joint axes are
/// nominally parallel (`alpha` 0 or π, the last link's not counted: its
/// frame carries no joint): the tilt of two parallel axes that no DH
/// parameter holds (a tilt of `alpha` turns one axis about the common
/// normal, `beta` about the other direction across them). Every option that
/// fits geometry has them but the paper's own plain-DH sets.
pub(crate) fn parallel_twists(arm: &Arm<f64>) -> impl Iterator<Item = ParamId> + '_ {
    let n = arm.joints.len();
    (0..n.saturating_sub(1))
        .filter(|&i| arm.joints[i].alpha.sin().abs() < PARALLEL_RAD)
        .filter_map(ParamId::beta)
}

/// Parameters of `option` that only the refresh proposes, at the estimate
/// (`calib::refresh`): one softening per spring. A softening's effect is
/// its spring's compliance times `|tau| tau`, so it is zero on an arm file's
/// rigid springs and vanishes wherever the fit takes the compliance to
/// zero: only at the estimate can the analysis and the fit's deviations
/// tell whether the poses determine it.
pub fn refresh_candidates(option: ModelOption, arm: &Arm<f64>) -> Vec<ParamKey> {
    if !fits_servo_curves(option) {
        return Vec::new();
    }
    (0..=arm.joints.len() as u8)
        .map(|spring| ParamKey::Softening { spring })
        .collect()
}

/// The softenings of the springs whose compliances are among `keys`, when
/// `option` fits them: what a fit of ours under a prior
/// (`calib::parameters::prior`) starts with, the prior determining a
/// softening wherever the poses do not (a least-squares fit has only the
/// refresh propose them, [`refresh_candidates`]).
pub fn softenings_of(option: ModelOption, keys: &[ParamKey]) -> Vec<ParamKey> {
    if !fits_servo_curves(option) {
        return Vec::new();
    }
    keys.iter()
        .filter_map(|k| match k.quantity() {
            Some(model::bounds::Quantity::Compliance { spring }) => {
                Some(ParamKey::Softening { spring })
            }
            _ => None,
        })
        .filter(|s| !keys.contains(s))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calib::testing::test_arm;

    const FINEST: KnotSpacing = KnotSpacing::FINEST;

    #[test]
    fn candidate_counts_are_43_36_7_and_98() {
        let arm = test_arm();
        // The paper's own sets: its 43 and 36 of plain DH.
        assert_eq!(
            candidates(ModelOption::PaperElastoKinematic, &arm, FINEST).len(),
            43
        );
        assert_eq!(
            candidates(ModelOption::PaperKinematic, &arm, FINEST).len(),
            36
        );
        // The complete sets add Hayati's twist of link 2, whose joint axes
        // (2 and 3) are parallel, after the paper's parameters.
        let ek = candidates(ModelOption::ElastoKinematic, &arm, FINEST);
        assert_eq!(ek.len(), 44);
        assert_eq!(ek[43].name(), "j2.beta");
        assert_eq!(
            ek[..43],
            candidates(ModelOption::PaperElastoKinematic, &arm, FINEST)[..]
        );
        let kin = candidates(ModelOption::Kinematic, &arm, FINEST);
        assert_eq!(kin.len(), 37);
        assert_eq!(kin[36].name(), "j2.beta");
        let ours = candidates(ModelOption::ElastoKinematicServo, &arm, FINEST);
        assert_eq!(ours.len(), 44 + 6 * servo_knots::KNOTS);
        assert_eq!(ours[..44], ek[..]);
        assert_eq!(
            refresh_candidates(ModelOption::ElastoKinematicServo, &arm).len(),
            7
        );
        assert!(refresh_candidates(ModelOption::ElastoKinematic, &arm).is_empty());
        assert_eq!(candidates(ModelOption::Elastic, &arm, FINEST).len(), 7);
        assert!(
            candidates(ModelOption::Elastic, &arm, FINEST)
                .iter()
                .all(|k| matches!(
                    k.quantity(),
                    Some(model::bounds::Quantity::Compliance { .. })
                ))
        );
        assert_eq!(
            candidates(ModelOption::ElastoKinematic, &arm, FINEST)[..7],
            candidates(ModelOption::Elastic, &arm, FINEST)[..]
        );
        // The frames before the DH parameters: they hold every base pose and tool point.
        assert_eq!(
            (kin[0].name(), kin[11].name()),
            ("base.x".into(), "tool.yaw".into())
        );
        assert_eq!(kin[12].name(), "j1.theta");
    }

    #[test]
    fn coarser_grids_take_every_second_or_fourth_knot() {
        let arm = test_arm();
        for (spacing, knots, names) in [
            (
                KnotSpacing::Deg50,
                5,
                ["j2.servo[1]", "j2.servo[3]", "j2.servo[9]"],
            ),
            (
                KnotSpacing::Deg100,
                3,
                ["j2.servo[1]", "j2.servo[5]", "j2.servo[9]"],
            ),
        ] {
            let ours = candidates(ModelOption::ElastoKinematicServo, &arm, spacing);
            assert_eq!(ours.len(), 44 + 6 * knots, "{spacing}");
            let names: Vec<String> = names.iter().map(|n| n.to_string()).collect();
            let joint2: Vec<String> = ours
                .iter()
                .filter(|k| matches!(k, ParamKey::ServoKnot { joint: 1, .. }))
                .map(|k| k.name().into_owned())
                .collect();
            assert!(names.iter().all(|n| joint2.contains(n)), "{joint2:?}");
            assert_eq!(servo_knots::spacing_of(&ours), Some(spacing));
            assert_eq!(
                servo_knots::on_spacing(
                    &candidates(ModelOption::ElastoKinematicServo, &arm, FINEST),
                    spacing
                ),
                ours
            );
        }
    }

    #[test]
    fn a_joint_without_a_servo_curve_has_no_knots() {
        let mut arm = test_arm();
        arm.joints[5].servo = None;
        let ours = candidates(ModelOption::ElastoKinematicServo, &arm, FINEST);
        assert_eq!(ours.len(), 44 + 5 * servo_knots::KNOTS);
        assert!(
            !ours
                .iter()
                .any(|k| matches!(k, ParamKey::ServoKnot { joint: 5, .. }))
        );
    }
}
