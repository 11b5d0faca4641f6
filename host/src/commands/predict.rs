//! `lrmcal predict`: where an arm (nominal or calibrated) puts its tool point
//! for each pose of a list: what the calibration means
//! (`calib::targets::Rig::evaluate`, the same evaluation `identify` and
//! `validate` use), servo curves, play and elastic deflection under the load
//! included.

use std::collections::HashMap;
use std::path::PathBuf;

use crate::error::Error;
use lrmcal_core::dataset::{Prediction, approaches};
use lrmcal_core::io::arm_source::ArmSource;
use lrmcal_core::io::{pose_list, predictions};
use lrmcal_engine::calib::Sample;
use lrmcal_engine::calib::results::export::rig_of;

/// How the way each joint arrived at a pose is known.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ApproachRule {
    /// The rows are the order the poses were visited in (as `measure`
    /// writes them): each joint arrives the way its command last moved.
    Order,
    /// Unknown: each joint stands at the middle of its play (its command),
    /// off by at most half the play either way.
    Middle,
}

/// Predict tool positions for a pose list.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal predict --poses poses.csv --load-kg 0.0663 --out predicted.csv\n  \
lrmcal predict --arm my_arm.toml --poses poses.csv > predicted.csv\n  \
lrmcal predict --arm calibration.json --poses poses.csv --out calibrated.csv\n\n\
The pose list is any CSV with the columns pose,q1_deg..q6_deg (and optionally load_kg): a \
pose list, a measurement file; other columns are ignored. A pose outside the arm's joint \
limits is refused with the line, joint and limit, unless --allow-outside-limits. The output has \
pose,x_mm,y_mm,z_mm: the tool point in the world frame of the deflected arm, as a \
tracker would measure it.\n\n\
A calibration's servo curves say where the pulses of the nominal arm's curves really take each \
joint (the commands of its measurements), and a joint with play stands short of or beyond its \
command by half the play, the way it arrived: the rows are taken as the order the poses are \
visited in, from the all-zero pose (--approach order, what `measure` writes and `validate` \
assumes). When that order is not known, --approach middle puts every joint at the middle of its \
play instead.")]
pub struct Args {
    /// The arm: a bundled arm's name, an arm description `.toml` file, a URDF
    /// `.urdf` file (its chain from --base-link to --tip-link), or a
    /// calibration `.json` file from `lrmcal identify` or `lrmcal demo` (its calibrated arm).
    #[arg(long, value_name = "NAME|FILE", default_value = lrmcal_core::io::arm_source::DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Pose list: any CSV with `pose,[load_kg,]q1_deg..q6_deg` columns.
    #[arg(long, value_name = "FILE")]
    pub poses: PathBuf,
    /// Predict poses outside the arm's joint limits too (with a warning)
    /// instead of refusing the list.
    #[arg(long)]
    pub allow_outside_limits: bool,
    /// Payload at the tool for every pose, kg [default: the list's `load_kg`, else 0].
    #[arg(long, value_name = "KG", value_parser = parse_load)]
    pub load_kg: Option<f64>,
    /// How each joint's approach (the side of its play) is known: `order`,
    /// the rows are the visiting order; `middle`, unknown (the middle of the play).
    #[arg(long, value_enum, default_value_t = ApproachRule::Order)]
    pub approach: ApproachRule,
    /// Where to write the predictions CSV [default: standard output].
    #[arg(long, short, value_name = "FILE")]
    pub out: Option<PathBuf>,
}

fn parse_load(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("expected a load >= 0 in kg, found `{text}`")),
    }
}

/// Runs `lrmcal predict`.
pub fn run(args: &Args) -> Result<(), Error> {
    let arm = args.arm.load()?;
    let rows = pose_list::read_listed(&args.poses)?;
    if let Some(warning) =
        pose_list::check_within_limits(&arm.arm, &args.poses, &rows, args.allow_outside_limits)?
    {
        eprintln!("warning: {warning}");
    }
    let rig = match args.approach {
        ApproachRule::Order => rig_of(&arm),
        ApproachRule::Middle => rig_of(&arm).without_play(),
    };
    let mut out: Vec<Prediction> = Vec::with_capacity(rows.len());
    // A prediction file holds one position per pose id: the same pose listed
    // under several loads needs one load for all (`--load-kg`). Of its rows
    // the one listed under that load counts (its place in the visiting
    // order says how the joints arrived, as `validate` takes it), else the first.
    let mut seen: HashMap<u32, (usize, f64, bool)> = HashMap::new();
    // The poses are visited in the file's order.
    let ways = approaches(rows.iter().map(|l| &l.row.pose.q));
    for (row, approach) in rows.iter().map(|l| &l.row).zip(ways) {
        let id = row.pose.id;
        let load_kg = args.load_kg.or(row.load_kg).unwrap_or(0.0);
        let listed_under = args.load_kg.is_some() && row.load_kg == args.load_kg;
        let slot = match seen.get(&id) {
            Some(&(_, previous, _)) if previous != load_kg => {
                return Err(Error::AmbiguousLoad {
                    path: args.poses.clone(),
                    pose: id,
                });
            }
            Some(&(k, _, matched)) if listed_under && !matched => Some(k),
            Some(_) => continue,
            None => None,
        };
        let sample = Sample {
            id,
            q: row.pose.q,
            load_kg,
            target: 0,
            approach,
        };
        let prediction = Prediction {
            pose: id,
            position: rig.evaluate(&sample)?.tool_m,
        };
        match slot {
            Some(k) => out[k] = prediction,
            None => out.push(prediction),
        }
        let k = slot.unwrap_or(out.len() - 1);
        seen.insert(id, (k, load_kg, listed_under));
    }
    match &args.out {
        Some(path) => {
            predictions::write(path, &out)?;
            eprintln!(
                "predicted {} poses with {} ({}) into `{}`",
                out.len(),
                arm.origin,
                arm.name,
                path.display()
            );
            Ok(())
        }
        None => predictions::write_to(&mut std::io::stdout().lock(), &out).map_err(|source| {
            Error::from(lrmcal_core::Error::Write {
                path: "<stdout>".into(),
                source,
            })
        }),
    }
}
