//! The camera as the instrument: what it finds in an image, and where that
//! puts the board.
//!
//! | module | what it holds |
//! |---|---|
//! | [`board_pose`] | the board's pose in the camera frame from one view's corners (a planar perspective-n-point solve) |
//! | [`corner_measurements`] | a camera's views as the fit's measurements: each corner a target, seen at its pixel |
//! | [`detect`] | the board's AprilTag corners found in a grey image, in the board's corner order and OpenCV's pixel convention |
//! | [`focus`] | how sharp a frame is (the variance of its Laplacian) and how much the scene changed between two frames, to keep a still, sharp webcam frame |
//! | [`printed_board`] | the board as a page to print (SVG at true size) |
//! | `tag_bits` | a tag36h11 tag's bit image, from the AprilTag C library |

pub mod board_pose;
pub mod corner_measurements;
pub mod detect;
pub mod focus;
pub mod printed_board;
pub(crate) mod tag_bits;
#[cfg(test)]
pub(crate) mod testing;
