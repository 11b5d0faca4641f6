//! The fit and what surrounds it: the arm's base in the tracker's frame
//! ([`registration`]), measurements that cannot be right ([`checks`]), the
//! Levenberg–Marquardt fit ([`identify`]), the rank analysis again at the
//! estimate ([`refresh`]), the servo curves' knot spacing ([`knot_choice`]),
//! how much model the measurements carry ([`model_choice`]), what those
//! choices are ([`choice`]),
//! these stages in their order for one option ([`grow`]), what a fit must
//! show before a calibration is made of it ([`guard`]),
//! validation on held-out poses ([`validate`]), re-teaching the tool points
//! ([`tool_only`]) and the stages chained for one option ([`pipeline`]).

pub mod checks;
pub mod choice;
pub mod grow;
pub mod guard;
pub mod identify;
pub mod knot_choice;
pub mod model_choice;
pub mod pipeline;
pub mod refresh;
pub mod registration;
pub mod tool_only;
pub mod validate;
