//! How every device command finds and talks to the board: the arguments they
//! share, the connection they open with them, and the timing of a move they
//! ask for.

use std::time::Duration;

use lrmcal_engine::device::{Client, ClientError, Link, open};
use protocol::Timing;

/// How every device command finds and talks to the board.
#[derive(Clone, Debug, clap::Args)]
pub struct DeviceArgs {
    /// Serial port of the board (`lrmcal ports` lists them), or
    /// `socket://HOST:PORT` for the emulator.
    #[arg(long, short, env = "LRMCAL_PORT")]
    pub port: String,
    /// How long to wait for each reply, ms.
    #[arg(long, default_value_t = 500)]
    pub timeout_ms: u64,
    /// How often to resend a request that got no reply.
    #[arg(long, default_value_t = 3)]
    pub retries: u32,
}

impl DeviceArgs {
    /// Opens the link and checks that the board speaks our protocol version.
    pub fn connect(&self) -> Result<Client<Box<dyn Link>>, ClientError> {
        let link = open(&self.port)?;
        let mut client = Client::new(link, Duration::from_millis(self.timeout_ms), self.retries);
        client.hello()?;
        Ok(client)
    }
}

/// The timing a move or `home` asks the board for: a speed of the joint that
/// travels furthest if given, else a duration, else as fast as the board's
/// limits allow (a duration of 0).
pub fn timing(duration_ms: Option<u32>, speed_deg_s: Option<f64>) -> Timing {
    match (duration_ms, speed_deg_s) {
        (_, Some(v)) => Timing::SpeedRadPerS(v.to_radians() as f32),
        (Some(ms), None) => Timing::DurationMs(ms),
        (None, None) => Timing::DurationMs(0),
    }
}
