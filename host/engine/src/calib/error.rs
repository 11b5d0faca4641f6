//! What can go wrong in the calibration engine, with messages that name the
//! input at fault and read after "failed to …".

/// An error of the calibration engine.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibError {
    /// The elastic deflection could not be solved for one pose.
    #[error("evaluate pose {pose} with {load_kg} kg: {message}")]
    Deflection {
        /// Pose id (or index when the poses carry no id).
        pose: u32,
        /// Payload, kg.
        load_kg: f64,
        /// The model's explanation.
        message: String,
    },
    /// An identified servo curve that no longer maps angle to pulse one-to-one.
    #[error(
        "identify joint {joint}'s servo curve: {fault} (identified knot angles {knots}); the board must never receive it: measure more poses of this joint, or fit the elasto-kinematic option"
    )]
    ServoCurve {
        /// Joint, from 1.
        joint: usize,
        /// What is wrong with the curve.
        fault: String,
        /// The identified knot angles, degrees.
        knots: String,
    },
    /// Fewer measured coordinates than parameters to fit.
    #[error(
        "identify {params} parameters from {poses} poses ({rows} coordinates): at least {params} coordinates are needed, and in practice several times more; measure more poses or choose fewer with --select"
    )]
    TooFewPoses {
        /// Poses given.
        poses: usize,
        /// Measured coordinates (3 per measurement).
        rows: usize,
        /// Parameters to fit.
        params: usize,
    },
    /// The chosen poses cannot identify every kept parameter.
    #[error(
        "identify the {option} model from this pose set: it is rank deficient (rank {rank} of {params}); the weakest directions involve {weakest}; add poses that move these joints or use `lrmcal select`"
    )]
    RankDeficient {
        /// Model option name.
        option: String,
        /// Numerical rank of the scaled Jacobian.
        rank: usize,
        /// Number of parameters.
        params: usize,
        /// The parameters dominating the null space.
        weakest: String,
    },
    /// The measured poses identify fewer parameters than the arm's structure allows.
    #[error(
        "identify the {option} model from these measurements: the measured poses identify {identified} of the {structural} parameters that positions reveal on this arm (over the -100/0/+100 degree grid), and leave {missing} undetermined; measure poses that move these joints, e.g. chosen with `lrmcal select`"
    )]
    Unidentifiable {
        /// Model option name.
        option: String,
        /// Parameters the measured poses identify.
        identified: usize,
        /// Parameters the grid identifies.
        structural: usize,
        /// The grid's parameters the measured poses do not identify.
        missing: String,
    },
    /// Parameters given to the fit twice, or unknown to it.
    #[error("set up the parameters to fit")]
    Params(#[from] super::parameters::params::ParamError),
    /// A measured target has too few poses to fix its tool point.
    #[error(
        "fit the tool point of target `{target}` of {file}: it is measured at {poses} poses, at least {needed} are needed to fix its three coordinates together with the arm; measure it at more poses or drop its rows"
    )]
    TargetTooFewPoses {
        /// File the measurements came from.
        file: String,
        /// The target's name.
        target: String,
        /// Distinct poses it is measured at.
        poses: usize,
        /// Poses needed.
        needed: usize,
    },
    /// Measurements of a target the calibration does not have.
    #[error("find target `{target}` in the calibration: it has the targets {known}")]
    UnknownTarget {
        /// The target asked for.
        target: String,
        /// The calibration's targets, in order.
        known: String,
    },
    /// A measured pose is not one of the candidate poses.
    #[error(
        "match measurements to candidates: pose {pose} of {file} is not in the candidate pose list ({detail})"
    )]
    PoseNotInCandidates {
        /// Pose id.
        pose: u32,
        /// File the measurement came from.
        file: String,
        /// Why it does not match (missing id or different angles).
        detail: String,
    },
    /// A measurement is implausible for this arm.
    #[error("use measurement of pose {pose} ({load_kg} kg) from {file}: {problem}")]
    BadMeasurement {
        /// Pose id.
        pose: u32,
        /// Payload, kg.
        load_kg: f64,
        /// File it came from.
        file: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The nominal arm cannot be placed on the measurements by a rigid motion.
    #[error("register the arm in the measurement frame: {problem}")]
    Registration {
        /// Why, and what to check.
        problem: String,
    },
    /// No measurement or pose to work with.
    #[error("{what}: the set is empty")]
    Empty {
        /// What was empty.
        what: String,
    },
    /// The solver ended without a usable result.
    #[error("identify the {option} model: {reason}")]
    Solver {
        /// Model option name.
        option: String,
        /// What the solver said.
        reason: String,
    },
    /// A fit that would leave the arm worse than where it started, or that
    /// did not converge: no calibration file is made of it.
    #[error("calibrate with the {option} model: {what}; no calibration was written. {advice}")]
    Refused {
        /// Model option name.
        option: String,
        /// What went wrong, with the figures.
        what: String,
        /// What to try.
        advice: String,
    },
    /// The input leaves a choice open that the user must make.
    #[error("{what}")]
    Ambiguous {
        /// What to choose and how.
        what: String,
    },
}
