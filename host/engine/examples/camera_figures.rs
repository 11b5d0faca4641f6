//! The camera path's figures over seeds: for each seed, a webcam and a true
//! arm drawn, 60 poses the camera sees fitted from their pixels, the board's
//! origin checked at 40 others (beside a tracker's calibration from the
//! same poses) and the camera's place against the truth
//! (`tests/common/camera_trial.rs`); then the median and the range.
//!
//! `cargo run --release -p lrmcal-engine --example camera_figures -- 1 10`
//! (first and last seed; 1 to 10 by default). With a third argument,
//! `off-held` or `off-refined`, the camera's true lens is off the setup's
//! intrinsics (focal lengths 3 %, k1 0.04, k2 0.03) and the fit holds the
//! setup's lens or refines it; with `eye-in-hand`, the webcam rides the
//! flange and the board stands before the arm (the bundled
//! `setup-eye-in-hand.toml`).

#[path = "../tests/common/camera_trial.rs"]
mod camera_trial;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seed = |i: usize, default: u64| {
        args.get(i)
            .map_or(default, |a| a.parse().expect("seeds are integers"))
    };
    let (first, last) = (seed(0, 1), seed(1, 10));
    let mut lens = camera_trial::Lens::Calibrated;
    let mut mount = lrmcal_core::camera::Mount::EyeToHand;
    for word in args.iter().skip(2) {
        match word.as_str() {
            "off-held" => lens = camera_trial::Lens::Off { refine: false },
            "off-refined" => lens = camera_trial::Lens::Off { refine: true },
            "eye-in-hand" => mount = lrmcal_core::camera::Mount::EyeInHand,
            other => panic!("expected off-held, off-refined or eye-in-hand, found {other}"),
        }
    }
    let mut rows = Vec::new();
    println!("seed  board origin mm  tracker mm  nominal mm  camera mm  camera deg  lens px");
    for seed in first..=last {
        let t = camera_trial::trial(seed, lens, mount);
        println!(
            "{seed:>4}  {:>15.3}  {:>10.3}  {:>10.1}  {:>9.3}  {:>10.3}  {:>7.3}",
            t.board_mm, t.tracker_mm, t.nominal_mm, t.camera_mm, t.camera_deg, t.lens_px
        );
        rows.push(t);
    }
    let summary = |name: &str, mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        println!(
            "{name}: median {:.3}, range {:.3} to {:.3}",
            v[v.len() / 2],
            v[0],
            v[v.len() - 1]
        );
    };
    summary("board origin mm", rows.iter().map(|t| t.board_mm).collect());
    summary("tracker mm", rows.iter().map(|t| t.tracker_mm).collect());
    summary(
        "camera / tracker",
        rows.iter().map(|t| t.board_mm / t.tracker_mm).collect(),
    );
    summary("camera mm", rows.iter().map(|t| t.camera_mm).collect());
    summary("camera deg", rows.iter().map(|t| t.camera_deg).collect());
    summary("lens px", rows.iter().map(|t| t.lens_px).collect());
}
