//! The figures of "Any serial arm from its URDF" in docs/RESULTS.md: one
//! URDF chain, its every joint placement (fixed joints too) moved by 1-2 mm
//! and 0.2-0.5° per axis, a tool point 3-6 cm off the tip link, the base
//! anywhere in the tracker's frame; 150 poses measured with 0.1 mm noise per
//! axis to fit and 200 others to check against the noise-free truth, per
//! seed. Prints, per seed, the mean error of an independent fit of the
//! placements (no DH), of `lrmcal identify --option paper-kinematic` (the
//! paper's plain DH), `--option kinematic` and the default option, each
//! through `lrmcal predict`; then their medians and ranges over the seeds,
//! and the largest ratio of each to the independent fit.
//!
//! ```sh
//! cargo build --release -p host --bin lrmcal --example chain_figures
//! target/release/examples/chain_figures ROBOT.urdf BASE_LINK TIP_LINK [SEEDS]
//! ```
//! The `lrmcal` beside the example's folder is run (`LRMCAL` overrides it).

#[path = "../tests/chain_support/mod.rs"]
mod chain_support;

use std::path::{Path, PathBuf};

use chain_support::calibrate;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        eprintln!("usage: chain_figures ROBOT.urdf BASE_LINK TIP_LINK [SEEDS]");
        std::process::exit(2);
    }
    let (urdf, base, tip) = (Path::new(&args[0]), &args[1], &args[2]);
    let seeds: u64 = args
        .get(3)
        .map_or(5, |s| s.parse().expect("SEEDS, a count"));
    let lrmcal = std::env::var_os("LRMCAL").map_or_else(
        || {
            let exe = std::env::current_exe().expect("the example's path");
            exe.parent()
                .and_then(Path::parent)
                .expect("target/<profile>/examples")
                .join("lrmcal")
        },
        PathBuf::from,
    );
    let default = lrmcal_engine::calib::parameters::option::DEFAULT.name();
    let options = ["paper-kinematic", "kinematic", default];
    println!(
        "seed  independent  {}  (mean 3D error, mm; residual RMS of each / noise)",
        options.join("  ")
    );
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for seed in 1..=seeds {
        let outcomes: Vec<_> = options
            .iter()
            .map(|o| calibrate(&lrmcal, urdf, (base, tip), o, seed, 150))
            .collect();
        let mut row = vec![outcomes[0].independent_mean];
        row.extend(outcomes.iter().map(|o| o.lrmcal_mean));
        let residuals: Vec<String> = outcomes
            .iter()
            .map(|o| format!("{:.3}", 1e3 * o.residual_rms))
            .collect();
        println!(
            "{seed:>4}  {}  ({} / {:.3})",
            row.iter()
                .map(|m| format!("{:>9.4}", 1e3 * m))
                .collect::<Vec<_>>()
                .join("  "),
            residuals.join(" / "),
            1e3 * outcomes[0].noise_rms
        );
        rows.push(row);
    }
    let summary = |k: usize| {
        let mut v: Vec<f64> = rows.iter().map(|r| 1e3 * r[k]).collect();
        v.sort_by(f64::total_cmp);
        let median = if v.len() % 2 == 1 {
            v[v.len() / 2]
        } else {
            (v[v.len() / 2 - 1] + v[v.len() / 2]) / 2.0
        };
        let worst = rows.iter().map(|r| r[k] / r[0]).fold(0.0, f64::max);
        format!(
            "{median:.3} ({:.3}-{:.3}), at most {worst:.2}x",
            v[0],
            v[v.len() - 1]
        )
    };
    println!("median (range) over {seeds} seeds, largest ratio to the independent fit:");
    println!("  independent {}", summary(0));
    for (k, o) in options.iter().enumerate() {
        println!("  {o} {}", summary(k + 1));
    }
}
