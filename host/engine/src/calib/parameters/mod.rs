//! The free parameters of a calibration: the registry of their values
//! ([`params`]), each model option's candidates ([`option`]), the rig they
//! correct (the arm and one tool point per measured target, [`targets`]),
//! the camera that measures them when one does ([`camera`]),
//! the servo curves' knots ([`servo_knots`]), the joints' play
//! ([`backlash`]), what a fit of ours assumes of its effects before any
//! measurement ([`prior`]) and how far a real arm's geometry is off at most
//! ([`real_arm`]).

pub mod backlash;
pub mod camera;
pub(crate) mod joint_columns;
pub mod option;
pub mod params;
pub mod prior;
pub mod real_arm;
pub mod servo_knots;
pub mod targets;
