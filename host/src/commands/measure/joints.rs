//! `measure --joints`: the poses of an arm our board does not drive, as the
//! joint angles its own controller reports it reached, one CSV record per
//! pose (the pose list's columns), from a file or standard input.
//!
//! A record is read only when the previous pose is recorded, and as soon as
//! its line is complete (`pose_list::PoseStream`): a controller that writes
//! a line each time the arm reaches a pose is followed pose by pose, not
//! read to its end first. Each record is checked before the pose is
//! measured: its angles within the arm's joint limits, and a pose already in
//! the output (a resumed run) skipped, or refused if its id now has other
//! angles.

use std::io::BufRead;
use std::path::{Path, PathBuf};

use model::Arm;

use crate::error::Error;
use crate::progress::Meter;
use lrmcal_core::dataset::{Measurement, Pose};
use lrmcal_core::io::pose_list::{self, PoseStream};

/// The file name `--joints` gives standard input.
pub const STDIN: &str = "-";

/// What errors call standard input as a source of joint angles.
const STDIN_NAME: &str = "<stdin>";

/// The joint angles reached, record by record.
pub(super) struct Reached {
    stream: PoseStream<Box<dyn BufRead>>,
    /// The arm whose limits the angles must lie within.
    arm: Arm<f64>,
    /// Use angles outside the limits with a warning instead of stopping.
    allow_outside_limits: bool,
    /// `--load-kg`, which overrides the records' own `load_kg`.
    load_kg: Option<f64>,
    /// The measurement file written, for messages.
    out: PathBuf,
}

impl Reached {
    /// The records of `source` (a file, or [`STDIN`]) for the arm `arm`.
    pub(super) fn open(
        source: &Path,
        arm: Arm<f64>,
        allow_outside_limits: bool,
        load_kg: Option<f64>,
        out: &Path,
    ) -> Result<Self, Error> {
        let (reader, name): (Box<dyn BufRead>, PathBuf) = if source == Path::new(STDIN) {
            (Box::new(std::io::stdin().lock()), STDIN_NAME.into())
        } else {
            let file = std::fs::File::open(source).map_err(|e| lrmcal_core::Error::Read {
                path: source.to_owned(),
                source: e,
            })?;
            (Box::new(std::io::BufReader::new(file)), source.to_owned())
        };
        Ok(Self {
            stream: PoseStream::new(reader, name),
            arm,
            allow_outside_limits,
            load_kg,
            out: out.to_owned(),
        })
    }

    /// The next pose and load to measure, blocking until its record
    /// arrives; `None` once the input ends. Records of poses `done` holds
    /// are skipped (said on `bar`).
    pub(super) fn next(
        &mut self,
        done: &[Measurement],
        bar: &Meter,
    ) -> Result<Option<(Pose, f64)>, Error> {
        while let Some(listed) = self.stream.next_pose()? {
            let pose = listed.row.pose;
            let load_kg = self.load_kg.or(listed.row.load_kg).unwrap_or(0.0);
            let mut same_id = done.iter().filter(|m| m.pose.id == pose.id);
            if let Some(other) = same_id.clone().find(|m| {
                m.pose
                    .q
                    .iter()
                    .zip(&pose.q)
                    .any(|(a, b)| (a - b).abs() > 1e-9)
            }) {
                return Err(Error::DeviceInput {
                    what: format!(
                        "record pose {} of `{}` (line {})",
                        pose.id,
                        self.stream.name().display(),
                        listed.line
                    ),
                    reason: format!(
                        "`{}` already holds pose {} with other joint angles (measured with {} kg); \
                         one pose id is one configuration: give this one a new id",
                        self.out.display(),
                        pose.id,
                        other.load_kg
                    ),
                });
            }
            if same_id.any(|m| m.load_kg == load_kg) {
                bar.println(&format!(
                    "pose {} with {load_kg} kg: already in `{}`, skipped",
                    pose.id,
                    self.out.display()
                ));
                continue;
            }
            if let Some(warning) = pose_list::check_within_limits(
                &self.arm,
                self.stream.name(),
                std::slice::from_ref(&listed),
                self.allow_outside_limits,
            )? {
                bar.println(&format!("warning: {warning}"));
            }
            return Ok(Some((pose, load_kg)));
        }
        Ok(None)
    }
}
