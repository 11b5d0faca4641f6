//! What the engine's integration tests and figures share.

pub mod camera_trial;
