//! `lrmcal import-tracker` on Motive takes made by a small generator: a
//! measurement run as the tracker records it (rest, move, ring, hold with
//! jitter, a brief occlusion, rest), Y-up, in metres or millimetres. The
//! positions come back per pose in Z-up millimetres; a take whose still
//! periods do not pair with the poses, or whose units are not Motive's, is
//! refused naming the file and what was expected, with nothing written.

mod common;

use common::lrmcal;

use std::fmt::Write as _;
use std::path::Path;
use std::process::Output;

use lrmcal_core::io::measurements;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The tool point at each pose, Z-up, mm (what `--up +y` must give back).
const POSES_MM: [[f64; 3]; 4] = [
    [212.4, -35.0, 188.8],
    [150.0, 120.5, 260.0],
    [-40.25, 210.0, 140.0],
    [90.0, -160.0, 320.5],
];
const HOME_MM: [f64; 3] = [0.0, 0.0, 540.0];

const POSE_LIST: &str = "pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n\
                         10,0.0663,0,10,-20,0,30,0\n11,0.0663,5,15,-25,0,35,0\n\
                         12,0.0663,-5,5,-15,0,25,0\n13,0.0663,20,-30,40,10,-20,5\n";

/// Motive's Y-up frame from a Z-up point: (x, y, z) -> (x, z, -y).
fn motive_frame(p: Vector3<f64>) -> Vector3<f64> {
    Vector3::new(p.x, p.z, -p.y)
}

/// A Motive CSV export of the run at 120 Hz: rest at home 2 s, then per pose a
/// 1.2 s move and a 2.5 s hold (0.8 mm ring, 0.05 mm jitter), then home and
/// rest 2 s. The tool is hidden for 0.2 s in the second hold. `units` is the
/// header's Length Units, `per_m` the numbers per metre.
fn motive_take(units: &str, per_m: f64) -> String {
    let rate = 120.0;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let jitter = Normal::new(0.0, 0.05).unwrap();
    let home = Vector3::from(HOME_MM);
    let mut path: Vec<Option<Vector3<f64>>> = Vec::new();
    let mut hold = |path: &mut Vec<_>, at: Vector3<f64>, s: f64, ring: bool, hide: bool| {
        for k in 0..(s * rate) as usize {
            let t = k as f64 / rate;
            let ring_mm = if ring {
                0.8 * (-t / 0.1).exp() * (std::f64::consts::TAU * 8.0 * t).cos()
            } else {
                0.0
            };
            let noise = Vector3::from_fn(|_, _| jitter.sample(&mut rng));
            let hidden = hide && (1.0..1.2).contains(&t);
            path.push((!hidden).then_some(at + Vector3::new(0.0, 0.0, ring_mm) + noise));
        }
    };
    let travel = |path: &mut Vec<_>, from: Vector3<f64>, to: Vector3<f64>| {
        let n = (1.2 * rate) as usize;
        for k in 0..n {
            let u = k as f64 / n as f64;
            path.push(Some(from + (to - from) * (3.0 * u * u - 2.0 * u * u * u)));
        }
    };
    hold(&mut path, home, 2.0, false, false);
    let mut at = home;
    for (i, p) in POSES_MM.iter().enumerate() {
        let p = Vector3::from(*p);
        travel(&mut path, at, p);
        hold(&mut path, p, 2.5, true, i == 1);
        at = p;
    }
    travel(&mut path, at, home);
    hold(&mut path, home, 2.0, false, false);

    let n = path.len();
    let mut out = format!(
        "Format Version,1.23,Take Name,arm-run-03,Take Notes,,Capture Frame Rate,120.000000,\
         Export Frame Rate,120.000000,Capture Start Time,2026-03-14 10.02.11.250 AM,\
         Total Frames in Take,{n},Total Exported Frames,{n},Rotation Type,Quaternion,\
         Length Units,{units},Coordinate Space,Global\n\n"
    );
    let columns = |label: &str, rb: &str, mk: &str| {
        format!(
            "{label}{}{}\n",
            format!(",{rb}").repeat(8),
            format!(",{mk}").repeat(3)
        )
    };
    out += &columns(",Type", "Rigid Body", "Marker");
    out += &columns(",Name", "Tool", "Base:Marker1");
    out += &columns(",ID", "1", "\"9E2075\"");
    out += ",,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,Mean Marker Error,\
            Position,Position,Position\n";
    out += "Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,,X,Y,Z\n";
    let base = motive_frame(Vector3::new(-300.0, 0.0, 5.0)) / 1000.0 * per_m;
    for (i, p) in path.iter().enumerate() {
        write!(out, "{i},{:.6},", i as f64 / rate).unwrap();
        match p {
            Some(p) => {
                let m = motive_frame(*p) / 1000.0 * per_m;
                write!(
                    out,
                    "0.000000,0.000000,0.000000,1.000000,{:.6},{:.6},{:.6},0.000120,",
                    m.x, m.y, m.z
                )
                .unwrap();
            }
            None => out.push_str(",,,,,,,,"),
        }
        writeln!(out, "{:.6},{:.6},{:.6}", base.x, base.y, base.z).unwrap();
    }
    out
}

/// `lrmcal import-tracker` on the files of [`files`], reading rigid body `body`.
fn import(files: &(String, String, String), body: &str, more: &[&str]) -> Output {
    let (take, poses, out) = files;
    let mut args = vec![
        "import-tracker",
        "--motive",
        take,
        "--rigid-body",
        body,
        "--poses",
        poses,
        "--out",
        out,
    ];
    args.extend(more);
    lrmcal(&args)
}

fn files(dir: &Path, take: &str) -> (String, String, String) {
    let (t, p, o) = (
        dir.join("take.csv"),
        dir.join("poses.csv"),
        dir.join("measured.csv"),
    );
    std::fs::write(&t, take).unwrap();
    std::fs::write(&p, POSE_LIST).unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_owned();
    (s(&t), s(&p), s(&o))
}

#[test]
fn each_hold_becomes_its_pose_in_z_up_millimetres() {
    for (units, per_m) in [("Meters", 1.0), ("Millimeters", 1000.0)] {
        let dir = tempfile::tempdir().unwrap();
        let paths = files(dir.path(), &motive_take(units, per_m));
        let out = &paths.2;
        let trim = ["--start-s", "1.9", "--end-s", "17.5", "--up", "+y"];
        let run = import(&paths, "Tool", &trim);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            stdout.contains("4 poses from rigid body `Tool` (arm-run-03)"),
            "{stdout}"
        );
        let rows = measurements::read(Path::new(out)).unwrap();
        assert_eq!(
            rows.iter().map(|m| m.pose.id).collect::<Vec<_>>(),
            [10, 11, 12, 13]
        );
        assert!(rows.iter().all(|m| m.load_kg == 0.0663));
        assert!((rows[3].pose.q[0].to_degrees() - 20.0).abs() < 1e-9);
        for (m, want) in rows.iter().zip(POSES_MM) {
            let error_mm = (m.position * 1000.0 - Vector3::from(want)).norm();
            // ~300 frames of 0.05 mm jitter and the ring's tail: a few µm.
            assert!(
                error_mm < 0.02,
                "{units}: pose {} off by {error_mm} mm",
                m.pose.id
            );
        }
    }
}

#[test]
fn the_rests_around_the_run_are_refused_as_extra_periods_listed_by_time() {
    let dir = tempfile::tempdir().unwrap();
    let paths = files(dir.path(), &motive_take("Meters", 1.0));
    let (take, poses, out) = &paths;
    let run = import(&paths, "Tool", &[]);
    assert_eq!(run.status.code(), Some(3));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.starts_with(&format!(
            "error: failed to match the still periods of `{take}` to the poses of `{poses}`: \
             expected 4 still periods, one per pose, found 6 (at least 1 s within 0.5 mm): 1: 0.00-2.0"
        )),
        "{err}"
    );
    // The first hold, after the 2 s rest and a 1.2 s move, and the final rest.
    assert!(err.contains(", 2: 3.2"), "{err}");
    assert!(
        err.contains(", 6: 17.9") && err.contains("--start-s/--end-s"),
        "{err}"
    );
    assert!(!Path::new(out).exists(), "nothing written");
}

#[test]
fn a_take_in_other_units_or_without_the_body_is_refused_at_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let paths = files(dir.path(), &motive_take("Inches", 39.37));
    let (take, _, out) = &paths;
    let run = import(&paths, "Tool", &[]);
    assert_eq!(run.status.code(), Some(3));
    let err = String::from_utf8_lossy(&run.stderr);
    assert_eq!(
        err.trim_end(),
        format!(
            "error: failed to import the take `{take}`: line 1, column `Length Units`: \
             expected one of Meters, Centimeters, Millimeters, found `Inches`"
        )
    );
    assert!(!Path::new(out).exists(), "nothing written");

    let paths = files(dir.path(), &motive_take("Meters", 1.0));
    let run = import(&paths, "Probe", &[]);
    assert_eq!(run.status.code(), Some(3));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains(
            "line 4: expected a rigid body named `Probe` with Position X, Y and Z columns; \
             the take has rigid bodies Tool; markers Base:Marker1"
        ),
        "{err}"
    );
    assert!(!Path::new(out).exists(), "nothing written");
}
