//! Fuzzing the file parsers: arm descriptions, measurement and
//! pose-list CSVs, calibration files, camera intrinsics and board files,
//! mutated from valid files and read
//! through the same `read` functions the commands use.
//!
//! Every input is written to a file and read back, and the result is held to
//! the [`Invariant`]s: no panic; a refusal is an [`Error::Parse`] whose
//! message names the file and a line or a key, the line inside the file;
//! what is accepted holds finite numbers only; a pose list read record by
//! record as it arrives (`measure --joints -`) is read as the whole file
//! is. The valid files the
//! mutations start from ([`Corpus`]) are the bundled arm (as shipped, as
//! `lrmcal` writes it, and with collision bodies), what the simulator
//! writes, pose lists with and without loads, a calibration file the
//! demo wrote, a ROS `camera_info` file and OpenCV's own calibration file,
//! and a Kalibr board file. Input `K` of a format under a seed is made from the seed, the
//! format and `K` alone, so any one can be made again
//! (`examples/fuzz_parsers.rs` runs the campaign; `tests/fuzz_parsers.rs` a
//! short one).

pub mod mutate;

use std::cell::RefCell;
use std::fmt;
use std::panic::{self, AssertUnwindSafe};
use std::path::Path;

use model::Arm;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use lrmcal_core::Error;
use lrmcal_core::camera::{board, intrinsics_file};
use lrmcal_core::dataset::{Pose, PoseRow};
use lrmcal_core::io::arm_source::{BUNDLED, DEFAULT_ARM, bundled};
use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_core::io::{arm_toml, measurements, pose_list};
use lrmcal_engine::sim::{SimConfig, TrueArm};

/// A kind of file the fuzzer feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// An arm description (TOML), read by `arm_toml::read`.
    Arm,
    /// A measurement file (CSV), read by `measurements::read`.
    Measurements,
    /// A pose list (CSV), read by `pose_list::read_listed`.
    Poses,
    /// A calibration file (JSON), read by `CalibrationFile::read`.
    Calibration,
    /// Camera intrinsics (YAML), read by `camera::intrinsics_file::read`.
    Intrinsics,
    /// A board of AprilTags (YAML), read by `camera::board::read`.
    Board,
}

impl Format {
    /// Every format, in campaign order.
    pub const ALL: [Format; 6] = [
        Format::Arm,
        Format::Measurements,
        Format::Poses,
        Format::Calibration,
        Format::Intrinsics,
        Format::Board,
    ];

    /// The name used on the command line (`--case arm:17`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Arm => "arm",
            Self::Measurements => "measurements",
            Self::Poses => "poses",
            Self::Calibration => "calibration",
            Self::Intrinsics => "intrinsics",
            Self::Board => "board",
        }
    }

    /// The format of a name, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The file name inputs are written under (the extension a user's file has).
    pub fn file_name(self) -> &'static str {
        match self {
            Self::Arm => "arm.toml",
            Self::Measurements => "measured.csv",
            Self::Poses => "poses.csv",
            Self::Calibration => "calibration.json",
            Self::Intrinsics => "camera_info.yaml",
            Self::Board => "board.yaml",
        }
    }

    fn index(self) -> u64 {
        self as u64
    }
}

/// A calibration file as this lrmcal writes it (`lrmcal identify` of the
/// simulated bundled arm, 50 poses, elasto-kinematic, registered).
const CALIBRATION: &str = include_str!("calibration.json");
/// A calibration file of schema 1, as an older lrmcal wrote it (read through
/// the upgrade path).
const CALIBRATION_SCHEMA_1: &str = include_str!("calibration-schema-1.json");

/// A webcam's intrinsics as ROS's camera calibrator saves them.
const CAMERA_INFO: &str = include_str!("../../core/arms/lrm-webcam/camera_info.yaml");

/// Intrinsics as OpenCV's FileStorage writes them (cv2.FileStorage of
/// OpenCV 5, the file the projection is checked against).
const OPENCV_CALIBRATION: &str =
    include_str!("../../core/tests/data/camera/opencv_calibration.yaml");

/// A Kalibr board file with lrmcal's two optional keys.
const BOARD: &str = "target_type: 'aprilgrid'
tagCols: 4
tagRows: 3
tagSize: 0.025
tagSpacing: 0.3
firstId: 10
tagFamily: tag36h11
";

/// Collision settings and bodies of every kind, appended to the bundled arm.
const BODIES: &str = r#"
[collision]
clearance = 0.01
floor = 0.0
ignore = [["base", "upper arm"]]

[[body]]
name = "base"
capsule = { from = "base", to = "j1", radius = 0.04 }

[[body]]
name = "upper arm"
capsule = { from = "j1", to = { frame = "j2", xyz = [0.0, 0.0, 0.01] }, radius = 0.025 }

[[body]]
name = "hand"
box = { frame = "j6", min = [-0.02, -0.02, -0.01], max = [0.02, 0.02, 0.03] }
floor = false
"#;

/// The valid files the mutations start from, per format.
#[derive(Clone, Debug)]
pub struct Corpus {
    examples: [Vec<Vec<u8>>; 6],
}

impl Corpus {
    /// The standard set; an error if one of them is no longer valid (the
    /// formats changed and the corpus was not regrown).
    pub fn new() -> Result<Self, String> {
        let broken = |what: &str, e: Error| {
            format!("the fuzz corpus's {what}: {}", crate::error::report(&e))
        };
        let (_, shipped) = BUNDLED
            .iter()
            .find(|(name, _)| *name == DEFAULT_ARM)
            .ok_or("no bundled default arm")?;
        let description = bundled(DEFAULT_ARM).map_err(|e| broken("bundled arm", e))?;
        let arms = vec![
            shipped.as_bytes().to_vec(),
            arm_toml::to_toml(&description).into_bytes(),
            format!("{shipped}{BODIES}").into_bytes(),
        ];
        let poses = spread_poses(&description.arm);
        let measured = TrueArm::draw(&description.arm, 1, &SimConfig::default())
            .and_then(|t| t.measure(&poses, &[0.0, 0.0663]))
            .map_err(|e| format!("the fuzz corpus's simulated measurements: {e}"))?;
        let mut measurement_file = Vec::new();
        measurements::write_to(&mut measurement_file, &measured, &description.arm.kinds())
            .map_err(|e| format!("the fuzz corpus's measurement file: {e}"))?;
        let listed = |load_kg: Option<f64>| -> Result<Vec<u8>, String> {
            let rows: Vec<PoseRow> = poses
                .iter()
                .map(|&pose| PoseRow { pose, load_kg })
                .collect();
            let mut out = Vec::new();
            pose_list::write_to(&mut out, &rows, &description.arm.kinds())
                .map_err(|e| format!("the fuzz corpus's pose list: {e}"))?;
            Ok(out)
        };
        let corpus = Self {
            examples: [
                arms,
                vec![measurement_file],
                vec![listed(None)?, listed(Some(0.0663))?],
                vec![
                    CALIBRATION.as_bytes().to_vec(),
                    CALIBRATION_SCHEMA_1.as_bytes().to_vec(),
                ],
                vec![
                    CAMERA_INFO.as_bytes().to_vec(),
                    OPENCV_CALIBRATION.as_bytes().to_vec(),
                ],
                vec![BOARD.as_bytes().to_vec()],
            ],
        };
        let dir = scratch_dir().map_err(|e| format!("a temporary directory: {e}"))?;
        for format in Format::ALL {
            let path = dir.path().join(format.file_name());
            for (i, example) in corpus.examples(format).iter().enumerate() {
                match check(format, &path, example) {
                    Ok(Outcome::Accepted) => {}
                    Ok(Outcome::Refused(e)) => {
                        return Err(broken(&format!("{} example {i}", format.name()), e));
                    }
                    Err(v) => return Err(format!("{} example {i}: {v}", format.name())),
                }
            }
        }
        Ok(corpus)
    }

    /// The valid files of `format`.
    pub fn examples(&self, format: Format) -> &[Vec<u8>] {
        &self.examples[format.index() as usize]
    }

    /// Input `index` of `format` under `seed`: a valid file of the format
    /// after one to four mutations, from its own random stream.
    pub fn input(&self, format: Format, seed: u64, index: u64) -> Vec<u8> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(index << 3 | format.index());
        let examples = self.examples(format);
        let start = &examples[(index % examples.len() as u64) as usize];
        mutate::mutate(&mut rng, start, examples)
    }
}

/// Poses spread over the joint ranges (ids 0…), as a planner or a user lists them.
fn spread_poses(arm: &Arm<f64>) -> Vec<Pose> {
    let fractions = [-0.8, -0.3, 0.0, 0.4, 0.9];
    (0..12u32)
        .map(|id| Pose {
            id: id * 7 + 3,
            q: model::PerJoint::from_fn(arm.joints.len(), |j| {
                let [lo, hi] = arm.joints[j].limits;
                let f = fractions[(id as usize + 2 * j) % fractions.len()];
                lo + (hi - lo) * (f + 1.0) / 2.0
            }),
        })
        .collect()
}

/// A temporary directory for the inputs: in memory (`/dev/shm`) where the
/// system has one, since every input is written and read back; else the
/// system's temporary directory.
pub fn scratch_dir() -> std::io::Result<tempfile::TempDir> {
    let shm = Path::new("/dev/shm");
    if shm.is_dir()
        && let Ok(dir) = tempfile::tempdir_in(shm)
    {
        return Ok(dir);
    }
    tempfile::tempdir()
}

/// What a reader made of an input that held every invariant.
#[derive(Debug)]
pub enum Outcome {
    /// Read and checked.
    Accepted,
    /// Refused with this error.
    Refused(Error),
}

/// A property every read must have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Invariant {
    /// The reader does not panic.
    NoPanic,
    /// A refusal is about the file's content (`Error::Parse`), not another kind of error.
    ContentError,
    /// A refusal's message names the file.
    NamesFile,
    /// A refusal names a line or a key.
    NamesPlace,
    /// A refusal's line is a line of the file.
    LineInFile,
    /// What is accepted holds finite numbers only.
    Finite,
    /// A pose list read record by record is accepted with the same poses,
    /// or refused, as the whole file.
    SameStreamed,
}

impl fmt::Display for Invariant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::NoPanic => "no panic",
            Self::ContentError => "a refusal is an error of the file's content",
            Self::NamesFile => "a refusal names the file",
            Self::NamesPlace => "a refusal names a line or a key",
            Self::LineInFile => "a refusal's line is in the file",
            Self::Finite => "what is accepted is finite",
            Self::SameStreamed => "a pose list reads the same record by record",
        })
    }
}

/// A broken invariant and what was seen.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Violation {
    /// Which.
    pub invariant: Invariant,
    /// The panic message, the error's message, or the value that is not finite.
    pub detail: String,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "\"{}\" broken: {}", self.invariant, self.detail)
    }
}

thread_local! {
    /// The message of this thread's last panic, kept by [`keep_panic_messages`].
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Replaces the panic hook by one that keeps the message (with its place)
/// for [`check`] to report, instead of printing it for every caught panic.
pub fn keep_panic_messages() {
    panic::set_hook(Box::new(|info| {
        PANIC.with(|p| *p.borrow_mut() = Some(info.to_string()));
    }));
}

/// Writes `bytes` to `path` (named as `format` files are), reads it with the
/// format's reader and checks every [`Invariant`].
pub fn check(format: Format, path: &Path, bytes: &[u8]) -> Result<Outcome, Violation> {
    std::fs::write(path, bytes).map_err(|e| Violation {
        invariant: Invariant::ContentError,
        detail: format!("the input could not be written to {}: {e}", path.display()),
    })?;
    let read = panic::catch_unwind(AssertUnwindSafe(|| read(format, path)));
    let result = read.map_err(|payload| {
        let kept = PANIC.with(|p| p.borrow_mut().take());
        let message = kept
            .or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_owned()))
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic".into());
        Violation {
            invariant: Invariant::NoPanic,
            detail: message,
        }
    })?;
    match result {
        Ok(None) => Ok(Outcome::Accepted),
        Ok(Some(violation)) => Err(violation),
        Err(e) => refusal(path, bytes, e).map(Outcome::Refused),
    }
}

/// Checks a refusal's message against the invariants.
fn refusal(path: &Path, bytes: &[u8], error: Error) -> Result<Error, Violation> {
    let report = crate::error::report(&error);
    let broken = |invariant| {
        Err(Violation {
            invariant,
            detail: report.clone(),
        })
    };
    let Error::Parse { source, .. } = &error else {
        return broken(Invariant::ContentError);
    };
    if !report.contains(&path.display().to_string()) {
        return broken(Invariant::NamesFile);
    }
    let location = &source.location;
    if location.line.is_none() && location.field.is_none() {
        return broken(Invariant::NamesPlace);
    }
    // A line is ended by `\n`, `\r\n` or a lone `\r` (readers count all three);
    // an error at the end of the file may name the line after the last break.
    let breaks = bytes
        .iter()
        .enumerate()
        .filter(|&(i, &b)| b == b'\n' || (b == b'\r' && bytes.get(i + 1) != Some(&b'\n')))
        .count() as u64;
    if location.line.is_some_and(|l| l == 0 || l > breaks + 1) {
        return broken(Invariant::LineInFile);
    }
    Ok(error)
}

/// Reads `path` as `format`: `Some` is an accepted file that breaks an
/// invariant (a value that is not finite, a pose list read otherwise
/// record by record).
fn read(format: Format, path: &Path) -> Result<Option<Violation>, Error> {
    let finite = |value: Option<String>| {
        value.map(|detail| Violation {
            invariant: Invariant::Finite,
            detail,
        })
    };
    Ok(finite(match format {
        Format::Arm => {
            let d = arm_toml::read(path)?;
            not_finite(arm_values("arm", &d.arm))
        }
        Format::Measurements => {
            let rows = measurements::read(path)?;
            not_finite(rows.iter().flat_map(|m| {
                let id = m.pose.id;
                pose_values(&m.pose)
                    .chain([("load_kg".into(), m.load_kg)])
                    .chain(m.position.iter().map(|&p| ("position".into(), p)))
                    .map(move |(what, v)| (format!("pose {id} {what}"), v))
            }))
        }
        Format::Poses => {
            let whole = pose_list::read_listed(path);
            if let Some(violation) = streamed_otherwise(path, &whole) {
                return Ok(Some(violation));
            }
            let rows = whole?;
            not_finite(rows.iter().flat_map(|l| {
                let id = l.row.pose.id;
                pose_values(&l.row.pose)
                    .chain(l.row.load_kg.map(|k| ("load_kg".into(), k)))
                    .map(move |(what, v)| (format!("pose {id} {what}"), v))
            }))
        }
        Format::Calibration => {
            let file = CalibrationFile::read(path)?;
            let params = file.parameters.iter().flat_map(|p| {
                [
                    (format!("{}.error", p.name), p.error),
                    (format!("{}.value", p.name), p.value),
                    (format!("{}.std", p.name), p.std.unwrap_or(0.0)),
                ]
            });
            not_finite(
                &mut arm_values("nominal", &file.nominal)
                    .chain(arm_values("arm", &file.arm))
                    .chain(params)
                    .chain(file.loads_kg.iter().map(|&k| ("loads_kg".into(), k))),
            )
        }
        Format::Intrinsics => {
            let c = intrinsics_file::read(path)?;
            not_finite(
                [("fx", c.fx), ("fy", c.fy), ("cx", c.cx), ("cy", c.cy)]
                    .into_iter()
                    .chain(c.distortion.map(|k| ("distortion", k)))
                    .map(|(what, v)| (what.to_string(), v)),
            )
        }
        Format::Board => {
            let b = board::read(path)?;
            not_finite(
                [("tagSize", b.tag_size_m), ("tagSpacing", b.spacing)]
                    .into_iter()
                    .map(|(what, v)| (what.to_string(), v)),
            )
        }
    }))
}

/// How the pose list at `path`, read record by record as `measure
/// --joints` reads it, differs from `whole`, the whole file's reading: other
/// poses, or accepted by one and refused by the other.
fn streamed_otherwise(
    path: &Path,
    whole: &Result<Vec<pose_list::ListedPose>, Error>,
) -> Option<Violation> {
    let streamed = (|| {
        let file = std::fs::File::open(path).map_err(|source| Error::Read {
            path: path.to_owned(),
            source,
        })?;
        let mut stream = pose_list::PoseStream::new(std::io::BufReader::new(file), path);
        let mut poses = Vec::new();
        while let Some(pose) = stream.next_pose()? {
            poses.push(pose);
        }
        Ok::<_, Error>(poses)
    })();
    let detail = match (whole, &streamed) {
        (Ok(a), Ok(b)) if a == b => return None,
        (Err(_), Err(_)) => return None,
        (Ok(a), Ok(b)) => format!("{} poses whole, {} record by record", a.len(), b.len()),
        (Ok(_), Err(e)) => format!("accepted whole, refused record by record: {}", e.report()),
        (Err(e), Ok(_)) => format!("refused whole ({}), accepted record by record", e.report()),
    };
    Some(Violation {
        invariant: Invariant::SameStreamed,
        detail,
    })
}

/// The first value of `values` that is not finite, with its name.
fn not_finite(mut values: impl Iterator<Item = (String, f64)>) -> Option<String> {
    values
        .find(|(_, v)| !v.is_finite())
        .map(|(what, v)| format!("{what} = {v}"))
}

/// A pose's joint angles, named.
fn pose_values(pose: &Pose) -> impl Iterator<Item = (String, f64)> + '_ {
    pose.q
        .iter()
        .enumerate()
        .map(|(j, &q)| (format!("q{}", j + 1), q))
}

/// Every number of an arm, named.
fn arm_values<'a>(which: &'a str, arm: &'a Arm<f64>) -> impl Iterator<Item = (String, f64)> + 'a {
    let whole = [
        arm.gravity.as_slice(),
        &arm.base.xyz,
        &arm.base.rpy,
        &[arm.base_compliance],
        &arm.tool.xyz,
        &arm.tool.rpy,
        &arm.payload_com,
    ]
    .concat();
    let joints = arm.joints.iter().enumerate().flat_map(move |(i, j)| {
        [
            j.theta,
            j.d,
            j.a,
            j.alpha,
            j.compliance,
            j.limits[0],
            j.limits[1],
            j.mass,
            j.com[0],
            j.com[1],
            j.com[2],
        ]
        .into_iter()
        .chain(j.servo.iter().flat_map(|c| c.angles_rad().iter().copied()))
        .chain(j.servo.iter().flat_map(|c| c.pulses_us().iter().copied()))
        .map(move |v| (format!("{which} joint {}", i + 1), v))
        .collect::<Vec<_>>()
    });
    whole
        .into_iter()
        .map(move |v| (which.to_owned(), v))
        .chain(joints)
}

/// Tallies of a campaign over one format.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Inputs read.
    pub inputs: u64,
    /// Accepted.
    pub accepted: u64,
    /// Refused naming a line and a key or column.
    pub line_and_field: u64,
    /// Refused naming a line only.
    pub line_only: u64,
    /// Refused naming a key only (JSON values checked after parsing).
    pub field_only: u64,
}

impl Counts {
    /// Adds one outcome.
    pub fn add(&mut self, outcome: &Outcome) {
        self.inputs += 1;
        match outcome {
            Outcome::Accepted => self.accepted += 1,
            Outcome::Refused(Error::Parse { source, .. }) => {
                match (source.location.line, &source.location.field) {
                    (Some(_), Some(_)) => self.line_and_field += 1,
                    (Some(_), None) => self.line_only += 1,
                    _ => self.field_only += 1,
                }
            }
            // `check` lets no other refusal through.
            Outcome::Refused(_) => {}
        }
    }

    /// Adds another tally.
    pub fn merge(&mut self, other: &Counts) {
        self.inputs += other.inputs;
        self.accepted += other.accepted;
        self.line_and_field += other.line_and_field;
        self.line_only += other.line_only;
        self.field_only += other.field_only;
    }
}

/// Runs inputs `range` of `format` under `seed` in `dir`, stopping at the
/// first violation (its input index and the violation).
pub fn run(
    corpus: &Corpus,
    format: Format,
    seed: u64,
    range: std::ops::Range<u64>,
    dir: &Path,
    counts: &mut Counts,
) -> Result<(), (u64, Violation)> {
    let path = dir.join(format.file_name());
    for index in range {
        let input = corpus.input(format, seed, index);
        let outcome = check(format, &path, &input).map_err(|v| (index, v))?;
        counts.add(&outcome);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use lrmcal_core::error::{InputError, Location, Problem};

    /// Each refusal that breaks an invariant is caught, and the right one named.
    #[test]
    fn refusals_without_file_place_or_real_line_are_violations() {
        let path = Path::new("/tmp/poses.csv");
        let bytes = b"pose\n1\n";
        let at = |location| InputError::new(location, Problem::NoRows);
        let broken = |e| refusal(path, bytes, e).map(|_| ()).unwrap_err().invariant;
        assert_eq!(
            broken(at(Location::default()).in_file(path)),
            Invariant::NamesPlace
        );
        assert_eq!(
            broken(at(Location::line(1)).in_file("other.csv")),
            Invariant::NamesFile
        );
        assert_eq!(
            broken(at(Location::line(4)).in_file(path)),
            Invariant::LineInFile
        );
        let read = Error::Read {
            path: path.to_owned(),
            source: std::io::Error::other("gone"),
        };
        assert_eq!(broken(read), Invariant::ContentError);
        assert!(refusal(path, bytes, at(Location::line(3)).in_file(path)).is_ok());
        assert!(refusal(path, bytes, at(Location::key(None, "pose")).in_file(path)).is_ok());
    }

    #[test]
    fn inputs_are_made_from_seed_format_and_index_alone() {
        let corpus = Corpus::new().unwrap();
        let a = corpus.input(Format::Poses, 5, 1234);
        assert_eq!(a, corpus.input(Format::Poses, 5, 1234));
        assert_ne!(a, corpus.input(Format::Poses, 5, 1235));
        assert_ne!(a, corpus.input(Format::Measurements, 5, 1234));
    }
}
