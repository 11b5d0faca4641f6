//! Serial chains as a URDF states them, evaluated without lrmcal's model:
//! the truth a chain test measures and the independent fit it compares
//! lrmcal with. A chain is its joints from the base link to the tip link,
//! each a fixed placement (the URDF `<origin>`) then a motion about or along
//! its axis; errors are 6-DOF corrections of every placement, fixed joints
//! included, as a real arm's parts are off. Nothing here uses DH.

use std::path::Path;
use std::process::{Command, Output};

use nalgebra::{DMatrix, DVector, Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// How a joint moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// Not at all: a placement only.
    Fixed,
    /// About its axis, rad.
    Revolute,
    /// Along its axis, m.
    Prismatic,
}

/// One URDF joint of the chain.
#[derive(Clone, Debug)]
pub struct Joint {
    /// How it moves.
    pub motion: Motion,
    /// Parent link -> joint frame at zero motion.
    pub origin: Isometry3<f64>,
    /// Unit axis in the joint frame.
    pub axis: Vector3<f64>,
    /// Lower and upper limit (rad or m).
    pub limits: (f64, f64),
}

/// The joints from the base link to the tip link.
#[derive(Clone, Debug)]
pub struct Chain {
    /// Base to tip.
    pub joints: Vec<Joint>,
}

impl Chain {
    /// The chain of `urdf` from `base` to `tip`.
    pub fn from_urdf(urdf: &str, base: &str, tip: &str) -> Chain {
        let robot = urdf_rs::read_from_string(urdf).expect("a URDF");
        let mut joints = Vec::new();
        let mut link = tip.to_owned();
        while link != base {
            let j = robot
                .joints
                .iter()
                .find(|j| j.child.link == link)
                .unwrap_or_else(|| panic!("no joint has child {link}"));
            let motion = match j.joint_type {
                urdf_rs::JointType::Fixed => Motion::Fixed,
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => Motion::Revolute,
                urdf_rs::JointType::Prismatic => Motion::Prismatic,
                ref other => panic!("joint type {other:?}"),
            };
            let limits = match j.joint_type {
                urdf_rs::JointType::Continuous => (-std::f64::consts::PI, std::f64::consts::PI),
                _ => (j.limit.lower, j.limit.upper),
            };
            let [x, y, z] = j.origin.xyz.0;
            let [r, p, w] = j.origin.rpy.0;
            joints.push(Joint {
                motion,
                origin: Isometry3::from_parts(
                    Translation3::new(x, y, z),
                    UnitQuaternion::from_euler_angles(r, p, w),
                ),
                axis: Vector3::from(j.axis.xyz.0).normalize(),
                limits,
            });
            link = j.parent.link.clone();
        }
        joints.reverse();
        Chain { joints }
    }

    /// The moving joints' kinds, base to tip.
    pub fn kinds(&self) -> Vec<Motion> {
        self.joints
            .iter()
            .map(|j| j.motion)
            .filter(|m| *m != Motion::Fixed)
            .collect()
    }

    /// The tip link's pose in the base link's frame at joint values `q`
    /// (one per moving joint).
    pub fn tip(&self, q: &[f64]) -> Isometry3<f64> {
        let mut pose = Isometry3::identity();
        let mut values = q.iter();
        for j in &self.joints {
            pose *= j.origin;
            match j.motion {
                Motion::Fixed => {}
                Motion::Revolute => {
                    let v = *values.next().expect("a value per moving joint");
                    pose *= UnitQuaternion::from_scaled_axis(j.axis * v);
                }
                Motion::Prismatic => {
                    let v = *values.next().expect("a value per moving joint");
                    pose *= Translation3::from(j.axis * v);
                }
            }
        }
        pose
    }

    /// The chain with every joint's placement moved by a 6-DOF error:
    /// `mm` millimetres of translation and `deg` degrees of rotation per
    /// axis, each drawn uniformly within the ranges with a random sign.
    pub fn perturbed(&self, rng: &mut impl Rng, mm: (f64, f64), deg: (f64, f64)) -> Chain {
        let mut chain = self.clone();
        for j in &mut chain.joints {
            j.origin *= small_pose(rng, mm, deg);
        }
        chain
    }
}

/// A pose of `mm` millimetres and `deg` degrees per axis, random signs.
pub fn small_pose(rng: &mut impl Rng, mm: (f64, f64), deg: (f64, f64)) -> Isometry3<f64> {
    let mut draw = |(lo, hi): (f64, f64)| {
        let v: f64 = rng.random_range(lo..=hi);
        if rng.random_bool(0.5) { v } else { -v }
    };
    let t = Vector3::new(draw(mm), draw(mm), draw(mm)) * 1e-3;
    let r = Vector3::new(draw(deg), draw(deg), draw(deg)).map(f64::to_radians);
    exp6(&t, &r)
}

/// The pose of translation `t` after rotation by the rotation vector `r`.
pub fn exp6(t: &Vector3<f64>, r: &Vector3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(*t), UnitQuaternion::from_scaled_axis(*r))
}

/// An arm as measured: its chain, where its base link stands in the
/// tracker's frame, and the measured point in the tip link's frame.
#[derive(Clone, Debug)]
pub struct Measured {
    /// The chain.
    pub chain: Chain,
    /// Tracker frame -> base link.
    pub base: Isometry3<f64>,
    /// The measured point in the tip link's frame, m.
    pub tool: Vector3<f64>,
}

impl Measured {
    /// The measured point in the tracker's frame at joint values `q`, m.
    pub fn point(&self, q: &[f64]) -> Vector3<f64> {
        (self.base * self.chain.tip(q) * nalgebra::Point3::from(self.tool)).coords
    }

    /// A least-squares fit of every joint placement's 6-DOF error, the
    /// base's pose and the tool point to `points` measured at `poses`,
    /// starting from `self` (the nominal chain near the answer): Gauss-Newton
    /// on the identifiable subspace (singular values below 1e-7 of the
    /// largest dropped, with every column scaled to unit norm), as a fit
    /// reduced to its identifiable subset predicts.
    pub fn fitted(&self, poses: &[Vec<f64>], points: &[Vector3<f64>]) -> Measured {
        let n = 6 * self.chain.joints.len() + 9;
        let at = |p: &DVector<f64>| -> Measured {
            let mut m = self.clone();
            for (k, j) in m.chain.joints.iter_mut().enumerate() {
                let e = p.fixed_rows::<6>(6 * k);
                j.origin *= exp6(&e.fixed_rows::<3>(0).into(), &e.fixed_rows::<3>(3).into());
            }
            let b = p.fixed_rows::<6>(n - 9);
            m.base *= exp6(&b.fixed_rows::<3>(0).into(), &b.fixed_rows::<3>(3).into());
            m.tool += Vector3::from(p.fixed_rows::<3>(n - 3));
            m
        };
        let residuals = |p: &DVector<f64>| -> DVector<f64> {
            let m = at(p);
            DVector::from_iterator(
                3 * poses.len(),
                poses
                    .iter()
                    .zip(points)
                    .flat_map(|(q, y)| (m.point(q) - y).iter().copied().collect::<Vec<_>>()),
            )
        };
        let mut p = DVector::zeros(n);
        let mut r = residuals(&p);
        for _ in 0..20 {
            let h = 1e-6;
            let mut jac = DMatrix::zeros(r.len(), n);
            for c in 0..n {
                let mut up = p.clone();
                up[c] += h;
                let mut down = p.clone();
                down[c] -= h;
                jac.set_column(c, &((residuals(&up) - residuals(&down)) / (2.0 * h)));
            }
            let norms: Vec<f64> = (0..n).map(|c| jac.column(c).norm().max(1e-300)).collect();
            for (c, norm) in norms.iter().enumerate() {
                jac.column_mut(c).scale_mut(1.0 / norm);
            }
            let svd = jac.svd(true, true);
            let largest = svd.singular_values.max();
            let step = svd
                .solve(&(-&r), 1e-7 * largest)
                .expect("an SVD with both factors");
            let mut step = DVector::from_iterator(n, step.iter().zip(&norms).map(|(s, k)| s / k));
            // Halve a step that does not lower the sum of squares.
            let mut next = &p + &step;
            let mut next_r = residuals(&next);
            while next_r.norm() > r.norm() && step.norm() > 1e-15 {
                step /= 2.0;
                next = &p + &step;
                next_r = residuals(&next);
            }
            if next_r.norm() > r.norm() {
                break;
            }
            let done = r.norm() - next_r.norm() < 1e-12 * r.norm();
            p = next;
            r = next_r;
            if done {
                break;
            }
        }
        at(&p)
    }
}

/// `count` joint configurations drawn uniformly within each moving joint's
/// limits, revolute joints within ±170° at most.
pub fn random_poses(chain: &Chain, count: usize, rng: &mut impl Rng) -> Vec<Vec<f64>> {
    let limits: Vec<(f64, f64)> = chain
        .joints
        .iter()
        .filter(|j| j.motion != Motion::Fixed)
        .map(|j| match j.motion {
            Motion::Revolute => {
                let cap = 170f64.to_radians();
                (j.limits.0.max(-cap), j.limits.1.min(cap))
            }
            _ => j.limits,
        })
        .collect();
    (0..count)
        .map(|_| {
            limits
                .iter()
                .map(|&(lo, hi)| rng.random_range(lo..=hi))
                .collect()
        })
        .collect()
}

/// The joint columns' header and one row's cells, in lrmcal's units.
fn joint_cells(kinds: &[Motion], q: &[f64]) -> (Vec<String>, Vec<String>) {
    kinds
        .iter()
        .zip(q)
        .enumerate()
        .map(|(i, (kind, v))| match kind {
            Motion::Prismatic => (format!("q{}_mm", i + 1), format!("{:.9}", v * 1e3)),
            _ => (format!("q{}_deg", i + 1), format!("{:.9}", v.to_degrees())),
        })
        .unzip()
}

/// A measurement file of `points` (m) at `poses`, ids from 1, no load.
pub fn measurements_csv(chain: &Chain, poses: &[Vec<f64>], points: &[Vector3<f64>]) -> String {
    let kinds = chain.kinds();
    let (header, _) = joint_cells(&kinds, &poses[0]);
    let mut text = format!("pose,load_kg,{},x_mm,y_mm,z_mm\n", header.join(","));
    for (k, (q, y)) in poses.iter().zip(points).enumerate() {
        let (_, cells) = joint_cells(&kinds, q);
        let y = y * 1e3;
        text += &format!(
            "{},0,{},{:.6},{:.6},{:.6}\n",
            k + 1,
            cells.join(","),
            y.x,
            y.y,
            y.z
        );
    }
    text
}

/// A pose list of `poses`, ids from 1.
pub fn pose_list_csv(chain: &Chain, poses: &[Vec<f64>]) -> String {
    let kinds = chain.kinds();
    let (header, _) = joint_cells(&kinds, &poses[0]);
    let mut text = format!("pose,{}\n", header.join(","));
    for (k, q) in poses.iter().enumerate() {
        let (_, cells) = joint_cells(&kinds, q);
        text += &format!("{},{}\n", k + 1, cells.join(","));
    }
    text
}

/// Mean distance between two lists of points, m.
pub fn mean_error(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len() as f64
}

/// A random serial chain of `moving` joints as a URDF from link `base` to
/// link `tip`: revolute and prismatic joints whose axes are parallel,
/// perpendicular or at a random angle to the one before, offsets along and
/// across them (a slide and a turn on one line among them, but no two
/// turns on one line), fixed joints between some moving ones, and links
/// with mass.
#[allow(dead_code)] // the chain test's, not the figures'
pub fn random_chain_urdf(rng: &mut impl Rng, moving: usize) -> String {
    let mut urdf = String::from("<?xml version=\"1.0\"?>\n<robot name=\"random_chain\">\n");
    let link = |name: &str, mass: f64| {
        format!(
            "  <link name=\"{name}\"><inertial><origin xyz=\"0.02 0 0.03\" rpy=\"0 0 0\"/>\
             <mass value=\"{mass}\"/><inertia ixx=\"1e-4\" ixy=\"0\" ixz=\"0\" iyy=\"1e-4\" \
             iyz=\"0\" izz=\"1e-4\"/></inertial></link>\n"
        )
    };
    urdf += &link("base", 1.0);
    let mut parent = "base".to_owned();
    let mut index = 0;
    let mut previous_axis = Vector3::z();
    let mut previous_kind = "none";
    let mut joint = |urdf: &mut String,
                     parent: &mut String,
                     kind: &str,
                     xyz: Vector3<f64>,
                     rpy: Vector3<f64>,
                     axis: Vector3<f64>,
                     limits: (f64, f64)| {
        index += 1;
        let child = format!("l{index}");
        *urdf += &link(&child, 0.1);
        *urdf += &format!(
            "  <joint name=\"j{index}\" type=\"{kind}\"><parent link=\"{parent}\"/>\
             <child link=\"{child}\"/><origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>\
             <axis xyz=\"{} {} {}\"/><limit lower=\"{}\" upper=\"{}\" effort=\"10\" \
             velocity=\"1\"/></joint>\n",
            xyz.x, xyz.y, xyz.z, rpy.x, rpy.y, rpy.z, axis.x, axis.y, axis.z, limits.0, limits.1
        );
        *parent = child;
    };
    for _ in 0..moving {
        if rng.random_bool(0.3) {
            let xyz = Vector3::new(
                rng.random_range(-0.05..0.05),
                rng.random_range(-0.05..0.05),
                rng.random_range(0.0..0.08),
            );
            let rpy = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            joint(
                &mut urdf,
                &mut parent,
                "fixed",
                xyz,
                rpy,
                Vector3::z(),
                (0.0, 0.0),
            );
            previous_axis =
                UnitQuaternion::from_euler_angles(rpy.x, rpy.y, rpy.z).inverse() * previous_axis;
        }
        // The axis relative to the one before, in this joint's frame.
        let parallel = rng.random_range(0..3) == 0;
        let axis = match rng.random_range(0..2) {
            _ if parallel => previous_axis,
            0 => {
                let across = previous_axis.cross(&Vector3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ));
                across.normalize()
            }
            _ => Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize(),
        };
        let (kind, limits) = if rng.random_bool(0.25) {
            ("prismatic", (0.0, 0.2))
        } else {
            ("revolute", (-2.6, 2.6))
        };
        // Offsets along the previous axis and across it. Two revolute
        // joints on one line turn the arm the same way, a redundant pair no
        // arm is built with: parallel revolute axes stand apart.
        let coaxial_pair = parallel && kind == "revolute" && previous_kind == "revolute";
        let along = rng.random_range(0.0..0.15);
        let across = if coaxial_pair || rng.random_bool(0.7) {
            rng.random_range(0.03..0.15)
        } else {
            0.0
        };
        let side = previous_axis
            .cross(&Vector3::new(0.3, -0.5, 0.8))
            .normalize();
        let xyz = previous_axis * along + side * across;
        joint(
            &mut urdf,
            &mut parent,
            kind,
            xyz,
            Vector3::zeros(),
            axis,
            limits,
        );
        previous_axis = axis;
        previous_kind = kind;
    }
    // The tip a little off the last joint.
    joint(
        &mut urdf,
        &mut parent,
        "fixed",
        Vector3::new(0.02, 0.01, 0.05),
        Vector3::zeros(),
        Vector3::z(),
        (0.0, 0.0),
    );
    urdf += "</robot>\n";
    urdf.replace(&format!("<link name=\"{parent}\">"), "<link name=\"tip\">")
        .replace(
            &format!("<child link=\"{parent}\"/>"),
            "<child link=\"tip\"/>",
        )
}

/// Tracker noise per axis, m.
pub const NOISE_M: f64 = 1e-4;

/// What one calibration of one chain reached.
#[derive(Debug)]
pub struct Outcome {
    /// RMS of the measurement noise drawn, 3D, m.
    pub noise_rms: f64,
    /// RMS of lrmcal's residuals on the fitted poses, 3D, m.
    pub residual_rms: f64,
    /// lrmcal's mean error on the validation poses against the truth, m.
    pub lrmcal_mean: f64,
    /// The independent fit's mean error on the same poses, m.
    pub independent_mean: f64,
}

fn rms(errors: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = errors.fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
    (sum / n as f64).sqrt()
}

/// Simulates `fit` and `check` poses of the chain `base`..`tip` of the URDF
/// at `urdf` with its placements perturbed (1-2 mm and 0.2-0.5° per axis),
/// a tool point 3-6 cm off the tip link and the base anywhere in the
/// tracker's frame; calibrates with `lrmcal identify --option option` and
/// checks with `lrmcal predict` (the `lrmcal` at `lrmcal`), beside the
/// independent fit.
pub fn calibrate(
    lrmcal: &Path,
    urdf: &Path,
    (base, tip): (&str, &str),
    option: &str,
    seed: u64,
    fit: usize,
) -> Outcome {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let nominal = Chain::from_urdf(&std::fs::read_to_string(urdf).unwrap(), base, tip);
    let tool = Vector3::new(
        rng.random_range(0.03..0.06),
        rng.random_range(-0.02..0.02),
        rng.random_range(-0.02..0.02),
    );
    let truth = Measured {
        chain: nominal.perturbed(&mut rng, (1.0, 2.0), (0.2, 0.5)),
        base: small_pose(&mut rng, (100.0, 500.0), (5.0, 60.0)),
        tool,
    };
    let fit_poses = random_poses(&nominal, fit, &mut rng);
    let check_poses = random_poses(&nominal, 200, &mut rng);
    let noise = Normal::new(0.0, NOISE_M).unwrap();
    let drawn: Vec<Vector3<f64>> = fit_poses
        .iter()
        .map(|_| Vector3::from_fn(|_, _| noise.sample(&mut rng)))
        .collect();
    let measured: Vec<Vector3<f64>> = fit_poses
        .iter()
        .zip(&drawn)
        .map(|(q, e)| truth.point(q) + e)
        .collect();
    let exact: Vec<Vector3<f64>> = check_poses.iter().map(|q| truth.point(q)).collect();

    // The independent fit starts from the nominal chain at the true base and
    // tool point: the least-squares answer it finds is the reference.
    let start = Measured {
        chain: nominal.clone(),
        ..truth.clone()
    };
    let independent = start.fitted(&fit_poses, &measured);
    let independent_points: Vec<Vector3<f64>> =
        check_poses.iter().map(|q| independent.point(q)).collect();

    let dir = tempfile::tempdir().unwrap();
    let file = |name: &str, content: String| {
        let path = dir.path().join(name);
        std::fs::write(&path, content).unwrap();
        path
    };
    let measurements = file("fit.csv", measurements_csv(&nominal, &fit_poses, &measured));
    let fitted_list = file("fit-poses.csv", pose_list_csv(&nominal, &fit_poses));
    let check_list = file("check-poses.csv", pose_list_csv(&nominal, &check_poses));
    let out = dir.path().join("cal");
    let ran = run(
        lrmcal,
        &[
            "identify",
            "--arm",
            p(urdf),
            "--base-link",
            base,
            "--tip-link",
            tip,
            "--measurements",
            p(&measurements),
            "--option",
            option,
            // The true chain stands level in its own frame, wherever the
            // tracker sees it from.
            "--level-base",
            "--out",
            p(&out),
        ],
    );
    assert!(
        ran.status.success(),
        "{}",
        String::from_utf8_lossy(&ran.stderr)
    );
    let calibration = out.join(format!("calibration-{option}.json"));
    let predict = |poses: &Path, name: &str| {
        let path = dir.path().join(name);
        let ran = run(
            lrmcal,
            &[
                "predict",
                "--arm",
                p(&calibration),
                "--poses",
                p(poses),
                "--approach",
                "middle",
                "--out",
                p(&path),
            ],
        );
        assert!(
            ran.status.success(),
            "{}",
            String::from_utf8_lossy(&ran.stderr)
        );
        lrmcal_core::io::predictions::read(&path)
            .expect("predict's own file reads back")
            .into_iter()
            .map(|p| p.position)
            .collect::<Vec<_>>()
    };
    let at_fit = predict(&fitted_list, "at-fit.csv");
    let at_check = predict(&check_list, "at-check.csv");
    Outcome {
        noise_rms: rms(drawn.iter().map(|e| e.norm())),
        residual_rms: rms(at_fit.iter().zip(&measured).map(|(a, b)| (a - b).norm())),
        lrmcal_mean: mean_error(&at_check, &exact),
        independent_mean: mean_error(&independent_points, &exact),
    }
}

/// Runs the `lrmcal` at `path` with `args`, its output captured.
fn run(path: &Path, args: &[&str]) -> Output {
    Command::new(path).args(args).output().expect("lrmcal runs")
}

/// `path` as a command-line argument.
fn p(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 path")
}
