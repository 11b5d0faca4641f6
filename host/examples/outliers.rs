//! The measurement behind `identify`'s default loss (docs/METHOD.md,
//! "Outliers"): the demo's elasto-kinematic fit (50 DETMAX poses, 66.3 g) on
//! seeds 1–10, on clean simulated measurements and with three of the fitted
//! poses' measurements 20 mm too high, with plain least squares and with the
//! robust (Huber) fit. Prints the mean held-out error of each.
//!
//! `cargo run --release -p host --example outliers`

use lrmcal_engine::calib::ModelOption;
use lrmcal_engine::calib::analysis::detmax::DetmaxOptions;
use lrmcal_engine::calib::fit::identify::IdentifyOptions;
use lrmcal_engine::calib::fit::pipeline::{Choice, RunSettings};
use lrmcal_engine::calib::results::experiments::outlier_trial;
use lrmcal_engine::calib::run::Request;
use lrmcal_engine::plan::{PlanConfig, candidates};
use lrmcal_engine::sim::{SimConfig, TrueArm};
use nalgebra::Vector3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let nominal = lrmcal_core::io::arm_source::bundled("lrm")?.arm;
    let poses = candidates(&nominal, &PlanConfig::default())?.kept;
    let load = 0.0663;
    println!("seed | clean: plain robust | 3 x +20 mm: plain robust (named) | mm, held-out mean");
    let mut sums = [0.0; 4];
    for seed in 1..=10u64 {
        let truth = TrueArm::draw(&nominal, seed, &SimConfig::default())?;
        let all = truth.measure(&poses, &[load])?;
        let request = Request::new(&nominal, &all);
        let mut row = Vec::new();
        let mut named = Vec::new();
        for robust in [false, true] {
            let settings = RunSettings {
                identify_load_kg: load,
                other_load_kg: None,
                choice: Choice::Detmax(DetmaxOptions {
                    starts: 8,
                    ..Default::default()
                }),
                identify: IdentifyOptions {
                    robust,
                    ..Default::default()
                },
            };
            let t = outlier_trial(
                &request,
                ModelOption::ElastoKinematic,
                &settings,
                3,
                Vector3::new(0.0, 0.0, 0.02),
            )?;
            row.push((t.clean_mean_m, t.contaminated_mean_m));
            let found = t.displaced.iter().filter(|p| t.named.contains(p)).count();
            named.push(format!("{found}/3 of {}", t.named.len()));
        }
        let figures = [row[0].0, row[1].0, row[0].1, row[1].1];
        for (s, f) in sums.iter_mut().zip(figures) {
            *s += f * 1e3 / 10.0;
        }
        println!(
            "{seed:>4} | {:>5.2} {:>5.2} | {:>5.2} {:>5.2} ({}; {}) |",
            figures[0] * 1e3,
            figures[1] * 1e3,
            figures[2] * 1e3,
            figures[3] * 1e3,
            named[0],
            named[1]
        );
    }
    println!(
        "mean | {:>5.2} {:>5.2} | {:>5.2} {:>5.2}",
        sums[0], sums[1], sums[2], sums[3]
    );
    Ok(())
}
