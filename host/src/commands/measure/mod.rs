//! `lrmcal measure`: drive the board through a pose list and record one
//! tracker position per pose into a measurement CSV, resumable. Without
//! `--port` the arm is moved by hand or by its own controller (an arm our
//! board does not drive): each pose is announced on stderr, and its tracker
//! line, or Enter on standard input before a DTrack reading, says it is
//! there. With `--joints` the poses are the angles such an arm's controller
//! reports it reached, one record at a time ([`joints`]).
//!
//! Positions come from a live ART DTrack stream (`dtrack://`, averaged once
//! the arm holds still, see `lrmcal_engine::tracker`), from lines of a file or a pipe,
//! or typed at a prompt. With `--hold-s` nothing is recorded: the arm holds
//! each pose for a tracker that records a take, imported afterwards with
//! `lrmcal import-tracker`.
//!
//! After every pose the whole file is rewritten atomically, so an
//! interruption (Ctrl-C, unplugged board, tracker glitch) loses at most the
//! pose in progress; running the same command again skips the recorded ones.

mod capture;
mod joints;
mod mover;
mod tracker;
#[cfg(target_os = "linux")]
mod webcam;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::commands::device_args::DeviceArgs;
use crate::commands::helpers::{non_negative, positive};
use crate::error::Error;
use crate::progress::Meter;
use joints::Reached;
use lrmcal_core::camera::board;
use lrmcal_core::dataset::{Measurement, Pose, from_home};
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM};
use lrmcal_core::io::{measurements, pose_list};
use lrmcal_engine::camera::detect::TagDetector;
use lrmcal_engine::tracker::listen::{self, Listener};
use lrmcal_engine::tracker::{SettleOptions, Target};
use mover::Mover;
use tracker::{Text, Tracker};

/// Drive the arm through a pose list and record tracker positions.
#[derive(Debug, clap::Args)]
#[command(
    mut_arg("port", |a| a.required(false)),
    group(clap::ArgGroup::new("frame_source").args(["capture", "webcam"])),
    after_help = "Examples:\n  \
lrmcal measure --poses selected.csv --out measured.csv --tracker dtrack://5000 --body 0\n  \
lrmcal measure --poses selected.csv --out measured.csv --load-kg 0.0663 --port /dev/ttyACM0\n  \
tracker-export | lrmcal measure --poses selected.csv --out measured.csv --tracker -\n  \
lrmcal measure --poses selected.csv --hold-s 3    # while Motive records a take\n  \
arm-controller | lrmcal measure --joints - --out measured.csv --tracker dtrack://5000 --body 0\n\n\
With --tracker dtrack://[ADDR:]PORT, set DTrack's output to send `6d` (or \
`3d`) by UDP to this machine and PORT. After each move and --settle-ms, the last --frames \
frames in which the target is tracked are averaged once none lies farther than \
--max-spread-mm from their mean. Positions stay in DTrack's room frame, in mm.\n\n\
Tracker positions from a file or pipe are millimetres in the world frame, one pose per line: \
`x y z` (or `x,y,z`) in the order of the poses still to measure, or `pose x y z` to name the \
pose. Without --tracker each one is typed at a prompt. Run the same command again after an \
interruption: recorded poses are kept and skipped.\n\n\
Without --port (and LRMCAL_PORT) lrmcal moves nothing: the arm is moved by hand or by its own \
controller. Each pose is announced with its joint angles; with a DTrack stream, press Enter \
(or send a line on standard input) once the arm is there, and the reading waits until it \
holds still; a tracker line from a file, a pipe or the prompt is itself the confirmation.\n\n\
An arm whose controller cannot go exactly to a pose list gives, with --joints, the joint angles \
it reached instead: CSV with the pose list's columns (pose,[load_kg,]q1_deg..q6_deg), one record \
per pose, in place of --poses. From standard input (--joints -) each record is read as it \
arrives and is itself the word that the arm is there: write it once the arm has reached the \
pose, and the position is taken (a DTrack reading still waits until the arm holds still). From \
a file the poses are announced and confirmed as a pose list's. Angles outside the joint limits \
of --arm are refused."
)]
pub struct Args {
    /// Pose list CSV (`pose,[load_kg,]q1_deg..q6_deg`).
    #[arg(long, value_name = "FILE", required_unless_present = "joints")]
    pub poses: Option<PathBuf>,
    /// Joint angles the arm reached, from its own controller, instead of a
    /// pose list: CSV with the pose list's columns, one record per pose;
    /// `-` reads standard input as each record arrives, a record being the
    /// word that the arm is there; a file's poses are announced and
    /// confirmed as a pose list's. Not with --port.
    #[arg(long, value_name = "FILE|-", conflicts_with_all = ["poses", "hold_s"])]
    pub joints: Option<PathBuf>,
    /// The arm whose joint limits the --joints angles must lie within: a
    /// bundled arm's name, an arm description `.toml` or a calibration
    /// `.json` [default: lrm].
    #[arg(
        long,
        value_name = "NAME|FILE",
        requires = "joints",
        conflicts_with = "poses"
    )]
    pub arm: Option<ArmSource>,
    /// Record --joints angles outside the arm's joint limits too (with a
    /// warning) instead of stopping at the first.
    #[arg(long, requires = "joints", conflicts_with = "poses")]
    pub allow_outside_limits: bool,
    /// Measurement CSV to write (extended if it exists).
    #[arg(long, short, value_name = "FILE", required_unless_present = "hold_s")]
    pub out: Option<PathBuf>,
    /// Payload at the tool, kg [default: the list's `load_kg`, else 0].
    #[arg(long, value_name = "KG")]
    pub load_kg: Option<f64>,
    /// Tracker positions: `dtrack://[ADDR:]PORT` (a live ART DTrack stream on this UDP
    /// port), a file, or `-` for standard input [default: typed at a prompt].
    #[arg(long, value_name = "SOURCE", value_parser = TrackerSource::parse)]
    pub tracker: Option<TrackerSource>,
    /// Record nothing: hold each pose this long, s, while a tracker records a take
    /// (import it with `lrmcal import-tracker`).
    #[arg(long, value_name = "S", conflicts_with_all = ["tracker", "out"], value_parser = non_negative)]
    pub hold_s: Option<f64>,
    /// Pause after the arm arrives, before the position is taken, ms.
    #[arg(long, value_name = "MS", default_value_t = 500)]
    pub settle_ms: u64,
    /// A webcam instead of a tracker: the shell command that takes one image
    /// into `{image}` (also `{pose}`, `{load_kg}`), e.g. `ffmpeg -loglevel
    /// error -f v4l2 -video_size 1280x720 -i /dev/video0 -frames:v 1 {image}`;
    /// run once a frame, --capture-frames times a pose and more while the
    /// scene still moves, the sharpest still frame kept and a blurred one
    /// warned of; --out is then the pose list naming the images (`detect
    /// --poses`).
    #[arg(long, value_name = "COMMAND", requires = "images", conflicts_with_all = ["tracker", "joints", "hold_s", "webcam"])]
    pub capture: Option<String>,
    /// A webcam instead of a tracker, read directly (Linux, V4L2): its
    /// device, e.g. `/dev/video0`, opened once and streaming for the whole
    /// run, so its exposure and focus settle once; frames are taken and
    /// kept as with --capture, each kept one written as a grey PNG.
    #[arg(long, value_name = "DEVICE", requires = "images", conflicts_with_all = ["tracker", "joints", "hold_s"])]
    pub webcam: Option<PathBuf>,
    /// With --webcam, the frames' size, px: the size the intrinsics are of.
    #[arg(long, value_name = "WxH", default_value = "1280x720", requires = "webcam", value_parser = frame_size)]
    pub webcam_size: (u32, u32),
    /// With --capture or --webcam, the still frames taken at each pose, the
    /// sharpest kept; up to twice as many are taken while two in a row
    /// differ (the arm still sways). 1 takes one frame, unchecked for motion.
    #[arg(long, value_name = "N", default_value_t = capture::FRAMES, requires = "frame_source", value_parser = clap::value_parser!(u32).range(1..))]
    pub capture_frames: u32,
    /// With --capture or --webcam, the folder the images are written to.
    #[arg(long, value_name = "DIR", requires = "frame_source")]
    pub images: Option<PathBuf>,
    /// With --capture or --webcam, the board (Kalibr aprilgrid YAML) each
    /// image is checked for at once: taken again, up to 3 times, while
    /// fewer than half its tags are found (a blurred or badly lit frame).
    #[arg(long, value_name = "FILE", requires = "frame_source")]
    pub board: Option<PathBuf>,
    /// The board that moves the arm; none: the arm is moved by hand or by its
    /// own controller.
    #[command(flatten)]
    pub device: Option<DeviceArgs>,
    /// How a DTrack stream is read (listed last: its help heading carries on).
    #[command(flatten)]
    pub dtrack: DTrackArgs,
}

/// Where `--tracker` positions come from.
#[derive(Clone, Debug, PartialEq)]
pub enum TrackerSource {
    /// Lines on standard input (`-`).
    Stdin,
    /// Lines of a file.
    File(PathBuf),
    /// A live DTrack stream received on this address.
    DTrack(SocketAddr),
}

impl TrackerSource {
    /// `-`, `dtrack://[ADDR:]PORT`, or a file path.
    pub fn parse(text: &str) -> Result<Self, String> {
        match text {
            "-" => Ok(Self::Stdin),
            t if t.starts_with(listen::SCHEME) => listen::parse_address(t).map(Self::DTrack),
            t => Ok(Self::File(t.into())),
        }
    }
}

/// The options of a DTrack reading.
#[derive(Clone, Debug, clap::Args)]
#[command(next_help_heading = "DTrack (--tracker dtrack://...)")]
pub struct DTrackArgs {
    /// The 6DOF body to read, by its id in DTrack's output (counting from 0).
    #[arg(long, value_name = "ID", conflicts_with = "marker")]
    pub body: Option<u32>,
    /// The single marker (`3d` output) to read instead, by its DTrack id.
    #[arg(long, value_name = "ID")]
    pub marker: Option<u32>,
    /// Frames averaged into each position.
    #[arg(long, value_name = "N", default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    pub frames: u32,
    /// Largest distance of an averaged frame from their mean, mm; more means the arm still moves.
    #[arg(long, value_name = "MM", default_value_t = 0.5, value_parser = positive)]
    pub max_spread_mm: f64,
    /// Frames in a row without the target (out of view, quality <= 0) before giving up.
    #[arg(long, value_name = "N", default_value_t = 120)]
    pub max_lost: usize,
    /// Longest wait for a still position at each pose, s.
    #[arg(long, value_name = "S", default_value_t = 5.0, value_parser = positive)]
    pub tracker_timeout_s: f64,
}

impl DTrackArgs {
    /// The target, or why none was named.
    fn target(&self) -> Result<Target, Error> {
        match (self.body, self.marker) {
            (Some(id), _) => Ok(Target::Body(id)),
            (None, Some(id)) => Ok(Target::Marker(id)),
            (None, None) => Err(Error::DeviceInput {
                what: "read the DTrack stream".into(),
                reason:
                    "name what to read: --body ID (a 6DOF body) or --marker ID (a single marker)"
                        .into(),
            }),
        }
    }

    fn settle(&self) -> SettleOptions {
        SettleOptions {
            frames: self.frames as usize,
            max_spread_m: self.max_spread_mm / 1000.0,
            max_lost_in_row: self.max_lost,
        }
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

/// Where the poses to measure come from, one at a time.
enum Poses {
    /// The pose list's poses not yet recorded, in its order.
    List(std::vec::IntoIter<(Pose, f64)>),
    /// The joint angles the arm's own controller reports it reached.
    Reached(Box<Reached>),
}

impl Poses {
    /// The next pose and load to measure, `None` when there are no more.
    fn next(&mut self, done: &[Measurement], bar: &Meter) -> Result<Option<(Pose, f64)>, Error> {
        match self {
            Self::List(todo) => Ok(todo.next()),
            Self::Reached(reached) => reached.next(done, bar),
        }
    }
}

/// Runs `lrmcal measure`.
pub fn run(args: &Args) -> Result<(), Error> {
    let list = match (&args.poses, &args.joints) {
        (Some(path), None) => Some(read_list(path, args.load_kg)?),
        _ => None,
    };
    // The measurement file gives each joint as the pose list does, or as the
    // arm whose reached angles are streamed moves.
    let mut kinds = list
        .as_ref()
        .map(|(_, units)| units.to_vec())
        .unwrap_or_default();
    let list = list.map(|(poses, _)| poses);
    let out = match (&args.out, args.hold_s, &list, &args.poses) {
        (_, Some(hold_s), Some(poses), Some(path)) => return hold(args, path, poses, hold_s),
        (Some(out), None, _, _) => out,
        _ => {
            return Err(Error::DeviceInput {
                what: "measure".into(),
                reason: "pass --out FILE to record positions, or --hold-s S with --poses to hold \
                         each pose for a recording tracker"
                    .into(),
            });
        }
    };
    if let (Some(source), Some(folder)) = (frame_source(args)?, &args.images) {
        let Some(poses) = &list else {
            return Err(Error::Usage(
                "--capture and --webcam take the images of a pose list: pass --poses".into(),
            ));
        };
        let board = match &args.board {
            Some(path) => Some((
                board::read(path)?,
                TagDetector::new().map_err(|e| Error::Detect {
                    reason: e.to_string(),
                })?,
            )),
            None => None,
        };
        let mut capture = capture::Capture {
            source,
            folder: folder.clone(),
            frames: args.capture_frames,
            board,
        };
        let units = model::PerJoint::from_slice(&kinds).unwrap_or_default();
        let mut mover = Mover::of(args.device.as_ref())?;
        return capture::run(&mut capture, poses, units, out, &mut mover, args.settle_ms);
    }
    let live = args.joints.as_deref() == Some(Path::new(joints::STDIN));
    check_joints(args, live)?;
    let mut done = if out.exists() {
        measurements::read(out)?
    } else {
        Vec::new()
    };
    // (the poses, how many of them: a stream's count is known only at its end)
    let (mut poses, total) = match (list, &args.joints) {
        (Some(list), _) => {
            let todo = remaining(&list, &done);
            (Poses::List(todo.into_iter()), Some(list.len()))
        }
        (None, Some(source)) => {
            let arm = match &args.arm {
                Some(source) => source.load()?.arm,
                None => ArmSource::Bundled(DEFAULT_ARM).load()?.arm,
            };
            kinds = arm.kinds().to_vec();
            let reached = Reached::open(source, arm, args.allow_outside_limits, args.load_kg, out)?;
            (Poses::Reached(Box::new(reached)), None)
        }
        (None, None) => {
            return Err(Error::DeviceInput {
                what: "measure".into(),
                reason: "pass --poses FILE (a pose list) or --joints FILE|- (the angles the arm \
                         reached)"
                    .into(),
            });
        }
    };
    let mut tracker = match &args.tracker {
        None => Tracker::Text(Text::Typed),
        Some(TrackerSource::Stdin) => Tracker::Text(Text::Lines(
            Box::new(std::io::stdin().lock()),
            "standard input".into(),
        )),
        Some(TrackerSource::File(path)) => {
            let file = std::fs::File::open(path).map_err(|source| lrmcal_core::Error::Read {
                path: path.clone(),
                source,
            })?;
            let name = format!("`{}`", path.display());
            Tracker::Text(Text::Lines(Box::new(std::io::BufReader::new(file)), name))
        }
        // Bound before the board moves, so a busy port fails at once.
        Some(TrackerSource::DTrack(addr)) => Tracker::DTrack {
            target: args.dtrack.target()?,
            listener: Listener::bind(*addr)?,
            options: args.dtrack.settle(),
            timeout: seconds(args.dtrack.tracker_timeout_s),
        },
    };
    let mut mover = if live {
        Mover::Reported
    } else {
        Mover::of(args.device.as_ref())?
    };
    // A stream's bar counts the poses come so far.
    let mut measured = match &poses {
        Poses::List(todo) => total.unwrap_or(0) - todo.len(),
        Poses::Reached(_) => done.len(),
    };
    let bar = Meter::new("measuring", total.unwrap_or(measured) as u64, "poses");
    bar.set_position(measured as u64);
    while let Some((pose, load_kg)) = poses.next(&done, &bar)? {
        if total.is_none() {
            bar.set_length(measured as u64 + 1);
        }
        bar.set_label(&format!("pose {}", pose.id));
        let confirm = matches!(tracker, Tracker::DTrack { .. });
        mover.arrive(pose, load_kg, args.settle_ms, confirm, &bar)?;
        let position = tracker.next(pose.id, &bar)?;
        // Appended in the order visited: the file's readers work out from
        // it which way each joint arrived (its backlash's side).
        done.push(Measurement {
            pose,
            load_kg,
            position,
            pixel: None,
            target: None,
            approach: from_home(pose.q.len()),
        });
        measurements::write(out, &done, &kinds)?;
        measured += 1;
        bar.inc(1);
    }
    bar.finish();
    println!("{} poses recorded in {}", done.len(), out.display());
    Ok(())
}

/// The poses of a pose list, each with its load: `--load-kg`, else the list's, else 0.
/// The poses of the list at `path` with their loads, and how the list gives
/// each joint (degrees or mm).
fn read_list(path: &Path, load_kg: Option<f64>) -> Result<ListWithUnits, Error> {
    let listed = pose_list::read_listed(path)?;
    let units = listed.first().map(|l| l.units).unwrap_or_default();
    let poses = listed
        .iter()
        .map(|l| (l.row.pose, load_kg.or(l.row.load_kg).unwrap_or(0.0)))
        .collect();
    Ok((poses, units))
}

/// A pose list's poses with their loads, and its joints' units.
type ListWithUnits = (Vec<(Pose, f64)>, model::PerJoint<model::JointKind>);

/// Refuses what cannot go with `--joints`: the board (it drives its arm to
/// a pose list's angles itself), and with `--joints -` a tracker that also
/// needs standard input.
fn check_joints(args: &Args, live: bool) -> Result<(), Error> {
    if args.joints.is_none() {
        return Ok(());
    }
    let refuse = |reason: &str| {
        Err(Error::DeviceInput {
            what: "measure the angles of --joints".into(),
            reason: reason.into(),
        })
    };
    if args.device.is_some() {
        return refuse(
            "--joints is for an arm our board does not drive, whose controller reports the \
             angles it reached; the board goes to a pose list's angles itself: pass --poses \
             with --port, or drop --port (and unset LRMCAL_PORT)",
        );
    }
    if live && matches!(args.tracker, None | Some(TrackerSource::Stdin)) {
        return refuse(
            "--joints - reads the angles from standard input, so the tracker positions cannot \
             come from there too: pass --tracker dtrack://PORT or --tracker FILE",
        );
    }
    Ok(())
}

/// `--hold-s`: every pose of the list `list` in order, held for `hold_s`, nothing recorded.
fn hold(args: &Args, list: &Path, poses: &[(Pose, f64)], hold_s: f64) -> Result<(), Error> {
    let Some(device) = &args.device else {
        return Err(Error::DeviceInput {
            what: "hold the poses".into(),
            reason: "--hold-s has the board hold each pose: pass --port (an arm moved by hand \
                     or its own controller holds its poses itself)"
                .into(),
        });
    };
    let mut mover = Mover::Board {
        client: Box::new(device.connect()?),
        load_now: None,
    };
    let bar = Meter::new("measuring", poses.len() as u64, "poses");
    for &(pose, load_kg) in poses {
        bar.set_label(&format!("holding pose {}", pose.id));
        mover.arrive(pose, load_kg, args.settle_ms, false, &bar)?;
        std::thread::sleep(seconds(hold_s));
        bar.inc(1);
    }
    bar.finish();
    println!(
        "{} poses held {hold_s} s each; stop the take, export it as CSV and run \
         `lrmcal import-tracker --poses {}` on it",
        poses.len(),
        list.display()
    );
    Ok(())
}

/// Where `measure`'s images come from: `--capture`'s command or
/// `--webcam`'s device, opened; none without either.
fn frame_source(args: &Args) -> Result<Option<capture::Source>, Error> {
    if let Some(command) = &args.capture {
        return Ok(Some(capture::Source::Command(command.clone())));
    }
    let Some(device) = &args.webcam else {
        return Ok(None);
    };
    #[cfg(target_os = "linux")]
    {
        let (width, height) = args.webcam_size;
        Ok(Some(capture::Source::Webcam(webcam::Webcam::open(
            device, width, height,
        )?)))
    }
    #[cfg(not(target_os = "linux"))]
    Err(Error::Webcam {
        device: device.clone(),
        reason: "a webcam is read directly on Linux only (V4L2); here pass --capture with a \
                 command that writes a frame, e.g. ffmpeg's"
            .into(),
    })
}

/// `--webcam-size`: `WIDTHxHEIGHT` in pixels.
fn frame_size(text: &str) -> Result<(u32, u32), String> {
    let expected = || format!("`{text}`: expected WIDTHxHEIGHT in pixels, e.g. 1280x720");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(expected)?;
    match (w.trim().parse::<u32>(), h.trim().parse::<u32>()) {
        (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(expected()),
    }
}

/// A duration from a checked number of seconds (>= 0); beyond `Duration`'s range, forever.
fn seconds(s: f64) -> Duration {
    Duration::try_from_secs_f64(s).unwrap_or(Duration::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;
    use model::testing::TEST_ARM_JOINTS as JOINTS;
    use nalgebra::Vector3;

    #[test]
    fn frame_sizes_read_as_width_by_height() {
        assert_eq!(frame_size("1280x720"), Ok((1280, 720)));
        assert_eq!(frame_size("640X480"), Ok((640, 480)));
        for bad in ["1280", "0x720", "x", "1280x-1", "wide x high"] {
            let e = frame_size(bad).unwrap_err();
            assert!(e.contains("WIDTHxHEIGHT"), "{bad}: {e}");
        }
    }

    #[test]
    fn tracker_sources_by_their_form() {
        assert_eq!(TrackerSource::parse("-"), Ok(TrackerSource::Stdin));
        assert_eq!(
            TrackerSource::parse("dtrack://5000"),
            Ok(TrackerSource::DTrack("0.0.0.0:5000".parse().unwrap()))
        );
        assert_eq!(
            TrackerSource::parse("points.txt"),
            Ok(TrackerSource::File("points.txt".into()))
        );
        let err = TrackerSource::parse("dtrack://port5000").unwrap_err();
        assert!(err.contains("expected `dtrack://PORT`"), "{err}");
    }

    #[test]
    fn resuming_skips_recorded_pose_and_load_pairs() {
        let pose = |id| Pose {
            id,
            q: [0.0; JOINTS].into(),
        };
        let poses = vec![(pose(1), 0.0), (pose(2), 0.0), (pose(1), 0.0663)];
        let done = vec![Measurement {
            pose: pose(1),
            load_kg: 0.0,
            position: Vector3::zeros(),
            pixel: None,
            target: None,
            approach: from_home(JOINTS),
        }];
        let left: Vec<(u32, f64)> = remaining(&poses, &done)
            .iter()
            .map(|(p, l)| (p.id, *l))
            .collect();
        assert_eq!(left, vec![(2, 0.0), (1, 0.0663)]);
    }
}
