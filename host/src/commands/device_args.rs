//! How every device command finds and talks to the board: the arguments they
//! share, and the connection they open with them.

use std::time::Duration;

use lrmcal_engine::device::{Client, ClientError, Link, open};

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
