//! What brings the arm to each pose `measure` records: our board, or the
//! person or controller that moves an arm our board does not drive.

use std::io::BufRead;
use std::time::Duration;

use crate::commands::device_args::DeviceArgs;
use crate::error::Error;
use crate::progress::Meter;
use lrmcal_core::dataset::Pose;
use lrmcal_engine::device::{Client, Link};

/// What brings the arm to each pose.
pub(super) enum Mover {
    /// Our board, with the payload it was last told.
    Board {
        client: Box<Client<Box<dyn Link>>>,
        load_now: Option<f64>,
    },
    /// A person or the arm's own controller, told each pose on stderr.
    Announced,
    /// The arm's own controller, which reported the pose it reached (a
    /// record of `--joints -`): nothing to move, nothing to wait for.
    Reported,
}

impl Mover {
    /// The board of `--port`, else the announcements.
    pub(super) fn of(device: Option<&DeviceArgs>) -> Result<Self, Error> {
        Ok(match device {
            Some(device) => Self::Board {
                client: Box::new(device.connect()?),
                load_now: None,
            },
            None => Self::Announced,
        })
    }

    /// Brings the arm to `pose` under `load_kg`: the board moves there,
    /// waits until it stands, then `settle_ms`; otherwise the pose is
    /// announced and, when `confirm`, a line on standard input awaited; a
    /// reported pose is only shown.
    pub(super) fn arrive(
        &mut self,
        pose: Pose,
        load_kg: f64,
        settle_ms: u64,
        confirm: bool,
        bar: &Meter,
    ) -> Result<(), Error> {
        match self {
            Self::Board { client, load_now } => {
                if *load_now != Some(load_kg) {
                    client.set_payload(load_kg as f32)?;
                    *load_now = Some(load_kg);
                }
                let targets = protocol::PerChannel::from_slice(
                    &pose.q.iter().map(|&q| q as f32).collect::<Vec<_>>(),
                )
                .ok_or_else(|| Error::DeviceInput {
                    what: format!("move to pose {}", pose.id),
                    reason: format!(
                        "it has {} joint angles and the board drives arms of 1 to {}",
                        pose.q.len(),
                        protocol::CHANNELS
                    ),
                })?;
                client.move_to(targets, protocol::Timing::DurationMs(0))?;
                client.wait_until_still(Duration::from_millis(100), Duration::from_secs(700))?;
                std::thread::sleep(Duration::from_millis(settle_ms));
                Ok(())
            }
            Self::Reported => {
                bar.println(&format!(
                    "pose {}: the arm reached q = ({}) deg with {load_kg} kg",
                    pose.id,
                    degrees(&pose)
                ));
                Ok(())
            }
            Self::Announced => {
                let announce = format!(
                    "pose {}: move the arm to q = ({}) deg with {load_kg} kg",
                    pose.id,
                    degrees(&pose)
                );
                if !confirm {
                    bar.println(&announce);
                    return Ok(());
                }
                let mut line = String::new();
                let read = bar.suspend(|| {
                    eprint!("{announce}, then press Enter ");
                    std::io::stdin().lock().read_line(&mut line)
                });
                match read {
                    Ok(n) if n > 0 => Ok(()),
                    Ok(_) => Err(Error::DeviceInput {
                        what: format!("wait for the arm at pose {}", pose.id),
                        reason: "standard input ended before the arm was there; the poses so far \
                                 are saved"
                            .into(),
                    }),
                    Err(e) => Err(Error::DeviceInput {
                        what: format!("wait for the arm at pose {}", pose.id),
                        reason: format!("standard input cannot be read: {e}"),
                    }),
                }
            }
        }
    }
}

/// A pose's joint angles as people read them: `10.00, 20.00, …` degrees.
fn degrees(pose: &Pose) -> String {
    let angles: Vec<String> = pose
        .q
        .iter()
        .map(|q| format!("{:.2}", q.to_degrees()))
        .collect();
    angles.join(", ")
}
