//! Tests of `identify`.

use super::*;
use crate::calib::parameters::prior::{self, Prior};
use crate::calib::parameters::servo_knots;
use crate::calib::testing::{key, measure, rigid_nominal, small_samples, true_errors};
use active_set::{outside_bounds, release_candidate};
use covariance::leave_one_out;
use levenberg_marquardt::LeastSquaresProblem;
use model::ParamId;
use nalgebra::DMatrix;
use robust::Weighting;

fn elastic_keys() -> Vec<ParamKey> {
    ["k2", "k3", "k4", "k5", "k0"].map(key).to_vec()
}

/// `nominal` with `errors` added to `keys`.
fn with_errors(nominal: &Rig, keys: &[ParamKey], errors: &[f64]) -> Rig {
    let mut v = ParamVector::new(keys.iter().copied()).unwrap();
    for (k, e) in keys.iter().zip(errors) {
        v.set(*k, *e).unwrap();
    }
    v.apply(nominal)
}

fn fit_data<'a>(nominal: &'a Rig, meas: &[Measurement]) -> FitData<'a> {
    FitData::new(nominal, ModelOption::Elastic, meas).unwrap()
}

/// The default fit (robust, prior, refresh) of the elastic option's `keys`.
fn fit_elastic(nominal: &Rig, keys: &[ParamKey], meas: &[Measurement]) -> Identified {
    identify(
        nominal,
        ModelOption::Elastic,
        keys,
        meas,
        &IdentifyOptions::default(),
    )
    .unwrap()
}

/// Measurements of an arm that sags *upwards* at joint 3: only a negative k3 would fit.
fn upward_sag(nominal: &Rig) -> Vec<Measurement> {
    let mut true_arm = with_errors(nominal, &elastic_keys(), &[0.1, 0.0, 0.08, 0.03, 0.02]).arm;
    true_arm.joints[2].compliance = -0.05;
    measure(&true_arm, &small_samples(16))
}

/// Noise-free data of a true arm that differs only in compliances: the fit
/// recovers them exactly and the residual vanishes.
#[test]
fn recovers_compliances_exactly() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let truth = [0.1, 0.05, 0.08, 0.03, 0.02];
    let meas = measure(
        &with_errors(&nominal, &keys, &truth).arm,
        &small_samples(16),
    );
    let fit = fit_elastic(&nominal, &keys, &meas);
    for (e, t) in fit.estimates.iter().zip(truth) {
        assert!((e.error - t).abs() < 1e-8, "{}: {} vs {t}", e.id, e.error);
    }
    assert!(fit.diagnostics.rms_after_m < 1e-9);
    assert!(fit.fit_residual.max_m < 1e-9);
    assert_eq!(fit.fit_residual.count, meas.len());
    assert!(fit.diagnostics.converged, "{}", fit.diagnostics.termination);
}

/// A true compliance of zero with data pulling it below zero stays at the
/// bound, and the bound is reported.
#[test]
fn compliances_never_go_negative() {
    let nominal = Rig::from(rigid_nominal());
    let meas = upward_sag(&nominal);
    let fit = fit_elastic(&nominal, &elastic_keys(), &meas);
    assert!(
        fit.rig.arm.joints.iter().all(|j| j.compliance >= 0.0)
            && fit.rig.arm.base_compliance >= 0.0
    );
    assert!(
        fit.diagnostics.at_bound.contains(&key("k3")),
        "{:?}",
        fit.estimates
    );
    // KKT: raising any compliance held at zero makes the fit worse.
    let data = fit_data(&nominal, &meas);
    let cost = |arm: &Rig| rms(&data.residual_norms(arm).unwrap());
    for &p in &fit.diagnostics.at_bound {
        let raised = with_errors(&fit.rig, &[p], &[1e-4]);
        assert!(cost(&raised) > cost(&fit.rig), "{p} should stay at zero");
    }
    assert!(fit.estimates[1].std.is_none());
}

/// With the round budget spent before the bound is met, the compliance is
/// fixed at its bound anyway: the estimate and the arm agree, and the arm
/// is physical.
#[test]
fn a_spent_round_budget_still_ends_inside_the_bounds() {
    let nominal = Rig::from(rigid_nominal());
    // Least squares: a prior's noise would be reweighted over more rounds.
    let one_round = IdentifyOptions {
        robust: false,
        max_active_set_rounds: 1,
        prior: false,
        ..Default::default()
    };
    let fit = identify(
        &nominal,
        ModelOption::Elastic,
        &elastic_keys(),
        &upward_sag(&nominal),
        &one_round,
    )
    .unwrap();
    assert_eq!(fit.diagnostics.active_set_rounds, 1);
    assert_eq!(fit.diagnostics.at_bound, [key("k3")]);
    let k3 = fit.estimates[1];
    assert_eq!((k3.id, k3.value, k3.std), (key("k3"), 0.0, None));
    assert_eq!(fit.rig.arm.joints[2].compliance, 0.0);
    for e in &fit.estimates {
        assert_eq!(e.value, e.id.value(&nominal) + e.error, "{}", e.id);
    }
}

/// A compliance held at zero while the data want it positive is the one
/// the active set releases; one that belongs at zero is not.
#[test]
fn release_names_the_compliance_whose_multiplier_has_the_wrong_sign() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let meas = measure(
        &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
        &small_samples(16),
    );
    let data = fit_data(&nominal, &meas);
    let sqrt_w = vec![1.0; meas.len()];
    let mut params = ParamVector::new(keys.iter().copied()).unwrap();
    params.fix(key("k4"), 0.0).unwrap();
    let arm = params.apply(&nominal);
    assert_eq!(
        release_candidate(&data, &params, &arm, Weighting::Scaled(&sqrt_w), 0.0),
        Some(key("k4"))
    );
    let sagging_up = upward_sag(&nominal);
    let data = fit_data(&nominal, &sagging_up);
    let mut params = ParamVector::new(keys.iter().copied()).unwrap();
    for (k, e) in keys.iter().zip([0.1, 0.0, 0.08, 0.03, 0.02]) {
        params.set(*k, e).unwrap();
    }
    params.fix(key("k3"), 0.0).unwrap();
    assert_eq!(
        release_candidate(
            &data,
            &params,
            &params.apply(&nominal),
            Weighting::Scaled(&sqrt_w),
            0.0
        ),
        None
    );
}

/// The covariance from the scaled SVD equals `s² (JᵀJ)⁻¹` computed directly.
#[test]
fn covariance_matches_the_normal_equations() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let mut meas = measure(
        &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
        &small_samples(16),
    );
    for (k, m) in meas.iter_mut().enumerate() {
        m.position.y += 2e-4 * ((k * 5 % 7) as f64 - 3.0);
    }
    let data = fit_data(&nominal, &meas);
    let arm = nominal.clone();
    let residuals = data.residuals(&arm).unwrap();
    let norms: Vec<f64> = residuals.iter().map(|r| r.norm()).collect();
    let weights: Vec<f64> = (0..meas.len()).map(|k| 0.5 + (k % 3) as f64).collect();
    let cov = covariance(&data, &arm, &keys, &weights, &residuals, None).unwrap();
    let sqrt_w: Vec<f64> = weights.iter().map(|w| w.sqrt()).collect();
    let j = data.weighted_jacobian(&arm, &keys, &sqrt_w).unwrap();
    let rss: f64 = norms.iter().zip(&weights).map(|(e, w)| w * e * e).sum();
    let s2 = rss / (3 * meas.len() - keys.len()) as f64;
    let direct = (j.transpose() * &j).try_inverse().unwrap() * s2;
    assert!((cov.sigma_m - s2.sqrt()).abs() < 1e-15);
    for (c, std) in cov.std.iter().enumerate() {
        let expected = direct[(c, c)].sqrt();
        assert!(
            (std - expected).abs() < 1e-8 * expected,
            "{}: {std} vs {expected}",
            keys[c]
        );
    }
}

/// The leave-one-out errors from the hat matrix equal those of refitting a
/// linear problem without each measurement in turn; a measurement that
/// alone decides a parameter cannot be predicted.
#[test]
fn leave_one_out_equals_refitting_without_each_measurement() {
    let (n, m) = (8, 5);
    let j = DMatrix::from_fn(3 * n, m, |r, c| {
        ((r * 7 + c * 13) % 11) as f64 - 5.0 + 0.1 * c as f64
    });
    let y = DVector::from_fn(3 * n, |r, _| ((r * 5) % 9) as f64 * 0.3 - 1.0);
    let fit = |rows: &[usize]| {
        let a = j.select_rows(rows);
        let b = y.select_rows(rows);
        (a.transpose() * &a).try_inverse().unwrap() * a.transpose() * b
    };
    let all: Vec<usize> = (0..3 * n).collect();
    let beta = fit(&all);
    let r = &y - &j * &beta;
    let residuals: Vec<Vector3<f64>> = (0..n)
        .map(|k| Vector3::new(r[3 * k], r[3 * k + 1], r[3 * k + 2]))
        .collect();
    let u = j.clone().svd(true, false).u.unwrap();
    let refitted_each: Vec<f64> = (0..n)
        .map(|k| {
            let rest: Vec<usize> = all.iter().copied().filter(|i| i / 3 != k).collect();
            let beta_k = fit(&rest);
            (y.rows(3 * k, 3) - j.rows(3 * k, 3) * beta_k).norm()
        })
        .collect();
    let refitted = refitted_each.iter().sum::<f64>() / n as f64;
    let (each, loo) = leave_one_out(&u, &residuals);
    assert!(
        (loo - refitted).abs() < 1e-9 * refitted,
        "{loo} vs {refitted}"
    );
    for (e, r) in each.iter().zip(&refitted_each) {
        assert!((e - r).abs() < 1e-9 * r, "{e} vs {r}");
    }
    assert!(loo > residuals.iter().map(|r| r.norm()).sum::<f64>() / n as f64);
    // Five parameters from two measurements (six rows): the first
    // measurement's rows are all the data have for some direction.
    let two = j.rows(0, 6).clone_owned();
    let u = two.svd(true, false).u.unwrap();
    let (_, loo) = leave_one_out(&u, &residuals[..2]);
    assert!(loo.is_infinite() || loo > 1e6, "{loo}");
}

/// The fit's range of each bounded parameter is the arm's physical one
/// (`model::bounds`), just inside; a value above it is outside.
#[test]
fn fit_ranges_are_the_arms_bounds_just_inside() {
    let nominal = Rig::from(rigid_nominal());
    let meas = measure(&nominal.arm, &small_samples(12));
    let data = fit_data(&nominal, &meas);
    let bounds = nominal.bounds;
    assert_eq!(bounds, model::bounds::Bounds::of(&nominal.arm));
    let k3 = key("k3");
    let (lo, hi) = data.bounds(k3);
    assert_eq!(lo, Some(0.0));
    let ceiling = model::bounds::MAX_SAG_RAD / bounds.torque_nm(3);
    assert!(hi.unwrap() < ceiling && hi.unwrap() > ceiling * (1.0 - 1e-4));
    let (s_lo, s_hi) = data.bounds(ParamKey::Softening { spring: 2 });
    assert!(s_lo.unwrap() > -0.5 / bounds.torque_nm(2) && s_lo.unwrap() < 0.0);
    assert!(s_hi.unwrap() < 1.0 / bounds.torque_nm(2));
    assert_eq!(data.bounds(key("j2.d")), (None, None));
    let mut params = ParamVector::new(elastic_keys()).unwrap();
    params.set(k3, 2.0 * hi.unwrap()).unwrap();
    let arm = params.apply(&nominal);
    assert_eq!(outside_bounds(&data, &params, &arm), [(k3, hi.unwrap())]);
}

/// A trial point whose deflection diverges is a failed step with a huge
/// residual, counted, not the end of the fit.
#[test]
fn an_unsolvable_trial_point_is_a_failed_step() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let meas = measure(
        &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
        &small_samples(8),
    );
    let data = fit_data(&nominal, &meas);
    let params = ParamVector::new(keys.iter().copied()).unwrap();
    let sqrt_w = vec![1.0; meas.len()];
    let mut problem = Problem {
        data: &data,
        params: &params,
        free: keys.clone(),
        weighting: Weighting::Scaled(&sqrt_w),
        sigma: 0.0,
        x: DVector::zeros(keys.len()),
        failed_entry: 7.0,
        failed: std::cell::Cell::new(0),
    };
    let rows = (3 * meas.len()) as f64;
    assert!(problem.residuals().unwrap()[0] != 7.0 * rows.sqrt());
    problem.set_params(&DVector::from_element(keys.len(), 500.0));
    assert!(data.residual_norms(&problem.arm()).is_err());
    // Every row of the stacked residuals at 7: the solver sees their norm.
    let r = problem.residuals().unwrap();
    assert_eq!(r.len(), keys.len() + 1);
    assert!(
        (r[0] - 7.0 * rows.sqrt()).abs() < 1e-12 && r.rows(1, keys.len()).iter().all(|v| *v == 0.0)
    );
    assert_eq!(problem.failed.get(), 1);
}

#[test]
fn huber_weights_down_weight_only_beyond_the_threshold() {
    // Median 1.5382 makes the robust scale 1, so the threshold is HUBER_K.
    let norms = [0.0, 1.0, 1.2, 1.5382, 2.9, 6.0, 30.0];
    let w = huber_weights(&norms, 3);
    assert_eq!(w[..5], [1.0; 5]);
    assert!((w[5] - HUBER_K / 6.0).abs() < 1e-12);
    assert!((w[6] - HUBER_K / 30.0).abs() < 1e-12);
}

/// Beyond the threshold a block is shortened to the root of Huber's cost,
/// and its map is the slope of that shortening; within, it is untouched.
#[test]
fn huber_blocks_carry_the_cost_and_its_slope() {
    let c = 0.5;
    let huber = Weighting::Huber(c);
    let inside = Vector3::new(0.1, -0.2, 0.3);
    let (r, map) = huber.block(0, &inside);
    assert_eq!((r, map), (inside, nalgebra::Matrix3::identity()));
    let beyond = Vector3::new(1.2, -0.7, 2.0);
    let e = beyond.norm();
    let (r, map) = huber.block(0, &beyond);
    assert!((r.norm_squared() - (2.0 * c * e - c * c)).abs() < 1e-12);
    assert!((r.normalize() - beyond.normalize()).norm() < 1e-12);
    let h = 1e-6;
    for axis in 0..3 {
        let step = Vector3::ith(axis, h);
        let slope =
            (huber.block(0, &(beyond + step)).0 - huber.block(0, &(beyond - step)).0) / (2.0 * h);
        assert!((slope - map.column(axis)).norm() < 1e-8, "axis {axis}");
    }
}

/// The robust fit ends where Huber's cost is stationary: the gradient of
/// the measurements' cost, each weighted as Huber's function weighs it,
/// vanishes beside that of plain least squares at the same point (which
/// the gross error pulls).
#[test]
fn the_robust_fit_ends_where_hubers_cost_is_stationary() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let samples = small_samples(24);
    let mut meas = measure(
        &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
        &samples,
    );
    for (k, m) in meas.iter_mut().enumerate() {
        m.position.y += 2e-4 * ((k * 5 % 7) as f64 - 3.0);
    }
    meas[3].position.x -= 0.015;
    let fit = fit_elastic(&nominal, &keys, &meas);
    assert!(fit.diagnostics.irls_rounds < 12, "{:?}", fit.diagnostics);
    let data = fit_data(&nominal, &meas);
    let norms = data.residual_norms(&fit.rig).unwrap();
    let gradient = |weights: &[f64]| {
        let (r, j) = data
            .weighted_with_jacobian(&fit.rig, &keys, Weighting::Scaled(weights))
            .unwrap();
        (j.transpose() * r).norm()
    };
    let sqrt_huber: Vec<f64> = huber_weights(&norms, 3).iter().map(|w| w.sqrt()).collect();
    let robust = gradient(&sqrt_huber);
    let plain = gradient(&vec![1.0; meas.len()]);
    assert!(robust < 1e-2 * plain, "robust {robust:e} plain {plain:e}");
}

#[test]
fn outliers_are_named_largest_first() {
    let samples = small_samples(7);
    let norms = [1.0, 1.5382, 9.0, 2.0, 0.5, 4.4, 7.0];
    let weights = [1.0, 1.0, 0.3, 1.0, 1.0, 1.0, 0.4];
    let o = name_outliers(&samples, &norms, &weights, 3);
    let named: Vec<(u32, f64)> = o.iter().map(|o| (o.pose, o.weight)).collect();
    assert_eq!(named, [(2, 0.3), (6, 0.4)]);
    assert_eq!(o[0].load_kg, samples[2].load_kg);
    assert!(name_outliers(&samples, &[0.0; 7], &weights, 3).is_empty());
}

/// One corrupted measurement is named, and the robust fit is not pulled by it.
#[test]
fn robust_fit_names_and_ignores_an_outlier() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let truth = [0.1, 0.05, 0.08, 0.03, 0.02];
    let samples = small_samples(24);
    let mut meas = measure(&with_errors(&nominal, &keys, &truth).arm, &samples);
    // Small noise so the robust scale is not zero, then one gross error.
    for (k, m) in meas.iter_mut().enumerate() {
        m.position.x += 1e-4 * ((k * 7 % 5) as f64 - 2.0);
    }
    meas[5].position.z += 0.02;
    // Robust is the default.
    let fit = fit_elastic(&nominal, &keys, &meas);
    assert_eq!(fit.outliers.first().map(|o| o.pose), Some(meas[5].pose.id));
    assert!(fit.outliers[0].weight < 0.1);
    let squared = IdentifyOptions {
        robust: false,
        ..Default::default()
    };
    let plain = identify(&nominal, ModelOption::Elastic, &keys, &meas, &squared).unwrap();
    assert_eq!(plain.outliers[0].weight, 1.0);
    let err = |f: &Identified| {
        f.estimates
            .iter()
            .zip(truth)
            .map(|(e, t)| (e.error - t).abs())
            .fold(0.0, f64::max)
    };
    assert!(
        err(&fit) < 0.5 * err(&plain),
        "robust {} plain {}",
        err(&fit),
        err(&plain)
    );
}

#[test]
fn too_few_and_rank_deficient_sets_are_refused() {
    let nominal = Rig::from(rigid_nominal());
    let all: Vec<ParamKey> = ParamId::all(6).map(ParamKey::Arm).collect();
    let meas = measure(
        &with_errors(&nominal, &all, &true_errors(1)).arm,
        &small_samples(20),
    );
    let opts = IdentifyOptions {
        prior: false,
        ..Default::default()
    };
    assert!(matches!(
        identify(
            &nominal,
            ModelOption::ElastoKinematic,
            &all,
            &meas[..5],
            &opts
        ),
        Err(CalibError::TooFewPoses { params: 43, .. })
    ));
    // Under a prior the compliances and the six twists are determined
    // whatever the poses: the rest of the geometry's 36 is what the poses
    // must carry.
    assert!(matches!(
        identify(
            &nominal,
            ModelOption::ElastoKinematic,
            &all,
            &meas[..5],
            &IdentifyOptions::default()
        ),
        Err(CalibError::TooFewPoses { params: 30, .. })
    ));
    // All 43 include the tool rotation, which no position can reveal.
    let err = identify(&nominal, ModelOption::ElastoKinematic, &all, &meas, &opts).unwrap_err();
    assert!(matches!(err, CalibError::RankDeficient { .. }), "{err}");
}

/// `measurements` with a deterministic noise of about `size` m on each axis.
fn noisy(mut measurements: Vec<Measurement>, size: f64) -> Vec<Measurement> {
    for (k, m) in measurements.iter_mut().enumerate() {
        let wobble = |a: usize, b: usize| size * (((k * a + b) % 7) as f64 - 3.0) / 2.0;
        m.position += Vector3::new(wobble(3, 1), wobble(5, 2), wobble(2, 4));
    }
    measurements
}

/// Where the poses determine every parameter well, the prior weighs
/// nothing beside them: the most probable fit is the least-squares one,
/// with the same deviations and the same noise.
#[test]
fn a_prior_changes_nothing_the_poses_determine() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let truth = [0.1, 0.05, 0.08, 0.03, 0.02];
    let meas = noisy(
        measure(
            &with_errors(&nominal, &keys, &truth).arm,
            &small_samples(40),
        ),
        1e-4,
    );
    let plain = IdentifyOptions {
        prior: false,
        ..Default::default()
    };
    let ls = identify(&nominal, ModelOption::Elastic, &keys, &meas, &plain).unwrap();
    let (map, evidence) = identify_scored(
        &nominal,
        &nominal,
        ModelOption::Elastic,
        &keys,
        &meas,
        &IdentifyOptions::default(),
    )
    .unwrap();
    assert!(evidence.is_some_and(f64::is_finite));
    for (a, b) in ls.estimates.iter().zip(&map.estimates) {
        let (sa, sb) = (a.std.unwrap(), b.std.unwrap());
        assert!(
            (a.error - b.error).abs() < 0.05 * sa,
            "{}: {} vs {} (std {sa})",
            a.id,
            a.error,
            b.error
        );
        assert!((sa - sb).abs() < 0.02 * sa, "{}: std {sa} vs {sb}", a.id);
    }
    let (s_ls, s_map) = (ls.diagnostics.sigma_m, map.diagnostics.sigma_m);
    assert!((s_ls - s_map).abs() < 0.02 * s_ls, "{s_ls} vs {s_map}");
    assert!(
        (ls.diagnostics.loo_mean_m - map.diagnostics.loo_mean_m).abs()
            < 0.02 * ls.diagnostics.loo_mean_m
    );
}

/// Joint 2 never above 0°: the knots of its curve at 25°, 50° and 75° move
/// no measured point. Least squares cannot fit them; under the prior they
/// stay near the arm file's curve, as smooth a continuation of what the
/// poses see as the prior says, with deviations that say so (neither
/// vanishing nor unbounded), while the knots the poses see are found.
#[test]
fn a_prior_holds_what_the_poses_do_not_see() {
    use crate::calib::parameters::prior::SERVO_SD_DEG;
    let nominal = Rig::from(rigid_nominal());
    let mut samples = small_samples(30);
    let qs: Vec<model::PerJoint<f64>> = samples
        .iter()
        .map(|s| {
            let mut q = s.q;
            q[1] = -q[1].abs();
            q
        })
        .collect();
    for ((s, q), a) in samples
        .iter_mut()
        .zip(&qs)
        .zip(lrmcal_core::dataset::approaches(&qs))
    {
        s.q = *q;
        s.approach = a;
    }
    // Knots 0..=7 of joint 2 every 25°, the one at +100° held.
    let knots: Vec<ParamKey> = (0..8)
        .map(|knot| ParamKey::ServoKnot { joint: 1, knot })
        .collect();
    let keys: Vec<ParamKey> = ["base.x", "base.y", "base.z", "j2.a"]
        .map(key)
        .into_iter()
        .chain(knots.iter().copied())
        .collect();
    let start = servo_knots::fit_start(&nominal, &keys);
    let seen = [0.010, -0.006, 0.004, 0.012, 0.008];
    let unseen = [0.030, -0.030, 0.030];
    let mut offsets = vec![0.0005, -0.0003, 0.0004, 0.0002];
    offsets.extend(seen.iter().chain(&unseen));
    let truth = with_errors(&start, &keys, &offsets);
    let meas = noisy(crate::calib::testing::measure_rig(&truth, &samples), 1e-4);
    let plain = IdentifyOptions {
        prior: false,
        ..Default::default()
    };
    assert!(matches!(
        identify(
            &nominal,
            ModelOption::ElastoKinematicServo,
            &keys,
            &meas,
            &plain
        ),
        Err(CalibError::RankDeficient { .. })
    ));
    let fit = identify(
        &nominal,
        ModelOption::ElastoKinematicServo,
        &keys,
        &meas,
        &IdentifyOptions::default(),
    )
    .unwrap();
    let sd = SERVO_SD_DEG.to_radians();
    let estimate = |k: ParamKey| fit.estimates.iter().find(|e| e.id == k).copied().unwrap();
    for (k, t) in knots[..5].iter().zip(seen) {
        let e = estimate(*k);
        assert!((e.error - t).abs() < 0.1 * sd, "{k}: {} vs {t}", e.error);
    }
    for k in &knots[5..] {
        let e = estimate(*k);
        let std = e.std.unwrap();
        assert!(e.error.abs() < 2.0 * sd, "{k}: {}", e.error);
        // The smooth curve between 0° (seen) and +100° (held) pins the
        // middle more than either end, never to nothing.
        assert!(std > 0.05 * sd && std < 2.0 * sd, "{k}: std {std}");
    }
    assert!(fit.diagnostics.sigma_m < 3e-4, "{:?}", fit.diagnostics);
}

/// Under a prior the covariance is the posterior's, `s² (JᵀJ + PᵀP)⁻¹`
/// (`P` the prior's rows scaled by the noise), and `s²` counts as
/// parameters only what the measurements determine, `tr H`, with the
/// singular vectors or without them.
#[test]
fn the_posterior_covariance_matches_the_regularised_normal_equations() {
    let nominal = Rig::from(rigid_nominal());
    let keys = elastic_keys();
    let meas = noisy(
        measure(
            &with_errors(&nominal, &keys, &[0.1, 0.05, 0.08, 0.03, 0.02]).arm,
            &small_samples(6),
        ),
        2e-4,
    );
    let data = fit_data(&nominal, &meas);
    let arm = nominal.clone();
    let residuals = data.residuals(&arm).unwrap();
    let weights = vec![1.0; meas.len()];
    let prior = Prior::new(&nominal, &nominal, &keys, prior::SERVO_CORRELATION_DEG).unwrap();
    let sigma = 3e-3;
    let p = prior.columns(&[0, 1, 2, 3, 4]) * sigma;
    let cov = covariance(&data, &arm, &keys, &weights, &residuals, Some(&p)).unwrap();
    let j = data.weighted_jacobian(&arm, &keys, &weights).unwrap();
    let normal = (j.transpose() * &j + p.transpose() * &p)
        .try_inverse()
        .unwrap();
    let determined = (&j * &normal * j.transpose()).trace();
    assert!(
        determined > 0.0 && determined < keys.len() as f64,
        "{determined}"
    );
    let rss: f64 = residuals.iter().map(|r| r.norm_squared()).sum();
    let s2 = rss / (3.0 * meas.len() as f64 - determined);
    assert!((cov.sigma_m - s2.sqrt()).abs() < 1e-9 * s2.sqrt());
    // The noise alone, read on the triangular factor, is the same.
    let alone =
        covariance::noise_sigma(&data, &arm, &keys, &weights, &residuals, Some(&p)).unwrap();
    assert!(
        (alone - s2.sqrt()).abs() < 1e-9 * s2.sqrt(),
        "{alone} vs {}",
        s2.sqrt()
    );
    for c in 0..keys.len() {
        let expected = (normal[(c, c)] * s2).sqrt();
        assert!(
            (cov.std[c] - expected).abs() < 1e-8 * expected,
            "{}: {} vs {expected}",
            keys[c],
            cov.std[c]
        );
        assert!((cov.matrix[(c, c)].sqrt() - expected).abs() < 1e-8 * expected);
    }
}

/// The leave-one-out errors of a regularised linear fit from its hat
/// matrix equal those of refitting, prior kept, without each measurement.
#[test]
fn regularised_leave_one_out_equals_refitting_without_each_measurement() {
    let (n, m) = (4, 6);
    let j = DMatrix::from_fn(3 * n, m, |r, c| {
        ((r * 7 + c * 13) % 11) as f64 - 5.0 + 0.1 * c as f64
    });
    let p = DMatrix::from_fn(m, m, |r, c| if r == c { 0.5 + 0.1 * r as f64 } else { 0.0 });
    let y = DVector::from_fn(3 * n, |r, _| ((r * 5) % 9) as f64 * 0.3 - 1.0);
    let fit = |rows: &[usize]| {
        let a = j.select_rows(rows);
        let b = y.select_rows(rows);
        (a.transpose() * &a + p.transpose() * &p)
            .try_inverse()
            .unwrap()
            * a.transpose()
            * b
    };
    let all: Vec<usize> = (0..3 * n).collect();
    let r = &y - &j * fit(&all);
    let residuals: Vec<Vector3<f64>> = (0..n)
        .map(|k| Vector3::new(r[3 * k], r[3 * k + 1], r[3 * k + 2]))
        .collect();
    let u = stack(j.clone(), Some(p.clone()))
        .svd(true, false)
        .u
        .unwrap();
    let (each, _) = leave_one_out(&u, &residuals);
    for (k, e) in each.iter().enumerate() {
        let rest: Vec<usize> = all.iter().copied().filter(|i| i / 3 != k).collect();
        let refitted = (y.rows(3 * k, 3) - j.rows(3 * k, 3) * fit(&rest)).norm();
        assert!((e - refitted).abs() < 1e-9 * refitted, "{e} vs {refitted}");
    }
}

/// The evidence tells how smooth a servo's error is: measurements of a
/// curve that bends gently are more probable under the smoother prior,
/// those of one that zigzags from knot to knot under the rougher one.
#[test]
fn the_evidence_prefers_the_smoothness_the_curve_has() {
    let nominal = Rig::from(rigid_nominal());
    let knots: Vec<ParamKey> = (0..8)
        .map(|knot| ParamKey::ServoKnot { joint: 1, knot })
        .collect();
    let keys: Vec<ParamKey> = ["base.x", "base.y", "base.z"]
        .map(key)
        .into_iter()
        .chain(knots.iter().copied())
        .collect();
    let start = servo_knots::fit_start(&nominal, &keys);
    let angle = |k: usize| (k as f64 - 4.0) * 25f64.to_radians();
    let evidence = |error: &dyn Fn(usize) -> f64, correlation_deg: f64| {
        // Each knot's error less the held one's at +100°.
        let mut offsets = vec![0.0; 3];
        offsets.extend((0..8).map(|k| error(k) - error(8)));
        let truth = with_errors(&start, &keys, &offsets);
        let meas = noisy(
            crate::calib::testing::measure_rig(&truth, &small_samples(40)),
            1e-4,
        );
        let options = IdentifyOptions {
            servo_correlation_deg: correlation_deg,
            ..Default::default()
        };
        identify_scored(
            &nominal,
            &nominal,
            ModelOption::ElastoKinematicServo,
            &keys,
            &meas,
            &options,
        )
        .unwrap()
        .1
        .unwrap()
    };
    let gentle = |k: usize| 0.02 * (0.8 * angle(k)).sin();
    let zigzag = |k: usize| if k.is_multiple_of(2) { 0.02 } else { -0.02 };
    assert!(evidence(&gentle, 100.0) > evidence(&gentle, 25.0));
    assert!(evidence(&zigzag, 25.0) > evidence(&zigzag, 100.0));
}
