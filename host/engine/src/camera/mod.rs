//! The camera as the instrument: what it finds in an image.
//!
//! | module | what it holds |
//! |---|---|
//! | [`detect`] | the board's AprilTag corners found in a grey image, in the board's corner order and OpenCV's pixel convention |

pub mod detect;
