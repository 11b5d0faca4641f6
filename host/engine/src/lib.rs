//! The engine of lrmcal's host side: everything between the files the ground
//! floor (`lrmcal_core`) reads and the files the command line writes.
//!
//! | module | what it does |
//! |---|---|
//! | [`calib`] | identifiability, pose selection, the fit, registration, validation, the results as files hold them |
//! | [`camera`] | the board's tag corners found in a camera image |
//! | [`plan`] | candidate poses: the grid and random poses the arm can take without colliding |
//! | [`ik`] | joint targets that put the tool on a point, for `move --xyz` and the positioning test |
//! | [`sim`] | a simulated arm to measure, and the demo's positioning through an in-memory board |
//! | [`tracker`] | 3D positions from a live tracker or a recorded take |
//! | [`device`] | the board: its messages, the client, the calibration it receives, an in-memory board |
//! | [`scale`] | how an arm's torques compare with the bundled arm's, for priors and typical errors |
//!
//! Nothing here touches a terminal or writes a file: the command line above
//! reads the inputs, calls in, and writes what comes back.

pub mod calib;
pub mod camera;
pub mod device;
pub mod ik;
pub mod plan;
pub mod scale;
pub mod sim;
pub mod tracker;
