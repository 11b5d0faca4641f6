//! The demo's positioning figure as a test: a true arm with play measured and
//! calibrated as the demo does it, then random tool-point targets driven by
//! the board (the firmware library's servo frames) and executed by the true
//! arm. The calibrated board must put the tool far nearer the targets than
//! an uncalibrated one, and nearer still when it knows the play.

use lrmcal_engine::calib::analysis::detmax::DetmaxOptions;
use lrmcal_engine::calib::fit::identify::IdentifyOptions;
use lrmcal_engine::calib::fit::pipeline::{Choice, RunSettings};
use lrmcal_engine::calib::progress::Silent;
use lrmcal_engine::calib::results::export::calibration_file;
use lrmcal_engine::calib::run::{Calibration, Request};
use lrmcal_engine::calib::{ModelOption, parameters::option};
use lrmcal_engine::plan::{PlanConfig, candidates};
use lrmcal_engine::sim::positioning::{self, Positioning};
use lrmcal_engine::sim::{SimConfig, TrueArm};

const LOAD_KG: f64 = 0.0663;

#[test]
fn calibration_and_the_boards_play_offset_bring_the_tool_to_its_targets() {
    let nominal = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("bundled arm")
        .arm;
    let poses = candidates(&nominal, &PlanConfig::default())
        .expect("plan")
        .kept;
    // The demo's true arm with a hobby servo's worn play: 2° full width per joint on average.
    let config = SimConfig {
        backlash_rad: 2f64.to_radians(),
        ..SimConfig::default()
    };
    let truth = TrueArm::draw(&nominal, 1, &config).expect("true arm");
    let measured = truth.measure(&poses, &[0.0, LOAD_KG]).expect("measure");
    let calibration =
        Calibration::open(&Request::new(&nominal, &measured).load(LOAD_KG)).expect("open");
    let settings = RunSettings {
        identify_load_kg: LOAD_KG,
        other_load_kg: None,
        choice: Choice::Detmax(DetmaxOptions {
            starts: 1,
            ..Default::default()
        }),
        identify: IdentifyOptions::default(),
    };
    let mut files = Vec::new();
    for option in [ModelOption::PaperElastoKinematic, option::DEFAULT] {
        if files.iter().any(|(o, _)| *o == option) {
            continue;
        }
        let r = calibration
            .option(option, &settings, &Silent)
            .expect("calibrate");
        let file = calibration_file(
            &nominal,
            &r.identified,
            &r.selection.candidates.identifiability.removed_ids(),
            r.pose_ids(),
            vec![LOAD_KG],
            r.identified.fit_residual,
            None,
        );
        files.push((option, file));
    }
    let calibrations: Vec<_> = files.iter().map(|(o, f)| (*o, f)).collect();
    let mut boards = positioning::demo_boards(&calibrations).expect("boards");
    assert_eq!(boards[0], ("uncalibrated".to_owned(), None));
    assert!(boards[1].0.starts_with("paper's model"), "{boards:?}");
    // Ours again, told the true play (until identification fits it).
    let (label, ours) = boards.last().cloned().expect("ours");
    let mut played = ours.expect("a calibration");
    for (joint, half) in played
        .calibrated
        .joints
        .iter_mut()
        .zip(&truth.backlash_half_rad)
    {
        joint.backlash = (2.0 * half) as f32;
    }
    boards.push((format!("{label} + play"), Some(played)));

    let targets = positioning::targets(&nominal, 25, 7, &PlanConfig::default(), &boards, LOAD_KG)
        .expect("targets");
    let rows =
        positioning::compare(&truth, &targets.targets, &boards, LOAD_KG).expect("positioning");
    let mean_mm = |r: &Positioning| r.stats.mean_m * 1e3;
    let table = positioning::table(&rows);
    println!("{table}");
    let (uncalibrated, paper) = (mean_mm(&rows[0]), mean_mm(&rows[1]));
    let (ours, with_play) = (
        mean_mm(&rows[rows.len() - 2]),
        mean_mm(&rows[rows.len() - 1]),
    );
    // Tens of millimetres of sag and geometry, down to a few.
    assert!(uncalibrated > 10.0, "{table}");
    assert!(
        paper < 0.3 * uncalibrated && ours < 0.3 * uncalibrated,
        "{table}"
    );
    // The play the board does not offset leaves on average a third of a
    // degree per joint; offsetting it must remove a clear part of the error.
    assert!(with_play < ours - 0.3, "{table}");
    // The table carries every board.
    assert_eq!(table.lines().count(), rows.len() + 1, "{table}");
    // Each board was sent joint targets its compensation can command: no
    // move ended with the compensation fallen back, nor a command clamped.
    assert!(
        rows.iter().all(|r| r.fell_back == 0 && r.clamped == 0),
        "{table}"
    );
}
