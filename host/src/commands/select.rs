//! `lrmcal select`: choose the poses to measure. Rank analysis of the option's
//! parameters over the candidates, then DETMAX for the N poses that maximise
//! O1; prints O1..O5 and how a random choice of N compares; sets a few other
//! candidates aside to validate the fit on (`--validate`,
//! `lrmcal_engine::plan::validation`) and writes the pose list, each pose
//! with its role (`fit` or `validate`).

use std::path::PathBuf;

use crate::commands::helpers::OptionChoice;
use crate::error::Error;
use crate::progress::Steps;
use lrmcal_core::camera::setup;
use lrmcal_core::dataset::{Pose, PoseRow};
use lrmcal_core::io::arm_source::{ArmSource, DEFAULT_ARM};
use lrmcal_core::io::pose_list::{self, PoseRole};
use lrmcal_engine::calib::analysis::detmax::DetmaxOptions;
use lrmcal_engine::calib::fit::pipeline::Choice;
use lrmcal_engine::calib::results::experiments::{median, random_o1};
use lrmcal_engine::calib::results::report::IdentifiabilityReport;
use lrmcal_engine::calib::run::Calibration;
use lrmcal_engine::plan::validation::{DEFAULT_VALIDATION_POSES, validation_poses};

/// Choose the N candidate poses that identify the model best (D-optimal, DETMAX).
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
lrmcal plan --out candidates.csv && lrmcal select --candidates candidates.csv --out selection.csv\n  \
lrmcal select --candidates candidates.csv --n 60 --option all --out selection.csv\n  \
lrmcal select --candidates candidates.csv --evaluate my_poses.csv   # O1..O5 of your own set\n  \
lrmcal plan --camera setup.toml --out seen.csv && lrmcal select --camera setup.toml --candidates seen.csv --out selection.csv\n\n\
The Jacobian is taken on the nominal arm under each --load-kg (default: the paper's \
0.0663 kg). With --option all, one list per option is written, named \
<out stem>-<option>.csv.\n\n\
Besides the N poses to fit, the list holds --validate poses (10 by default) marked \
`validate` in its `role` column: other candidates, each the farthest in joint space from \
the poses already chosen. Measure them with the others; `identify --poses` holds them out \
of the fit and shows the calibration's error on them.")]
pub struct Args {
    /// The nominal arm: a bundled arm's name, an arm description `.toml` file, or a
    /// URDF `.urdf` file (its chain from --base-link to --tip-link).
    #[arg(long, value_name = "NAME|FILE", default_value = DEFAULT_ARM)]
    pub arm: ArmSource,
    /// Candidate pose list CSV (`pose,q1_deg..q6_deg`), e.g. from `lrmcal plan`.
    #[arg(long, value_name = "FILE")]
    pub candidates: PathBuf,
    /// Poses to select.
    #[arg(long, default_value_t = 60)]
    pub n: usize,
    /// Model option: elasto-kinematic-servo (each servo's own curve too),
    /// elasto-kinematic, kinematic, elastic (the paper's three),
    /// paper-elasto-kinematic, paper-kinematic (the paper's plain DH) or all.
    #[arg(long, default_value = "elasto-kinematic-servo")]
    pub option: OptionChoice,
    /// Loads each pose will be measured under, kg (repeat or comma-separate).
    #[arg(long, value_name = "KG", value_delimiter = ',', default_values_t = [0.0663])]
    pub load_kg: Vec<f64>,
    /// DETMAX random starts.
    #[arg(long, default_value_t = DetmaxOptions::default().starts)]
    pub starts: usize,
    /// Seed of the first DETMAX start.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Validation poses to set aside besides the N (role `validate` in the
    /// list): measured with the others, held out of the fit; 0 for none.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_VALIDATION_POSES)]
    pub validate: usize,
    /// Random N-pose sets to compare O1 with; 0 skips the comparison.
    #[arg(long, default_value_t = 20)]
    pub compare_random: usize,
    /// A webcam will measure: the camera setup (TOML) whose camera sees the
    /// board's corners; the poses are chosen for what its pixels tell
    /// (plan the candidates it sees with `lrmcal plan --camera`).
    #[arg(long, value_name = "SETUP")]
    pub camera: Option<PathBuf>,
    /// Instead of selecting, print the observability indices of this pose
    /// list (a subset of the candidates) and compare it with random sets.
    #[arg(long, value_name = "FILE", conflicts_with = "out")]
    pub evaluate: Option<PathBuf>,
    /// Where to write the selected pose list CSV.
    #[arg(long, short, value_name = "FILE", required_unless_present = "evaluate")]
    pub out: Option<PathBuf>,
}

/// Runs `lrmcal select`.
pub fn run(args: &Args) -> Result<(), Error> {
    let nominal = args.arm.load()?.arm;
    let candidates: Vec<Pose> = pose_list::read(&args.candidates)?
        .into_iter()
        .map(|r| r.pose)
        .collect();
    let options = args.option.options();
    let bar = Steps::new();
    // One plan for every option: the analyses are those `identify` will make.
    let planned = match &args.camera {
        Some(path) => {
            Calibration::plan_seen(&nominal, &candidates, &args.load_kg, &setup::read(path)?)?
        }
        None => Calibration::plan(&nominal, &candidates, &args.load_kg)?,
    };
    for option in &options {
        let choice = match &args.evaluate {
            // A selection's validation poses are not fitted: its fit poses are evaluated.
            Some(path) => Choice::Given(pose_list::ids_with_role(
                &pose_list::read_listed(path)?,
                PoseRole::Fit,
            )),
            None => Choice::Detmax(DetmaxOptions {
                n: args.n,
                starts: args.starts,
                seed: args.seed,
                ..Default::default()
            }),
        };
        let s = planned.select(*option, &choice, &bar)?;
        let ident = IdentifiabilityReport::from(&s.candidates.identifiability);
        println!(
            "{option}: {} of {} candidate parameters identifiable over {} candidate poses (SVD rank {})",
            ident.kept.len(),
            ident.candidates,
            candidates.len(),
            ident.svd_rank
        );
        for r in &ident.removed {
            println!("  removed {}", r.explain());
        }
        let o = s.observability;
        println!(
            "  {} poses {}: O1 {:.4}  O2 {:.4}  O3 {:.4}  O4 {:.4}  O5 {:.4} (column-scaled Jacobian)",
            s.poses.len(),
            if args.evaluate.is_some() {
                "given"
            } else {
                "selected"
            },
            o.o1,
            o.o2,
            o.o3,
            o.o4,
            o.o5
        );
        let n = s.poses.len();
        if args.compare_random > 0 {
            println!(
                "  median O1 of {} random {n}-pose sets: {:.4}",
                args.compare_random,
                median(random_o1(&s.candidates, n, args.compare_random))
            );
        }
        let Some(out) = &args.out else { continue };
        let out = if options.len() > 1 {
            let stem = out
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("selection");
            out.with_file_name(format!("{stem}-{option}.csv"))
        } else {
            out.clone()
        };
        let fit_ids: Vec<u32> = s.poses.iter().map(|p| p.id).collect();
        let validation = validation_poses(&nominal, &candidates, &fit_ids, args.validate);
        if args.validate > 0 {
            let ids: Vec<String> = validation.iter().map(|p| p.id.to_string()).collect();
            println!(
                "  {} validation poses set aside (measure them too; identify --poses holds them out): {}",
                validation.len(),
                ids.join(", ")
            );
        }
        let row = |p: &Pose| PoseRow {
            pose: *p,
            load_kg: None,
        };
        let rows: Vec<PoseRow> = s.poses.iter().chain(&validation).map(row).collect();
        if validation.is_empty() {
            pose_list::write(&out, &rows, &nominal.kinds())?;
        } else {
            let roles: Vec<PoseRole> = s
                .poses
                .iter()
                .map(|_| PoseRole::Fit)
                .chain(validation.iter().map(|_| PoseRole::Validate))
                .collect();
            pose_list::write_with_roles(&out, &rows, &roles, &nominal.kinds())?;
        }
        println!("  wrote {}", out.display());
    }
    Ok(())
}
