//! `lrmcal measure`: drive the board through a pose list and record one
//! tracker position per pose into a measurement CSV, resumable.
//!
//! After every pose the whole file is rewritten atomically, so an
//! interruption (Ctrl-C, unplugged board, tracker glitch) loses at most the
//! pose in progress; running the same command again skips the recorded ones.

use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Vector3;

use crate::dataset::{Measurement, Pose};
use crate::device::DeviceArgs;
use crate::error::Error;
use crate::io::{measurements, pose_list};

/// Drive the board through a pose list and record tracker positions.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal measure --poses selected.csv --out measured.csv --load-kg 0.0663 --port /dev/ttyACM0\n  \
tracker-export | lrmcal measure --poses selected.csv --out measured.csv --tracker -\n\n\
Tracker positions are millimetres in the world frame, one pose per line: `x y z` (or \
`x,y,z`) in the order of the poses still to measure, or `pose x y z` to name the pose. \
Without --tracker each one is typed at a prompt. Run the same command again after an \
interruption: recorded poses are kept and skipped.")]
pub struct Args {
    /// Pose list CSV (`pose,[load_kg,]q1_deg..q6_deg`).
    #[arg(long, value_name = "FILE")]
    pub poses: PathBuf,
    /// Measurement CSV to write (extended if it exists).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// Payload at the tool, kg [default: the list's `load_kg`, else 0].
    #[arg(long, value_name = "KG")]
    pub load_kg: Option<f64>,
    /// Tracker positions: a file, or `-` for standard input [default: typed at a prompt].
    #[arg(long, value_name = "FILE|-")]
    pub tracker: Option<String>,
    /// Pause after the arm arrives, before the position is taken, ms.
    #[arg(long, default_value_t = 500)]
    pub settle_ms: u64,
    /// The board.
    #[command(flatten)]
    pub device: DeviceArgs,
}

/// A tracker position, m, with the pose id the line names, if it names one.
pub type TrackerReading = (Option<u32>, Vector3<f64>);

/// One tracker line: `None` for a blank, comment or header line.
pub fn parse_tracker_line(line: &str) -> Result<Option<TrackerReading>, String> {
    let line = line.trim();
    if line.is_empty() || line.starts_with('#') || line.starts_with(|c: char| c.is_alphabetic()) {
        return Ok(None);
    }
    let fields: Vec<&str> = line
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .collect();
    let numbers: Vec<f64> = fields
        .iter()
        .map(|f| f.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("expected three numbers `x y z` in mm, found `{line}`"))?;
    let mm = |x: f64, y: f64, z: f64| Vector3::new(x, y, z) / 1000.0;
    match numbers[..] {
        [x, y, z] => Ok(Some((None, mm(x, y, z)))),
        [p, x, y, z] if p >= 0.0 && p.fract() == 0.0 && p <= u32::MAX as f64 => {
            Ok(Some((Some(p as u32), mm(x, y, z))))
        }
        _ => Err(format!(
            "expected `x y z` or `pose x y z` (mm), found `{line}`"
        )),
    }
}

/// The poses still to measure: those without a row of the same pose and load in `done`.
pub fn remaining(poses: &[(Pose, f64)], done: &[Measurement]) -> Vec<(Pose, f64)> {
    poses
        .iter()
        .filter(|(p, load)| !done.iter().any(|m| m.pose.id == p.id && m.load_kg == *load))
        .copied()
        .collect()
}

/// Where tracker positions come from.
enum Tracker {
    Lines(Box<dyn BufRead>, String),
    Typed,
}

impl Tracker {
    /// The next position for `pose`.
    fn next(&mut self, pose: u32, bar: &ProgressBar) -> Result<Vector3<f64>, Error> {
        loop {
            let mut line = String::new();
            let (n, source) = match self {
                Tracker::Lines(r, name) => (r.read_line(&mut line), name.clone()),
                Tracker::Typed => bar.suspend(|| {
                    print!("pose {pose}: tracker x y z (mm)? ");
                    let _ = std::io::stdout().flush();
                    (
                        std::io::stdin().lock().read_line(&mut line),
                        "the keyboard".to_owned(),
                    )
                }),
            };
            let read_failed = |reason: String| Error::DeviceInput {
                what: format!("read a tracker position from {source}"),
                reason,
            };
            if n.map_err(|e| read_failed(e.to_string()))? == 0 {
                return Err(read_failed(format!(
                    "it ended before pose {pose}; the poses so far are saved"
                )));
            }
            match parse_tracker_line(&line) {
                Ok(None) => continue,
                Ok(Some((Some(named), _))) if named != pose => {
                    return Err(read_failed(format!(
                        "the line names pose {named} but the arm is at pose {pose}"
                    )));
                }
                Ok(Some((_, p))) => return Ok(p),
                Err(reason) if matches!(self, Tracker::Typed) => {
                    bar.suspend(|| eprintln!("{reason}"))
                }
                Err(reason) => return Err(read_failed(reason)),
            }
        }
    }
}

/// Runs `lrmcal measure`.
pub fn run(args: &Args) -> Result<(), Error> {
    let list = pose_list::read(&args.poses)?;
    let poses: Vec<(Pose, f64)> = list
        .iter()
        .map(|r| (r.pose, args.load_kg.or(r.load_kg).unwrap_or(0.0)))
        .collect();
    let mut done = if args.out.exists() {
        measurements::read(&args.out)?
    } else {
        Vec::new()
    };
    let todo = remaining(&poses, &done);
    let mut tracker = match args.tracker.as_deref() {
        None => Tracker::Typed,
        Some("-") => Tracker::Lines(Box::new(std::io::stdin().lock()), "standard input".into()),
        Some(path) => {
            let file = std::fs::File::open(path).map_err(|source| Error::Read {
                path: path.into(),
                source,
            })?;
            Tracker::Lines(Box::new(std::io::BufReader::new(file)), format!("`{path}`"))
        }
    };
    let mut client = args.device.connect()?;
    let bar = ProgressBar::new(poses.len() as u64).with_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} poses, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_position((poses.len() - todo.len()) as u64);
    let mut load_now = None;
    for (pose, load_kg) in todo {
        bar.set_message(format!("pose {}", pose.id));
        if load_now != Some(load_kg) {
            client.set_payload(load_kg as f32)?;
            load_now = Some(load_kg);
        }
        client.move_to(pose.q.map(|q| q as f32), protocol::Timing::DurationMs(0))?;
        client.wait_until_still(Duration::from_millis(100), Duration::from_secs(700))?;
        std::thread::sleep(Duration::from_millis(args.settle_ms));
        let position = tracker.next(pose.id, &bar)?;
        done.push(Measurement {
            pose,
            load_kg,
            position,
        });
        measurements::write(&args.out, &done)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    println!("{} poses recorded in {}", done.len(), args.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tracker_lines_in_either_form() {
        let p = parse_tracker_line("212.41, -35.02, 188.77")
            .unwrap()
            .unwrap();
        assert_eq!(p.0, None);
        assert!((p.1 - Vector3::new(0.21241, -0.03502, 0.18877)).norm() < 1e-12);
        assert_eq!(parse_tracker_line("17 1 2 3").unwrap().unwrap().0, Some(17));
        assert_eq!(parse_tracker_line("# comment").unwrap(), None);
        assert_eq!(parse_tracker_line("x_mm,y_mm,z_mm").unwrap(), None);
        assert!(parse_tracker_line("1 2").unwrap_err().contains("expected"));
        assert!(parse_tracker_line("1 NaN 3").is_err());
        assert!(parse_tracker_line("1.5 1 2 3").is_err());
    }

    #[test]
    fn resuming_skips_recorded_pose_and_load_pairs() {
        let pose = |id| Pose { id, q: [0.0; 6] };
        let poses = vec![(pose(1), 0.0), (pose(2), 0.0), (pose(1), 0.0663)];
        let done = vec![Measurement {
            pose: pose(1),
            load_kg: 0.0,
            position: Vector3::zeros(),
        }];
        let left: Vec<(u32, f64)> = remaining(&poses, &done)
            .iter()
            .map(|(p, l)| (p.id, *l))
            .collect();
        assert_eq!(left, vec![(2, 0.0), (1, 0.0663)]);
    }
}
