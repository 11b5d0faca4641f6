//! The figures of "Any serial arm from its URDF" in docs/RESULTS.md: one
//! URDF chain, its every joint placement (fixed joints too) moved by 1-2 mm
//! and 0.2-0.5° per axis, a tool point 3-6 cm off the tip link, the base
//! anywhere in the tracker's frame; 150 poses measured with 0.1 mm noise per
//! axis to fit and 200 others to check against the noise-free truth, per
//! seed. Prints, per seed, the mean error of an independent fit of the
//! placements (no DH), of `lrmcal identify --option kinematic` and of the
//! default option, each through `lrmcal predict`; then their medians and
//! ranges over the seeds.
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
    println!(
        "seed  independent  kinematic  {default}  (mean 3D error, mm; residual RMS kinematic / default / noise)"
    );
    let mut rows = Vec::new();
    for seed in 1..=seeds {
        let kinematic = calibrate(&lrmcal, urdf, (base, tip), "kinematic", seed, 150);
        let ours = calibrate(&lrmcal, urdf, (base, tip), default, seed, 150);
        println!(
            "{seed:>4}  {:>11.4}  {:>9.4}  {:>9.4}  ({:.3} / {:.3} / {:.3})",
            1e3 * kinematic.independent_mean,
            1e3 * kinematic.lrmcal_mean,
            1e3 * ours.lrmcal_mean,
            1e3 * kinematic.residual_rms,
            1e3 * ours.residual_rms,
            1e3 * kinematic.noise_rms,
        );
        rows.push([
            kinematic.independent_mean,
            kinematic.lrmcal_mean,
            ours.lrmcal_mean,
        ]);
    }
    let summary = |k: usize| {
        let mut v: Vec<f64> = rows.iter().map(|r| 1e3 * r[k]).collect();
        v.sort_by(f64::total_cmp);
        let median = if v.len() % 2 == 1 {
            v[v.len() / 2]
        } else {
            (v[v.len() / 2 - 1] + v[v.len() / 2]) / 2.0
        };
        format!("{median:.3} ({:.3}-{:.3})", v[0], v[v.len() - 1])
    };
    println!(
        "median (range) over {seeds} seeds: independent {}, kinematic {}, {default} {}",
        summary(0),
        summary(1),
        summary(2)
    );
}
