//! `lrmcal`: calibrate a low-cost arm from 3D tool positions.
pub mod dataset;
