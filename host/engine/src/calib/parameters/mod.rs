//! The free parameters of a calibration: the registry of their values
//! ([`params`]), each model option's candidates ([`option`]), the rig they
//! correct (the arm and one tool point per measured target, [`targets`]),
//! the servo curves' knots ([`servo_knots`]) and the joints' play
//! ([`backlash`]).

pub mod backlash;
pub(crate) mod joint_columns;
pub mod option;
pub mod params;
pub mod servo_knots;
pub mod targets;
