//! One meaning of a calibration, as a round trip: for calibrations the fit
//! makes on simulated arms whose effects are and are not the model's own
//! forms (springs that soften, springs that stiffen as `k / (1 + c|τ|)`,
//! a servo error with harmonics; several strengths and seeds), the file
//! written and read back predicts every pose exactly as `identify` did in
//! memory, `validate`'s figures on it are `identify`'s own, every reader
//! and the board accept it, and the board's compensated commands put the
//! tool point where the nominal arm's would be, within its tolerance.

use lrmcal_core::io::calibration_file::CalibrationFile;
use lrmcal_engine::calib::analysis::detmax::DetmaxOptions;
use lrmcal_engine::calib::fit::identify::IdentifyOptions;
use lrmcal_engine::calib::fit::pipeline::{Choice, RunSettings};
use lrmcal_engine::calib::fit::validate::validate;
use lrmcal_engine::calib::progress::Silent;
use lrmcal_engine::calib::results::export::{result_calibration_file, rigs_of};
use lrmcal_engine::calib::run::{Calibration, Request};
use lrmcal_engine::calib::{Sample, parameters::option};
use lrmcal_engine::plan::{PlanConfig, candidates};
use lrmcal_engine::sim::{ServoErrorShape, SimConfig, TrueArm};
use model::SolverOptions;
use model::backlash::Approach;
use model::testing::TEST_ARM_JOINTS as JOINTS;
use protocol::CompensationMode;

const LOAD_KG: f64 = 0.0663;

/// One simulated world.
struct Case {
    name: &'static str,
    seed: u64,
    config: SimConfig,
}

fn cases() -> Vec<Case> {
    let default = SimConfig::default();
    vec![
        Case {
            name: "softening springs (the model's form), seed 2",
            seed: 2,
            config: default,
        },
        Case {
            name: "stiffening springs c = 0.4, seed 3",
            seed: 3,
            config: SimConfig {
                softening_per_nm: 0.0,
                stiffening_per_nm: 0.4,
                noise_sigma_m: 0.15e-3,
                ..default
            },
        },
        Case {
            name: "stiffening springs c = 0.8, harmonic servo error, seed 4",
            seed: 4,
            config: SimConfig {
                softening_per_nm: 0.0,
                stiffening_per_nm: 0.8,
                servo_error_shape: ServoErrorShape::Harmonics,
                noise_sigma_m: 0.15e-3,
                ..default
            },
        },
    ]
}

#[test]
fn a_calibration_means_the_same_written_read_validated_and_on_the_board() {
    let nominal = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
    let poses = candidates(&nominal, &PlanConfig::default()).unwrap().kept;
    for case in cases() {
        let truth = TrueArm::draw(&nominal, case.seed, &case.config).unwrap();
        let measured = truth.measure(&poses, &[0.0, LOAD_KG]).unwrap();
        let calibration = Calibration::open(&Request::new(&nominal, &measured).load(LOAD_KG))
            .unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let settings = RunSettings {
            identify_load_kg: LOAD_KG,
            other_load_kg: None,
            choice: Choice::Detmax(DetmaxOptions {
                starts: 1,
                ..Default::default()
            }),
            identify: IdentifyOptions::default(),
        };
        let r = calibration
            .option(option::DEFAULT, &settings, &Silent)
            .unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let name = case.name;

        // Written and read back: the very numbers.
        let file = result_calibration_file(&nominal, &r.identified, &r);
        let read = CalibrationFile::parse(&file.to_json())
            .unwrap_or_else(|e| panic!("{name}: a reader refuses what identify wrote: {e}"));
        assert_eq!(read, file, "{name}");

        // The file's rig predicts every held-out pose as identify's did.
        let (nominal_rig, calibrated) = rigs_of(&read);
        let held_out = calibration
            .inputs()
            .measurements
            .of(calibration.inputs().held_out(&r.pose_ids()), LOAD_KG);
        let samples: Vec<Sample> = held_out.iter().map(Sample::from).collect();
        let in_memory = r.identified.rig.tool_points(&samples).unwrap();
        let from_file = calibrated.tool_points(&samples).unwrap();
        let worst = in_memory
            .iter()
            .zip(&from_file)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(worst <= 1e-9, "{name}: {worst} m");

        // validate's figures on the file are identify's report.
        let reported = r.validation.as_ref().expect("held-out poses");
        let validated = validate(&nominal_rig, &calibrated, &held_out).unwrap();
        assert_eq!(validated.before, reported.before, "{name}");
        assert_eq!(validated.after, reported.after, "{name}");
        assert_eq!(
            read.validation.as_ref().map(|v| v.after),
            Some(reported.after),
            "{name}"
        );

        // The board accepts it, and its compensation (the firmware's own,
        // servo frame by servo frame, in f32) puts the calibrated arm's tool
        // point where the nominal arm's is, to within its 5 µm tolerance
        // (plus the single precision of the arms it was sent).
        let payload = lrmcal_engine::device::calibration::payload(&read, [0.0; JOINTS].into())
            .unwrap_or_else(|f| panic!("{name}: the board refuses it: {f}"));
        let config = firmware::Config::default();
        let board = lrmcal_engine::device::commanded::Commanded::new(
            &payload,
            CompensationMode::Full,
            LOAD_KG,
        );
        // On the board the calibrated servo curves make the pulses: a joint
        // stands at its command (its play aside, which the board offsets).
        let mut standing = calibrated.without_play();
        standing.command_curves = standing.arm.joints.map(|j| j.servo);
        let nominal_chain = read.board_arms().0.chain();
        let mut tried = 0;
        let mut worst_um = 0.0f64;
        for m in held_out.iter().step_by(9) {
            if board.command(&m.pose.q).is_err() {
                continue;
            }
            tried += 1;
            let mut compensator = firmware::compensator::Compensator::new(
                &payload,
                config.compensation,
                config.max_correction_rad,
            );
            let q32 = m.pose.q.map(|q| q as f32);
            let mut command = q32;
            for _ in 0..60 {
                command = compensator.step(&q32, CompensationMode::Full, LOAD_KG as f32);
                if compensator.report().converged {
                    break;
                }
            }
            assert!(
                compensator.report().converged,
                "{name}: pose {}: {:?}",
                m.pose.id,
                compensator.report()
            );
            let target = nominal_chain
                .tool_point(&m.pose.q, LOAD_KG, &SolverOptions::default())
                .unwrap();
            let reached = standing
                .evaluate(&Sample {
                    id: m.pose.id,
                    q: command.map(f64::from),
                    load_kg: LOAD_KG,
                    target: 0,
                    approach: [Approach::Rising; JOINTS].into(),
                })
                .unwrap()
                .tool_m;
            worst_um = worst_um.max((reached - target).norm() * 1e6);
        }
        assert!(tried >= 20, "{name}: {tried} poses tried");
        assert!(worst_um < 10.0, "{name}: {worst_um} µm");
        eprintln!(
            "{name}: held out {} poses, mean {:.3} mm after; file = memory to {worst:.1e} m; \
             board within {worst_um:.2} µm over {tried} poses",
            held_out.len(),
            reported.after.mean_m * 1e3
        );
    }
}
