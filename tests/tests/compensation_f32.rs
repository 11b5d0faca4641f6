//! The firmware's per-frame f32 compensation on the bundled arm, judged by
//! the host's f64 model: commanded with the board's solution, the calibrated
//! (deflected, its springs softening) arm puts its tool within 0.05 mm of where the nominal arm
//! would, over 1000 random reachable targets, with and without the payload.
//!
//! "Reachable": the f64 model's own solve (cold, 60 iterations) converges,
//! with a correction no larger than the board accepts (`max_correction_rad`).

use firmware::Config;
use firmware::compensator::Compensator;
use model::testing::{ErrorSizes, random_errors};
use model::{CompensationOptions, ParamId, SolverOptions};
use protocol::{Calibration, CompensationMode, ModelOption};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Servo frames a cold start from rest may take: one Newton step per frame,
/// about three on average, a dozen for corrections near the board's bound.
const FRAMES_FROM_REST: usize = 20;

#[test]
fn board_compensation_reaches_nominal_targets_within_50_um() {
    let nominal = lrmcal_core::io::arm_source::bundled("lrm").unwrap().arm;
    let mut rng = StdRng::seed_from_u64(2024);
    let ids: Vec<ParamId> = ParamId::all(6).collect();
    let errors = random_errors(&mut rng, &ErrorSizes::CALIBRATED);
    let mut calibrated = nominal.with_errors(&ids, &errors);
    // Springs that soften as the simulator's do, one stiffening a little:
    // the board must compensate the model identification fits.
    calibrated.base_softening = 0.3;
    for (j, s) in calibrated
        .joints
        .iter_mut()
        .zip([0.3, 0.3, 0.5, -0.05, 0.3, 0.3])
    {
        j.softening = s;
    }
    let cal = lrmcal_engine::device::calibration::identified(Calibration {
        id: 0,
        option: ModelOption::ElastoKinematic,
        nominal: nominal.map(|x| x as f32),
        calibrated: calibrated.map(|x| x as f32),
        home_rad: [0.0; 6].into(),
        max_correction_rad: lrmcal_engine::device::calibration::max_corrections(
            &nominal,
            &calibrated,
        ),
    })
    .unwrap();
    // The host's f64 model of what was sent (the board gets f32 numbers).
    let nominal64 = cal.nominal.map(f64::from).chain();
    let calibrated64 = cal.calibrated.map(f64::from).chain();
    let reference = CompensationOptions {
        tolerance_m: 1e-7,
        damping_m: 1e-6,
        max_iterations: 60,
        settle_rad: 1e-9,
    };
    let limits = cal.calibrated.joints.map(|j| j.limits);

    let config = Config::default();
    for payload in [0.0f32, 0.0663] {
        let mut board = Compensator::new(&cal, config.compensation, config.max_correction_rad);
        let (mut worst, mut done, mut skipped, mut frames) = (0.0f64, 0, 0, 0);
        while done < 1000 {
            let q: [f32; 6] = std::array::from_fn(|i| rng.random_range(limits[i][0]..limits[i][1]));
            let q64 = q.map(f64::from);
            let target = nominal64
                .tool_point(&q64, payload.into(), &SolverOptions::default())
                .unwrap();
            // Reachable: the f64 model itself finds a command for it, within the
            // largest corrections the board accepts for this calibration (near
            // singular poses it needs more).
            let solved = calibrated64.compensate(&q64, &target, payload.into(), None, &reference);
            let within = |c: &model::Compensation<f64>| {
                c.converged
                    && c.q
                        .iter()
                        .zip(&q64)
                        .zip(&cal.max_correction_rad)
                        .all(|((a, b), m)| {
                            (a - b).abs() <= f64::from(m.min(config.max_correction_rad))
                        })
            };
            if !solved.is_ok_and(|c| within(&c)) {
                skipped += 1;
                continue;
            }
            done += 1;
            board.reset();
            let mut command = model::PerJoint::from(q);
            for _ in 0..FRAMES_FROM_REST {
                frames += 1;
                command = board.step(&q, CompensationMode::Full, payload);
                if board.report().converged {
                    break;
                }
            }
            assert!(board.report().converged, "q {q:?}: {:?}", board.report());
            let reached = calibrated64
                .tool_point(
                    &command.map(f64::from),
                    payload.into(),
                    &SolverOptions::default(),
                )
                .unwrap();
            worst = worst.max((reached - target).norm());
        }
        println!(
            "payload {payload} kg: worst {:.4} mm over 1000 targets, {frames} servo frames, {skipped} unreachable skipped",
            worst * 1e3
        );
        assert!(
            worst < 5e-5,
            "payload {payload}: worst {:.4} mm",
            worst * 1e3
        );
    }
}
