//! The validation poses of the documented workflow, through the `lrmcal`
//! binary: `select` sets some candidates aside beside the poses to fit and
//! marks them in the list it writes; measured with the others, `identify
//! --poses` fits the fit poses and holds exactly the validation ones out (the
//! report's validation is on them and on nothing else, even when more poses
//! were measured); `--no-hold-out` fits them too; a list without roles keeps
//! the old behaviour (every measured pose not fitted validates).

mod common;

use std::collections::BTreeSet;
use std::path::Path;

use common::{lrmcal, p, text};
use lrmcal_core::dataset::PoseRow;
use lrmcal_core::io::pose_list::{self, PoseRole};
use lrmcal_engine::calib::results::report::Report;

/// Runs `lrmcal` with `args`; its standard output, or a failed test with all it printed.
fn ok(args: &[&str]) -> String {
    let out = lrmcal(args);
    assert!(out.status.success(), "lrmcal {args:?}: {}", text(&out));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The report `identify` wrote into `dir`.
fn report(dir: &Path) -> Report {
    Report::parse(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

/// The pose ids the report's only option fitted, and those it validated on.
fn fitted_and_held(report: &Report) -> (BTreeSet<u32>, BTreeSet<u32>) {
    assert_eq!(report.options.len(), 1);
    let o = &report.options[0];
    let held = o
        .validation
        .iter()
        .flat_map(|v| &v.per_pose)
        .map(|p| p.pose)
        .collect();
    (o.selected_poses.iter().copied().collect(), held)
}

#[test]
fn identify_holds_out_exactly_the_validation_poses_select_set_aside() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);
    ok(&["plan", "--out", p(&path("candidates.csv"))]);
    let printed = ok(&[
        "select",
        "--candidates",
        p(&path("candidates.csv")),
        "--validate",
        "8",
        "--compare-random",
        "0",
        "--out",
        p(&path("selected.csv")),
    ]);
    assert!(
        printed.contains("8 validation poses set aside"),
        "{printed}"
    );

    // The list reads back with its roles: 60 to fit, 8 others to validate on,
    // every one a candidate.
    let listed = pose_list::read_listed(&path("selected.csv")).unwrap();
    let fit: BTreeSet<u32> = pose_list::ids_with_role(&listed, PoseRole::Fit)
        .into_iter()
        .collect();
    let validate: BTreeSet<u32> = pose_list::ids_with_role(&listed, PoseRole::Validate)
        .into_iter()
        .collect();
    assert_eq!((fit.len(), validate.len()), (60, 8));
    assert!(fit.is_disjoint(&validate));
    let candidates: BTreeSet<u32> = pose_list::read(&path("candidates.csv"))
        .unwrap()
        .iter()
        .map(|r| r.pose.id)
        .collect();
    assert!(fit.is_subset(&candidates) && validate.is_subset(&candidates));

    // The documented workflow: the selected poses measured, the validation ones with them.
    ok(&[
        "simulate",
        "--poses",
        p(&path("selected.csv")),
        "--loads",
        "0,0.0663",
        "--out",
        p(&path("measured.csv")),
    ]);
    let identify = |measured: &str, list: &Path, out: &str, extra: &[&str]| {
        let (measured, out_dir) = (path(measured), path(out));
        let args = [
            &[
                "identify",
                "--measurements",
                p(&measured),
                "--load-kg",
                "0.0663",
                "--poses",
                p(list),
                "--out",
                p(&out_dir),
            ][..],
            extra,
        ]
        .concat();
        let printed = ok(&args);
        (printed, report(&out_dir))
    };
    let (printed, r) = identify("measured.csv", &path("selected.csv"), "cal", &[]);
    assert!(
        printed.contains("holding out the 8 validation poses of"),
        "{printed}"
    );
    let (fitted, held) = fitted_and_held(&r);
    assert_eq!(fitted, fit);
    assert_eq!(held, validate);
    let o = &r.options[0];
    // Both loads of each held-out pose validate: under the fitted load and across.
    assert_eq!(o.validation.as_ref().unwrap().per_pose.len(), 8);
    assert_eq!(o.cross_load.as_ref().unwrap().per_pose.len(), 8);
    // The fit's own errors are every fitted measurement's, none a held-out pose's.
    assert_eq!(o.fit.per_pose.len(), 60);
    assert!(o.fit.per_pose.iter().all(|p| fit.contains(&p.pose)));

    // More poses measured than the list names: still exactly its validation poses held out.
    ok(&[
        "simulate",
        "--poses",
        p(&path("candidates.csv")),
        "--loads",
        "0,0.0663",
        "--out",
        p(&path("all.csv")),
    ]);
    let (printed, r) = identify("all.csv", &path("selected.csv"), "cal-all", &[]);
    let unnamed = candidates.len() - fit.len() - validate.len();
    assert!(
        printed.contains(&format!("{unnamed} measured poses are not in")),
        "{printed}"
    );
    assert_eq!(fitted_and_held(&r), (fit.clone(), validate.clone()));

    // --no-hold-out: the validation poses are fitted too, nothing is held out.
    let (_, r) = identify(
        "measured.csv",
        &path("selected.csv"),
        "cal-every",
        &["--no-hold-out"],
    );
    let (fitted, held) = fitted_and_held(&r);
    assert_eq!(fitted, fit.union(&validate).copied().collect());
    assert!(held.is_empty() && r.options[0].validation.is_none());

    // A list without roles (as lists were before them): its poses are fitted,
    // every other measured pose validates.
    let fit_rows: Vec<PoseRow> = listed
        .iter()
        .filter(|l| l.role == PoseRole::Fit)
        .map(|l| l.row)
        .collect();
    pose_list::write(
        &path("old.csv"),
        &fit_rows,
        &[model::JointKind::Revolute; 6],
    )
    .unwrap();
    assert!(
        !std::fs::read_to_string(path("old.csv"))
            .unwrap()
            .contains("role")
    );
    let (_, r) = identify("all.csv", &path("old.csv"), "cal-old", &[]);
    let (fitted, held) = fitted_and_held(&r);
    assert_eq!(fitted, fit);
    assert_eq!(held, candidates.difference(&fit).copied().collect());
}
