//! DETMAX's choice is a function of the set of candidate poses: the rows of
//! the candidate file in another order give the same poses, and the
//! canonical order costs nothing in D-optimality.

use std::collections::BTreeSet;

use lrmcal_core::dataset::{Pose, PoseRow};
use lrmcal_core::io::pose_list;
use lrmcal_engine::calib::ModelOption;
use lrmcal_engine::calib::analysis::detmax::{DetmaxOptions, detmax};
use lrmcal_engine::calib::fit::pipeline::{CandidateBlocks, Choice, Selection};
use lrmcal_engine::calib::progress::Silent;
use lrmcal_engine::plan::{PlanConfig, candidates};
use model::testing::TEST_ARM_JOINTS as JOINTS;
use rand::seq::SliceRandom;
use rand::{SeedableRng, rngs::StdRng};

/// A pose as a set element: its joint angles' bits.
fn key(pose: &Pose) -> [u64; JOINTS] {
    std::array::from_fn(|j| pose.q[j].to_bits())
}

/// The bundled arm's candidate file as `lrmcal plan` writes it, as text.
fn candidate_file() -> (model::Arm<f64>, String) {
    let arm = lrmcal_core::io::arm_source::bundled("lrm")
        .expect("bundled arm")
        .arm;
    let kept = candidates(&arm, &PlanConfig::default())
        .expect("the grid plans")
        .kept;
    let rows: Vec<PoseRow> = kept
        .iter()
        .map(|&pose| PoseRow {
            pose,
            load_kg: None,
        })
        .collect();
    let mut text = Vec::new();
    pose_list::write_to(&mut text, &rows, &[model::JointKind::Revolute; 6])
        .expect("written to memory");
    (arm, String::from_utf8(text).expect("UTF-8"))
}

/// The same file with its data rows in another order.
fn reordered(text: &str, order: impl FnOnce(&mut Vec<&str>)) -> String {
    let mut lines: Vec<&str> = text.lines().collect();
    let header = lines.remove(0);
    order(&mut lines);
    format!("{header}\n{}\n", lines.join("\n"))
}

#[test]
fn shuffled_candidate_rows_give_the_same_selection() {
    let (arm, text) = candidate_file();
    let options = DetmaxOptions {
        starts: 2,
        ..Default::default()
    };
    let select = |text: &str| {
        let poses: Vec<Pose> = pose_list::parse(text)
            .expect("the candidate file parses")
            .iter()
            .map(|r| r.pose)
            .collect();
        let blocks =
            CandidateBlocks::build(&arm.into(), ModelOption::ElastoKinematic, &poses, &[0.0663])
                .expect("the candidates are analysed");
        let s = Selection::choose(blocks, &poses, &Choice::Detmax(options), &Silent)
            .expect("DETMAX selects");
        let set: BTreeSet<[u64; JOINTS]> = s.poses.iter().map(key).collect();
        (set, s.design.log_det)
    };
    let (first, log_det) = select(&text);
    assert_eq!(first.len(), options.n);
    let by_id_descending = reordered(&text, |l| l.reverse());
    let mut files = vec![by_id_descending];
    for seed in [1, 2] {
        files.push(reordered(&text, |l| {
            l.shuffle(&mut StdRng::seed_from_u64(seed))
        }));
    }
    for (i, other) in files.iter().enumerate() {
        assert_ne!(*other, text);
        let (set, other_log_det) = select(other);
        assert_eq!(
            set.symmetric_difference(&first).count(),
            0,
            "permutation {i} selects other poses"
        );
        assert!((other_log_det - log_det).abs() < 1e-9 * log_det.abs());
    }
}

/// The canonical order is one order among many: DETMAX's criterion in it is
/// as good as on the order `lrmcal plan` writes.
#[test]
fn the_canonical_order_is_as_d_optimal_as_the_file_order() {
    let (arm, text) = candidate_file();
    let poses: Vec<Pose> = pose_list::parse(&text)
        .expect("parses")
        .iter()
        .map(|r| r.pose)
        .collect();
    let options = DetmaxOptions::default();
    let blocks =
        CandidateBlocks::build(&arm.into(), ModelOption::ElastoKinematic, &poses, &[0.0663])
            .expect("analysed");
    let in_file_order = detmax(&blocks.blocks, &options, &Silent).expect("selects");
    // What DETMAX on the rows as given reached before the canonical order,
    // for two shuffles of the same file (printed for the record).
    for seed in [1, 2] {
        let mut order: Vec<usize> = (0..poses.len()).collect();
        order.shuffle(&mut StdRng::seed_from_u64(seed));
        let shuffled: Vec<_> = order.iter().map(|&i| blocks.blocks[i].clone()).collect();
        let d = detmax(&shuffled, &options, &Silent).expect("selects");
        eprintln!("ln det, rows as given, shuffle {seed}: {:.4}", d.log_det);
    }
    let canonical = Selection::choose(blocks, &poses, &Choice::Detmax(options), &Silent)
        .expect("selects")
        .design;
    let m = canonical.log_det;
    eprintln!(
        "ln det: file order {:.4}, canonical order {m:.4}",
        in_file_order.log_det
    );
    assert!(canonical.log_det >= in_file_order.log_det - 1e-9 * m.abs());
}
