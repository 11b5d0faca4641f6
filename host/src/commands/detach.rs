//! `lrmcal detach`: make servos limp (or drive them again).

use crate::commands::device_args::DeviceArgs;
use crate::error::Error;
use protocol::CHANNELS;

/// Stop the pulses of one joint or all, so the servos go limp; `--attach` undoes it.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  lrmcal detach            # all joints limp\n  \
lrmcal detach 3          # joint 3 only\n  lrmcal detach --attach   # hold all joints where they are"
)]
pub struct Args {
    /// Joint (servo channel) 1..6 [default: all].
    #[arg(value_parser = clap::value_parser!(u8).range(1..=CHANNELS as i64))]
    pub joint: Option<u8>,
    /// Drive the joint(s) again, holding the current position.
    #[arg(long)]
    pub attach: bool,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// Runs `lrmcal detach`.
pub fn run(args: &Args) -> Result<(), Error> {
    let mut client = args.device.connect()?;
    let channel = args.joint.map(|j| j - 1);
    if args.attach {
        client.attach(channel)?;
    } else {
        client.detach(channel)?;
    }
    Ok(())
}
