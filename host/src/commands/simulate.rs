//! `lrmcal simulate`: measurements of a simulated real arm (the digital twin),
//! to try a calibration without hardware and to check it against the truth.

use std::path::{Path, PathBuf};

use crate::commands::helpers::write_text;
use crate::error::Error;
use crate::progress::Meter;
use lrmcal_core::camera::setup;
use lrmcal_core::camera::shots::{self, Shot};
use lrmcal_core::camera::views;
use lrmcal_core::dataset::{Measurement, Pose};
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM, LoadedArm};
use lrmcal_core::io::{measurements, pose_list};
use lrmcal_engine::calib::Sample;
use lrmcal_engine::calib::results::export::rig_of;
use lrmcal_engine::plan::{DEFAULT_RANDOM_POSES, PlanConfig, candidates};
use lrmcal_engine::sim::render::Look;
use lrmcal_engine::sim::{
    DEFAULT_PIXEL_NOISE_PX, DEFAULT_SEED, Pass, ServoErrorShape, SimConfig, TrueArm, Watched,
    Webcam,
};
use model::{JointKind, PerJoint};
use rayon::prelude::*;

/// The paper's two data sets: no load, and a 66.3 g weight on the target.
const DEFAULT_LOADS_KG: [f64; 2] = [0.0, 0.0663];

/// Simulate tracker measurements of a real arm drawn around the nominal one.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "The \"true\" arm is drawn (seeded) around the nominal one: errors on every \
DH, base and tool parameter, joint and base compliances, and \
effects the calibration model does not contain (a smooth servo angle error, direction-dependent \
play, stiffness that softens with load, tracker noise), each switchable. The softening is the \
form the calibration model fits; --stiffening-per-nm gives springs that stiffen with load in a \
form it does not contain, --servo-error-shape harmonics a servo error with sharper \
features between the tuned points, and --parallel-twist-deg a tilt between parallel joint axes \
that the paper's DH parameters cannot hold.\n\n\
Every pose is measured under every load. Per load the poses are visited in the order of the \
list, starting from home (all joints at 0), and each joint's play depends on the direction it \
last moved in. The same seed and settings give byte-identical files.\n\n\
The compliance ranges and the softening default to a printed arm's (the bundled one's), \
scaled by the ratio of its largest gravity torque to your arm's: an industrial arm then sags \
by the same angles under its own weight, not a thousand times more.\n\n\
Examples:\n  \
lrmcal simulate --out measurements.csv --truth truth.json\n  \
lrmcal simulate --poses selection.csv --loads 0.0663 --seed 7 --out m.csv\n  \
lrmcal simulate --model-only --out exact.csv      # the paper's model exactly, no noise\n  \
lrmcal simulate --noise-mm 0.5 --backlash-deg 0 --out m.csv\n  \
lrmcal simulate --stiffening-per-nm 0.4 --servo-error-shape harmonics --out m.csv\n  \
lrmcal simulate --camera setup.toml --poses seen.csv --out corners.csv --truth truth.json\n\n\
Without --poses the candidates of `lrmcal plan` (its defaults) are measured. The truth file \
(JSON, SI units) holds the true arm and its errors by name (`j3.d`, `base.pitch`, `k2`, ...: 43 \
for six joints, and `j2.beta` and the like when --parallel-twist-deg draws the twists); \
--noise-free writes the same rows as --out without tracker noise. On stderr: the mean distance \
between the nominal (rigid) model's prediction and the measurement, per load.\n\n\
With --camera SETUP.toml a webcam measures instead of a tracker: the camera and the board stand \
where the setup tells them, off by drawn errors (20 mm and 2° per axis for the camera, 2 mm and \
1° for the board; the truth file's `webcam` says where), and --out gets the board's tag corners \
the camera sees at each pose, with --pixel-noise-px of noise (camera measurement CSV, \
docs/FORMATS.md). Poses where it does not see the whole board, facing it, are left out \
(`lrmcal plan --camera` plans the ones it sees)."
)]
pub struct Args {
    /// The nominal arm: a bundled arm's name, an arm description `.toml` file, or a
    /// URDF `.urdf` file (its chain from --base-link to --tip-link).
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Poses to measure, a pose-list CSV [default: the planner's candidates].
    #[arg(long, value_name = "FILE")]
    pub poses: Option<PathBuf>,
    /// Loads at the tool, kg, comma-separated; every pose is measured with each
    /// [default: the list's `load_kg` column if it has one, else 0,0.0663].
    #[arg(long, value_name = "KG,...", value_delimiter = ',', allow_negative_numbers = true, value_parser = parse_load)]
    pub loads: Option<Vec<f64>>,
    /// Seed of the true arm and of the tracker noise.
    #[arg(long, default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// Where to write the measurements CSV [default: standard output].
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Where to write the truth file: true arm and its 43 errors by name (JSON).
    #[arg(long, value_name = "FILE")]
    pub truth: Option<PathBuf>,
    /// Where to write the positions without tracker noise (measurement CSV;
    /// with --camera, the corners without pixel noise).
    #[arg(long, value_name = "FILE")]
    pub noise_free: Option<PathBuf>,
    /// A webcam measures instead of a tracker: the camera setup (TOML) it
    /// stands as, roughly; --out gets the corners it sees (camera measurement CSV).
    #[arg(long, value_name = "SETUP")]
    pub camera: Option<PathBuf>,
    /// With --camera, the webcam takes images instead of telling corners:
    /// DIR gets one PNG of the board at each pose it sees and `poses.csv`,
    /// the pose list naming them (what `lrmcal detect --poses` reads).
    #[arg(long, value_name = "DIR", requires = "camera", conflicts_with_all = ["out", "pixel_noise_px"])]
    pub images: Option<PathBuf>,
    /// Sigma of the corners' noise on each pixel axis, px (with --camera).
    #[arg(long, value_name = "PX", requires = "camera", default_value_t = DEFAULT_PIXEL_NOISE_PX, allow_negative_numbers = true, value_parser = non_negative)]
    pub pixel_noise_px: f64,
    /// How the true arm differs and which effects are on.
    #[command(flatten)]
    pub sim: SimArgs,
}

/// The simulator's settings in the units people think in (mm, degrees).
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "True arm and effects (0 switches an effect off)")]
pub struct SimArgs {
    /// Sigma of the DH length errors (d, a), mm.
    #[arg(long, value_name = "MM", default_value_t = mm(SimConfig::default().dh_length_sigma_m), allow_negative_numbers = true, value_parser = non_negative)]
    pub dh_length_sigma_mm: f64,
    /// Sigma of the DH angle errors (theta, alpha), degrees.
    #[arg(long, value_name = "DEG", default_value_t = deg(SimConfig::default().dh_angle_sigma_rad), allow_negative_numbers = true, value_parser = non_negative)]
    pub dh_angle_sigma_deg: f64,
    /// Sigma of the base and tool translation errors, mm.
    #[arg(long, value_name = "MM", default_value_t = mm(SimConfig::default().frame_length_sigma_m), allow_negative_numbers = true, value_parser = non_negative)]
    pub frame_length_sigma_mm: f64,
    /// Sigma of the base and tool rotation errors, degrees.
    #[arg(long, value_name = "DEG", default_value_t = deg(SimConfig::default().frame_angle_sigma_rad), allow_negative_numbers = true, value_parser = non_negative)]
    pub frame_angle_sigma_deg: f64,
    /// Range the six joint compliances are drawn from (log-uniform), rad/Nm
    /// [default: 0.08,0.2 on the bundled arm, scaled to another arm's torques].
    #[arg(long, value_name = "LO,HI")]
    pub joint_compliance: Option<Range>,
    /// Range the base compliance is drawn from (log-uniform), rad/Nm
    /// [default: 0.01,0.03 on the bundled arm, scaled to another arm's torques].
    #[arg(long, value_name = "LO,HI")]
    pub base_compliance: Option<Range>,
    /// Servo angle error that is not piecewise-linear (its amplitude; the
    /// shape is --servo-error-shape's), degrees.
    #[arg(long, value_name = "DEG", default_value_t = deg(SimConfig::default().servo_error_rad), allow_negative_numbers = true, value_parser = non_negative)]
    pub servo_error_deg: f64,
    /// Shape of each servo's angle error: sine-cubic (a bow and one slow wave,
    /// period 120-240°) or harmonics (the wave with its 2nd and 3rd
    /// harmonics, periods down to 40°: a potentiometer track's nonlinearity).
    #[arg(long, value_name = "SHAPE", default_value = "sine-cubic", value_parser = servo_shape())]
    pub servo_error_shape: ServoErrorShape,
    /// Full width of each joint's direction-dependent play, degrees.
    #[arg(long, value_name = "DEG", default_value_t = deg(SimConfig::default().backlash_rad), allow_negative_numbers = true, value_parser = non_negative)]
    pub backlash_deg: f64,
    /// Stiffness softening: compliance k becomes k (1 + s |torque|), s in 1/Nm
    /// [default: 0.3 on the bundled arm, scaled to another arm's torques].
    #[arg(long, value_name = "S", allow_negative_numbers = true, value_parser = non_negative)]
    pub softening_per_nm: Option<f64>,
    /// Stiffening springs instead of softening ones: compliance k becomes
    /// k / (1 + c |torque|), c in 1/Nm, on every joint and the base (a form
    /// the calibration model does not contain) [default: off].
    #[arg(long, value_name = "C", allow_negative_numbers = true, value_parser = non_negative, conflicts_with = "softening_per_nm")]
    pub stiffening_per_nm: Option<f64>,
    /// Sigma of the tilt between nominally parallel joint axes that DH cannot
    /// say (Hayati's twist, across both axes; DH's alpha tilts them about their
    /// common normal), degrees [default: 0, the axes tilt only as DH says].
    #[arg(long, value_name = "DEG", default_value_t = 0.0, allow_negative_numbers = true, value_parser = non_negative)]
    pub parallel_twist_deg: f64,
    /// Sigma of the tracker noise on each axis, mm.
    #[arg(long, value_name = "MM", default_value_t = mm(SimConfig::default().noise_sigma_m), allow_negative_numbers = true, value_parser = non_negative)]
    pub noise_mm: f64,
    /// Switch off servo error, play, softening and noise: measurements are then
    /// exactly the calibration model's prediction for the true arm.
    #[arg(long, conflicts_with_all = ["servo_error_deg", "servo_error_shape", "backlash_deg", "softening_per_nm", "stiffening_per_nm", "noise_mm"])]
    pub model_only: bool,
}

impl SimArgs {
    /// The simulator configuration these flags describe for `nominal` (SI
    /// units); what they leave out is [`SimConfig::scaled_to`] `nominal`.
    pub fn config(&self, nominal: &model::Arm<f64>) -> SimConfig {
        let scaled = SimConfig::default().scaled_to(nominal);
        let config = SimConfig {
            dh_length_sigma_m: self.dh_length_sigma_mm * 1e-3,
            dh_angle_sigma_rad: self.dh_angle_sigma_deg.to_radians(),
            frame_length_sigma_m: self.frame_length_sigma_mm * 1e-3,
            frame_angle_sigma_rad: self.frame_angle_sigma_deg.to_radians(),
            joint_compliance: self
                .joint_compliance
                .map_or(scaled.joint_compliance, |r| r.0),
            base_compliance: self.base_compliance.map_or(scaled.base_compliance, |r| r.0),
            servo_error_rad: self.servo_error_deg.to_radians(),
            servo_error_shape: self.servo_error_shape,
            backlash_rad: self.backlash_deg.to_radians(),
            // Stiffening springs replace the softening ones (one form at a time).
            softening_per_nm: match self.stiffening_per_nm {
                Some(_) => 0.0,
                None => self.softening_per_nm.unwrap_or(scaled.softening_per_nm),
            },
            stiffening_per_nm: self.stiffening_per_nm.unwrap_or(scaled.stiffening_per_nm),
            parallel_twist_sigma_rad: self.parallel_twist_deg.to_radians(),
            noise_sigma_m: self.noise_mm * 1e-3,
        };
        if self.model_only {
            SimConfig {
                servo_error_rad: 0.0,
                backlash_rad: 0.0,
                softening_per_nm: 0.0,
                stiffening_per_nm: 0.0,
                noise_sigma_m: 0.0,
                ..config
            }
        } else {
            config
        }
    }
}

/// Metres to millimetres, rounded to 1 nm so defaults print cleanly.
fn mm(m: f64) -> f64 {
    (m * 1e6).round() / 1e3
}

/// Radians to degrees, rounded to 1e-9 degree so defaults print cleanly.
fn deg(rad: f64) -> f64 {
    (rad.to_degrees() * 1e9).round() / 1e9
}

fn non_negative(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("expected a finite number >= 0, found `{text}`")),
    }
}

/// `--servo-error-shape`: the simulator's [`ServoErrorShape`]s by name.
fn servo_shape() -> impl clap::builder::TypedValueParser<Value = ServoErrorShape> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(["sine-cubic", "harmonics"]).map(|name| {
        if name == "harmonics" {
            ServoErrorShape::Harmonics
        } else {
            ServoErrorShape::SineCubic
        }
    })
}

fn parse_load(text: &str) -> Result<f64, String> {
    non_negative(text).map_err(|_| format!("expected a load >= 0 in kg, found `{text}`"))
}

/// A compliance range `LO,HI`, rad/Nm, with `0 < LO <= HI`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range(pub [f64; 2]);

impl std::fmt::Display for Range {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{},{}", self.0[0], self.0[1])
    }
}

impl std::str::FromStr for Range {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let expected = || format!("expected `LO,HI` with 0 < LO <= HI in rad/Nm, found `{text}`");
        let values: Vec<f64> = text
            .split(',')
            .map(|v| v.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| expected())?;
        match values[..] {
            [lo, hi] if lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi => {
                Ok(Self([lo, hi]))
            }
            _ => Err(expected()),
        }
    }
}

/// Runs `lrmcal simulate`.
pub fn run(args: &Args) -> Result<(), Error> {
    let arm = args.arm.load()?;
    let owned = passes(args, &arm)?;
    let passes: Vec<Pass<'_>> = owned
        .iter()
        .map(|(load_kg, poses)| Pass {
            load_kg: *load_kg,
            poses,
        })
        .collect();
    let truth = TrueArm::draw(&arm.arm, args.seed, &args.sim.config(&arm.arm))?;
    if let Some(path) = &args.camera {
        return watch(args, &arm, &truth, &passes, path);
    }
    let simulation = truth.simulate_passes(&passes)?;

    if let Some(path) = &args.truth {
        write_text(path, &truth.truth_json(None))?;
    }
    if let Some(path) = &args.noise_free {
        measurements::write(path, &simulation.noise_free, &arm.arm.kinds())?;
    }
    match &args.out {
        Some(path) => measurements::write(path, &simulation.measurements, &arm.arm.kinds())?,
        None => measurements::write_to(
            &mut std::io::stdout().lock(),
            &simulation.measurements,
            &arm.arm.kinds(),
        )
        .map_err(|source| lrmcal_core::Error::Write {
            path: "<stdout>".into(),
            source,
        })?,
    }

    eprintln!(
        "simulated {} measurements of a true arm drawn around {} ({}) with seed {}",
        simulation.measurements.len(),
        arm.origin,
        arm.name,
        args.seed
    );
    for (load_kg, _) in &owned {
        let rows: Vec<&Measurement> = simulation
            .measurements
            .iter()
            .filter(|m| m.load_kg == *load_kg)
            .collect();
        let mean_mm = mean_model_error_m(&arm, &rows)? * 1e3;
        eprintln!(
            "  load {load_kg} kg: mean distance nominal model -> measurement {mean_mm:.2} mm over {} poses",
            rows.len()
        );
    }
    Ok(())
}

/// `simulate --camera`: the webcam of `setup` watches the true arm's board.
fn watch(
    args: &Args,
    arm: &LoadedArm,
    truth: &TrueArm,
    passes: &[Pass<'_>],
    setup_file: &Path,
) -> Result<(), Error> {
    let setup = &setup::read(setup_file)?;
    let webcam = Webcam::draw(setup, args.seed, args.pixel_noise_px);
    let watched = truth.watch(&webcam, passes)?;
    if watched.views.is_empty() {
        return Err(Error::Usage(format!(
            "the camera of `{}` sees the board at none of the {} poses: plan them with \
             `lrmcal plan --camera {}`, or check where the setup puts the camera and the board",
            setup_file.display(),
            watched.unseen,
            setup_file.display(),
        )));
    }
    if let Some(path) = &args.truth {
        write_text(path, &truth.truth_json(Some(&webcam)))?;
    }
    let kinds = arm.arm.kinds();
    if let Some(path) = &args.noise_free {
        views::write(path, &watched.noise_free, &kinds)?;
    }
    if let Some(folder) = &args.images {
        take_images(folder, &webcam, &watched, &kinds)?;
        eprintln!(
            "simulated a webcam taking {} images of the board on a true arm drawn around {} ({}) \
             with seed {} (the board not seen at {} poses): {}",
            watched.views.len(),
            arm.origin,
            arm.name,
            args.seed,
            watched.unseen,
            folder.join(IMAGE_LIST).display()
        );
        return Ok(());
    }
    match &args.out {
        Some(path) => views::write(path, &watched.views, &kinds)?,
        None => views::write_to(&mut std::io::stdout().lock(), &watched.views, &kinds).map_err(
            |source| lrmcal_core::Error::Write {
                path: "<stdout>".into(),
                source,
            },
        )?,
    }
    let corners: usize = watched.views.iter().map(|v| 4 * v.tags.len()).sum();
    eprintln!(
        "simulated a webcam seeing the board on a true arm drawn around {} ({}) with seed {}: \
         {corners} corners at {} poses, the board not seen at {}",
        arm.origin,
        arm.name,
        args.seed,
        watched.views.len(),
        watched.unseen
    );
    let told = Webcam::as_told(setup);
    let rig = rig_of(arm);
    let mut sum = 0.0;
    let mut count = 0usize;
    for view in &watched.views {
        let sample = Sample::from(view);
        let flange = rig.evaluate(&sample)?.deflection.frames.frames.last_value();
        let Some(predicted) = told.project_board(&flange) else {
            continue;
        };
        for (seen, tag) in view.tags.iter().zip(&predicted) {
            for (a, b) in seen.corners_px.iter().zip(&tag.corners_px) {
                sum += (a[0] - b[0]).hypot(a[1] - b[1]);
                count += 1;
            }
        }
    }
    eprintln!(
        "  mean distance nominal model and setup -> corner {:.1} px over {count} corners",
        sum / count.max(1) as f64
    );
    Ok(())
}

/// The pose list `simulate --images` writes beside the images.
pub const IMAGE_LIST: &str = "poses.csv";

/// Writes the webcam's image of each view of `watched` into `folder` as a
/// PNG, and then the pose list naming them ([`IMAGE_LIST`]).
fn take_images(
    folder: &Path,
    webcam: &Webcam,
    watched: &Watched,
    kinds: &PerJoint<JointKind>,
) -> Result<(), Error> {
    let failed = |path: &Path, source: std::io::Error| lrmcal_core::Error::Write {
        path: path.to_owned(),
        source,
    };
    std::fs::create_dir_all(folder).map_err(|source| failed(folder, source))?;
    let meter = Meter::new("rendering images", watched.views.len() as u64, "images");
    let (width, height) = (webcam.intrinsics.width_px, webcam.intrinsics.height_px);
    // Two cores or more take images at once, a batch a core; each image's
    // light and noise are its own, so the files are the same however many.
    let views: Vec<_> = watched.views.iter().zip(&watched.flanges).collect();
    let mut shots = Vec::new();
    for (batch, chunk) in views.chunks(rayon::current_num_threads()).enumerate() {
        let first = batch * rayon::current_num_threads();
        let taken = chunk
            .par_iter()
            .enumerate()
            .map(|(k, (view, flange))| {
                let name = format!("pose{}-{}kg.png", view.pose.id, view.load_kg);
                let path = folder.join(&name);
                let pixels = webcam.image((first + k) as u32, flange, &Look::WEBCAM);
                image::GrayImage::from_raw(width, height, pixels)
                    .ok_or_else(|| {
                        failed(&path, std::io::Error::other("the image is not its size"))
                    })?
                    .save(&path)
                    .map_err(|e| failed(&path, std::io::Error::other(e)))?;
                Ok(Shot {
                    line: 0,
                    pose: view.pose,
                    load_kg: view.load_kg,
                    image: name,
                    units: *kinds,
                })
            })
            .collect::<Result<Vec<_>, lrmcal_core::Error>>()?;
        meter.inc(taken.len() as u64);
        shots.extend(taken);
    }
    meter.finish();
    shots::write(&folder.join(IMAGE_LIST), &shots, kinds)?;
    Ok(())
}

/// The poses to measure under each load, in order.
fn passes(args: &Args, arm: &LoadedArm) -> Result<Vec<(f64, Vec<Pose>)>, Error> {
    let Some(path) = &args.poses else {
        // `lrmcal plan`'s defaults: the grid and the random poses off it.
        let mut config = PlanConfig::for_loaded(arm)?;
        config.random = DEFAULT_RANDOM_POSES;
        let plan = candidates(&arm.arm, &config)?;
        let loads = args.loads.clone().unwrap_or(DEFAULT_LOADS_KG.to_vec());
        return Ok(loads.into_iter().map(|l| (l, plan.kept.clone())).collect());
    };
    let rows = pose_list::read(path)?;
    match &args.loads {
        // Explicit loads: every distinct pose (first listing) under each.
        Some(loads) => {
            let mut poses: Vec<Pose> = Vec::new();
            for row in &rows {
                if !poses.iter().any(|p| p.id == row.pose.id) {
                    poses.push(row.pose);
                }
            }
            Ok(loads.iter().map(|&l| (l, poses.clone())).collect())
        }
        // The list's own loads: one pass per load, in order of first appearance.
        None if rows.iter().any(|r| r.load_kg.is_some()) => {
            let mut passes: Vec<(f64, Vec<Pose>)> = Vec::new();
            for row in &rows {
                let load = row.load_kg.unwrap_or(0.0);
                match passes.iter_mut().find(|(l, _)| *l == load) {
                    Some((_, poses)) => poses.push(row.pose),
                    None => passes.push((load, vec![row.pose])),
                }
            }
            Ok(passes)
        }
        None => {
            let poses: Vec<Pose> = rows.iter().map(|r| r.pose).collect();
            Ok(DEFAULT_LOADS_KG
                .iter()
                .map(|&l| (l, poses.clone()))
                .collect())
        }
    }
}

/// Mean distance between what the arm's model predicts for the rows (the
/// one evaluation of a calibration, `Rig::evaluate`: a calibration file's
/// servo curves and play included) and the rows, m.
fn mean_model_error_m(arm: &LoadedArm, rows: &[&Measurement]) -> Result<f64, Error> {
    let samples: Vec<Sample> = rows.iter().map(|m| Sample::from(*m)).collect();
    let predicted = rig_of(arm).tool_points(&samples)?;
    let sum: f64 = predicted
        .iter()
        .zip(rows)
        .map(|(p, m)| (p - m.position).norm())
        .sum();
    Ok(sum / rows.len().max(1) as f64)
}
