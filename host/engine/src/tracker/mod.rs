//! Positions from optical trackers: a live ART DTrack stream or positions
//! as text lines ([`text`]) for `lrmcal measure`, and recorded OptiTrack
//! Motive takes for `lrmcal import-tracker`.
//!
//! Data flow: DTrack datagrams ([`dtrack`]) → [`settle`] (wait until still,
//! average a window) → one position per pose; a Motive CSV export
//! ([`motive`]) → [`still`] periods → one position per pose, in order. The
//! positions stay in the tracker's frame (units converted to m), optionally
//! turned Z-up ([`axes`]).

pub mod axes;
pub mod dtrack;
pub mod listen;
pub mod motive;
pub mod settle;
pub mod still;
pub mod text;

use std::net::SocketAddr;
use std::path::PathBuf;

pub use dtrack::Target;
pub use settle::{Reading, SettleOptions, StreamProblem};

/// Everything that can go wrong getting positions from a tracker.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrackerError {
    /// The UDP port could not be bound.
    #[error("listen for DTrack output on {addr}")]
    Listen {
        /// The address asked for.
        addr: SocketAddr,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// Receiving from the socket failed.
    #[error("receive DTrack output on {addr}")]
    Receive {
        /// The bound address.
        addr: SocketAddr,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// The stream gave no reading of the target.
    #[error("read {target} from the DTrack stream on {addr}: {problem}")]
    Stream {
        /// The bound address.
        addr: SocketAddr,
        /// The body or marker.
        target: Target,
        /// What was seen instead.
        problem: StreamProblem,
    },
    /// A take file's content cannot be used.
    #[error("import the take `{}`", path.display())]
    Take {
        /// The take file.
        path: PathBuf,
        /// Where and what.
        #[source]
        source: motive::TakeError,
    },
    /// The still periods of a take do not pair up with the poses.
    #[error(
        "match the still periods of `{}` to the poses of `{}`: {problem}",
        take.display(),
        poses.display()
    )]
    Periods {
        /// The take file.
        take: PathBuf,
        /// The pose list.
        poses: PathBuf,
        /// The counts and the periods found.
        problem: String,
    },
}
