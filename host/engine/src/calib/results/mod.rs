//! What a calibration run gives people and files: the calibration file's
//! content ([`export`]), the machine-readable report ([`report`]), the lines
//! and tables the commands print ([`summary`]), each identified servo curve
//! with its uncertainty ([`servo_curves`]), the demo's study of every
//! option ([`study`]), its experiments ([`experiments`]) and their figures
//! ([`figures`]).

pub mod experiments;
pub mod export;
pub mod figures;
pub mod report;
pub mod servo_curves;
pub mod study;
pub mod summary;
