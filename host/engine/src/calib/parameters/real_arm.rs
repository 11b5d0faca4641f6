//! How far a real arm's geometry is off its file at most: what the guard
//! refuses a fit beyond (`calib::guard`) and what ours' prior sizes the
//! twists by (`calib::parameters::prior`).

/// The largest correction of a DH length a real arm needs, as a fraction
/// of its reach: a tenth of the arm. A fit past it has wandered into a
/// region the measurements do not pin (two parameters trading off).
pub const LENGTH_FRACTION_OF_REACH: f64 = 0.1;

/// The largest correction of a link's twist (`alpha`, `beta`) a real arm
/// needs, rad (10°). A joint's zero (`theta`) is not held to it: a servo
/// horn one spline tooth off is 14° off.
pub const MAX_TWIST_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;
