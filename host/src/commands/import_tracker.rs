//! `lrmcal import-tracker`: a take recorded by an optical tracker over a whole
//! measurement run (OptiTrack Motive's CSV export) → the measurement CSV.
//!
//! The arm was driven through the pose list in order, holding each pose
//! (`lrmcal measure --hold-s`); the take is cut into still periods and the
//! n-th period is the n-th pose. Counting is all there is to match them, so a
//! count that differs from the pose list is refused with the periods found.

use std::path::PathBuf;

use crate::commands::helpers::{non_negative, positive};
use crate::error::Error;
use lrmcal_core::dataset::{Measurement, from_home};
use lrmcal_core::io::{measurements, pose_list, read_text};
use lrmcal_engine::tracker::TrackerError;
use lrmcal_engine::tracker::axes::Up;
use lrmcal_engine::tracker::motive::{self, Asset};
use lrmcal_engine::tracker::still::{StillOptions, StillPeriod, still_periods};

/// Import a recorded tracker take (Motive CSV) into a measurement CSV.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal import-tracker --motive take.csv --rigid-body Tool --poses selected.csv --out measured.csv\n  \
lrmcal import-tracker --motive take.csv --marker Tool:M1 --poses p.csv -o m.csv --up +y\n\n\
Record the take while `lrmcal measure --poses selected.csv --hold-s 3` drives the arm, then \
export it from Motive as CSV with header information, in any length unit. A still period is \
at least --min-still-s long with every frame within --max-spread-mm of the mean; the n-th \
period is the n-th pose of the list. Leave out the rest before the first pose and after the \
last with --start-s and --end-s. Positions are written in mm in the tracker's frame, or turned \
Z-up with --up.")]
pub struct Args {
    /// The take: Motive's CSV export (header information on).
    #[arg(long, value_name = "FILE")]
    pub motive: PathBuf,
    /// The rigid body whose pivot point is the tool point, by name.
    #[arg(long, value_name = "NAME", required_unless_present = "marker")]
    pub rigid_body: Option<String>,
    /// A labelled marker instead, by its name in the export (e.g. `Tool:Marker1`).
    #[arg(long, value_name = "NAME", conflicts_with = "rigid_body")]
    pub marker: Option<String>,
    /// The pose list the arm was driven through, in that order.
    #[arg(long, value_name = "FILE")]
    pub poses: PathBuf,
    /// Measurement CSV to write (replaced if it exists).
    #[arg(long, short, value_name = "FILE")]
    pub out: PathBuf,
    /// Payload at the tool, kg [default: the list's `load_kg`, else 0].
    #[arg(long, value_name = "KG", value_parser = non_negative)]
    pub load_kg: Option<f64>,
    /// Shortest hold that counts as a pose, s.
    #[arg(long, value_name = "S", default_value_t = 1.0, value_parser = positive)]
    pub min_still_s: f64,
    /// Largest distance of a frame from the mean of a hold, mm.
    #[arg(long, value_name = "MM", default_value_t = 0.5, value_parser = positive)]
    pub max_spread_mm: f64,
    /// Leave out the take before this time, s (Motive's `Time (Seconds)`).
    #[arg(long, value_name = "S")]
    pub start_s: Option<f64>,
    /// Leave out the take after this time, s.
    #[arg(long, value_name = "S")]
    pub end_s: Option<f64>,
    /// Turn the positions so that this tracker axis points up (`+y` for Motive's
    /// default frame), into a right-handed Z-up frame [default: the tracker's frame as is].
    #[arg(long, value_name = "AXIS", allow_hyphen_values = true)]
    pub up: Option<Up>,
}

/// Runs `lrmcal import-tracker`.
pub fn run(args: &Args) -> Result<(), Error> {
    let listed = pose_list::read_listed(&args.poses)?;
    // The measurements give each joint as the pose list does (degrees or mm).
    let kinds = listed.first().map(|l| l.units).unwrap_or_default();
    let list: Vec<_> = listed.iter().map(|l| l.row).collect();
    let asset = match (&args.rigid_body, &args.marker) {
        (Some(name), _) => Asset::RigidBody(name),
        (None, Some(name)) => Asset::Marker(name),
        (None, None) => {
            return Err(Error::DeviceInput {
                what: format!("import `{}`", args.motive.display()),
                reason: "name the tracked point: --rigid-body NAME or --marker NAME".into(),
            });
        }
    };
    let take =
        motive::parse(&read_text(&args.motive)?, asset).map_err(|source| TrackerError::Take {
            path: args.motive.clone(),
            source,
        })?;
    let within = |t: f64| args.start_s.is_none_or(|s| t >= s) && args.end_s.is_none_or(|e| t <= e);
    let samples: Vec<_> = take
        .samples
        .iter()
        .copied()
        .filter(|s| within(s.time_s))
        .collect();
    let options = StillOptions {
        min_duration_s: args.min_still_s,
        max_spread_m: args.max_spread_mm / 1000.0,
    };
    let periods = still_periods(&samples, options);
    if periods.len() != list.len() {
        return Err(TrackerError::Periods {
            take: args.motive.clone(),
            poses: args.poses.clone(),
            problem: mismatch(&periods, list.len(), args),
        }
        .into());
    }
    let turn = args.up.map(Up::rotation).unwrap_or_default();
    let rows: Vec<Measurement> = list
        .iter()
        .zip(&periods)
        .map(|(row, period)| Measurement {
            pose: row.pose,
            load_kg: args.load_kg.or(row.load_kg).unwrap_or(0.0),
            position: turn * period.position,
            pixel: None,
            target: None,
            // The take's still periods are in the order the poses were
            // visited; the file's readers work the approach out from it.
            approach: from_home(row.pose.q.len()),
        })
        .collect();
    measurements::write(&args.out, &rows, &kinds)?;
    println!("pose   start_s    end_s  frames  lost  spread_mm");
    for (row, p) in list.iter().zip(&periods) {
        println!(
            "{:>4} {:>8.2} {:>8.2} {:>7} {:>5} {:>10.3}",
            row.pose.id,
            p.start_s,
            p.end_s,
            p.frames,
            p.lost,
            p.spread_m * 1e3
        );
    }
    let frame = match args.up {
        Some(up) => format!("turned from {up} up to Z up"),
        None => "in the tracker's frame".to_owned(),
    };
    println!(
        "{} poses from {} ({}) written to {}, {frame}",
        rows.len(),
        asset,
        take.name.as_deref().unwrap_or("unnamed take"),
        args.out.display()
    );
    Ok(())
}

/// The refusal when the periods and poses differ in number, with the periods.
fn mismatch(periods: &[StillPeriod], poses: usize, args: &Args) -> String {
    let found = periods
        .iter()
        .enumerate()
        .map(|(i, p)| format!("{}: {:.2}-{:.2} s", i + 1, p.start_s, p.end_s))
        .collect::<Vec<_>>()
        .join(", ");
    let hint = if periods.len() > poses {
        "leave out rests before the first pose and after the last with --start-s/--end-s, \
         or raise --min-still-s above the longest pause that is not a pose"
    } else {
        "lower --min-still-s below the shortest hold, or raise --max-spread-mm if the holds shake"
    };
    format!(
        "expected {poses} still periods, one per pose, found {} (at least {} s within {} mm){}{found}; {hint}",
        periods.len(),
        args.min_still_s,
        args.max_spread_mm,
        if periods.is_empty() { "" } else { ": " },
    )
}
