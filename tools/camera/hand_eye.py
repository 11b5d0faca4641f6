"""What users do today, measured on lrmcal's own simulated images: OpenCV's hand-eye
calibration with the arm's nominal forward kinematics, beside lrmcal's camera.

For each seed, `lrmcal demo --camera` renders the images of a simulated arm (its true
geometry drawn around the nominal one) carrying an AprilTag grid on its flange, seen by
a fixed webcam. This script then does what a user of OpenCV (or easy_handeye, which
wraps it) would do with those images:
- finds the tags with OpenCV's ArUco detector (DICT_APRILTAG_36h11, sub-pixel corner
  refinement by default) and solves the board's pose in the camera (solvePnP, IPPE then
  Levenberg-Marquardt) with the camera's known intrinsics and distortion;
- takes the flange's pose from the nominal URDF that `lrmcal export --urdf --world`
  writes, at the commanded joint angles (all images, both loads);
- runs cv2.calibrateHandEye in its eye-to-hand form (base-to-gripper poses in, the
  camera in the arm's world frame out) with each of its five methods.
Each camera is judged as lrmcal's is in the demo's check.json: by where it puts the
arm's first joint frame (DH frame 1) at the zero command, against where the true camera
sees the true arm's frame 1: the translation (mm) and angle (deg) between the two.

With --eye-in-hand the demos run `lrmcal demo --camera --eye-in-hand` (the webcam on the
flange, the board standing in the scene) and OpenCV's calibrateHandEye runs in its
eye-in-hand form (gripper-to-base poses in, the camera on the gripper out). The board's
place in the arm's world is then the mean over the images of flange . camera . board,
as a user of OpenCV would place it. Each camera is judged as check.json judges lrmcal's:
by where it stands before the board at the demo's 100 checked poses (their commanded
angles and the true board in the true camera are in check.json's `checked`), the mean
translation (mm) and angle (deg) from where the true camera stood.

Frames, checked on every seed (the table's last part gives the checks' figures):
- the URDF's link_i is DH frame i-1 turned by joint i, so DH frame 1 at the zero
  command is link_2 there (not link_1, joint 1's child, which is DH frame 0), and DH
  frame 6, the frame the setup's board pose is given in, is tool0 (not link_6, nor
  `flange`, whose axes follow REP 199);
- OpenCV's AprilTag 36h11 markers are the official tags turned by 180 degrees, so its
  corner k is corner k+2 (mod 4) of the official tag, the one Kalibr's grid and
  lrmcal's files use; the corners are renumbered before matching them to the board.

Reproduce (from the repository root; the demos take about 20 s a seed):
    cargo build --release -p host --bin lrmcal && cp target/release/lrmcal /tmp/lrmcal-bin
    python3 -m venv /tmp/cvenv
    /tmp/cvenv/bin/pip install "opencv-python-headless<5" numpy yourdfpy pyyaml
    /tmp/cvenv/bin/python tools/camera/hand_eye.py --lrmcal /tmp/lrmcal-bin \\
        --runs /tmp/he --seeds 1 10 --out tools/camera/hand_eye_results.md
    /tmp/cvenv/bin/python tools/camera/hand_eye.py --lrmcal /tmp/lrmcal-bin --eye-in-hand \\
        --runs /tmp/he-eih --seeds 1 10 --out tools/camera/hand_eye_results_eye_in_hand.md
OpenCV below 5 because the 5.0.0.93 wheel leaves calibrateHandEye out of its Python
bindings. The demo folders (--runs/seed-S) are made when missing and reused otherwise;
the script writes the table to --out and a line per seed to the terminal.

Corner refinement: SUBPIX by default, the usual choice. On these images CONTOUR gives
the same cameras; APRILTAG gives tighter board poses but finds about a tenth fewer tags,
is some 30 times slower, and puts its corners about half a pixel right of and below
OpenCV's own pixel convention.
"""

import argparse
import collections
import csv
import json
import pathlib
import subprocess
import sys
import tomllib

import cv2
import numpy as np
import yaml
import yourdfpy

METHODS = ["TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS"]
REFINE = ["SUBPIX", "CONTOUR", "APRILTAG", "NONE"]


def pose(xyz_mm, rpy_deg):
    """A 4x4 pose from a setup file's position (mm) and roll, pitch, yaw (deg)."""
    r, p, y = np.radians(rpy_deg)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    t = np.eye(4)
    t[:3, :3] = rz @ ry @ rx
    t[:3, 3] = np.asarray(xyz_mm) / 1000.0
    return t


def from_rt(rot, trans):
    t = np.eye(4)
    t[:3, :3] = rot if np.shape(rot) == (3, 3) else cv2.Rodrigues(rot)[0]
    t[:3, 3] = np.ravel(trans)
    return t


def off(seen, truth):
    """Translation (mm) and angle (deg) of inverse(seen) . truth."""
    e = np.linalg.inv(seen) @ truth
    cos = np.clip((np.trace(e[:3, :3]) - 1.0) / 2.0, -1.0, 1.0)
    return 1000.0 * np.linalg.norm(e[:3, 3]), np.degrees(np.arccos(cos))


def board_corners(path):
    """Each tag's four corners in Kalibr's board frame (m), in the official tag's order:
    top-left, top-right, bottom-right, bottom-left of the tag seen upright."""
    b = yaml.safe_load(pathlib.Path(path).read_text())
    s, pitch = b["tagSize"], b["tagSize"] * (1.0 + b["tagSpacing"])
    tags = {}
    for row in range(b["tagRows"]):
        for col in range(b["tagCols"]):
            x, y = col * pitch, row * pitch
            tags[row * b["tagCols"] + col] = np.array(
                [[x, y + s, 0], [x + s, y + s, 0], [x + s, y, 0], [x, y, 0]], dtype=np.float64
            )
    return tags


def intrinsics(path):
    info = yaml.safe_load(pathlib.Path(path).read_text())
    k = np.array(info["camera_matrix"]["data"], dtype=np.float64).reshape(3, 3)
    return k, np.array(info["distortion_coefficients"]["data"], dtype=np.float64)


def read_seed(run, lrmcal, seed, eye_in_hand):
    """The demo's files for one seed, running the demo first if its folder lacks them."""
    if not (run / "check.json").exists():
        cmd = [lrmcal, "demo", "--camera", "--seed", str(seed), "--out", str(run)]
        cmd += ["--eye-in-hand"] if eye_in_hand else []
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    setup_file = "setup-eye-in-hand.toml" if eye_in_hand else "setup.toml"
    setup = tomllib.loads((run / setup_file).read_text())
    if (setup.get("mount") == "eye-in-hand") != eye_in_hand:
        sys.exit(f"{run / setup_file}: its mount is not the one asked for")
    ours = collections.defaultdict(dict)
    with open(run / "views.csv", newline="") as f:
        for r in csv.DictReader(f):
            ours[r["image"]][int(r["tag"]), int(r["corner"])] = (float(r["u_px"]), float(r["v_px"]))
    with open(run / "images/poses.csv", newline="") as f:
        images = [(r["image"], [float(r[f"q{i}_deg"]) for i in range(1, 7)]) for r in csv.DictReader(f)]
    return {
        "eye_in_hand": eye_in_hand,
        "check": json.loads((run / "check.json").read_text()),
        # Eye-to-hand the camera in the world and the board on the flange;
        # eye-in-hand the camera on the flange and the board in the world.
        "cam_told": pose(setup["camera"]["xyz_mm"], setup["camera"]["rpy_deg"]),
        "board_told": pose(setup["board"]["xyz_mm"], setup["board"]["rpy_deg"]),
        "K_D": intrinsics(run / "camera_info.yaml"),
        "tags": board_corners(run / "board.yaml"),
        "ours": ours,
        "images": images,
    }


class Arm:
    """The nominal arm's forward kinematics from lrmcal's URDF, world-rooted."""

    def __init__(self, urdf):
        self.urdf = yourdfpy.URDF.load(str(urdf), load_meshes=False, build_collision_scene_graph=False)
        self.joints = self.urdf.actuated_joint_names  # base to tip

    def frame(self, link, q_deg):
        self.urdf.update_cfg(dict(zip(self.joints, np.radians(q_deg), strict=True)))
        return self.urdf.get_transform(link, "world")


def detect(detector, image, tags):
    """OpenCV's tags in one image: {tag: 4x2 corners in the official order}."""
    corners, ids, _ = detector.detectMarkers(cv2.imread(str(image), cv2.IMREAD_GRAYSCALE))
    if ids is None:
        return {}
    # OpenCV's marker is the official tag turned by 180 degrees: its corner k is the
    # official tag's corner k + 2.
    return {
        int(i): np.roll(c.reshape(4, 2), -2, axis=0)
        for c, i in zip(corners, ids.ravel(), strict=True)
        if int(i) in tags
    }


def project(point, cam_in_world, K, D):
    w = np.linalg.inv(cam_in_world)
    return cv2.projectPoints(point[None], cv2.Rodrigues(w[:3, :3])[0], w[:3, 3], K, D)[0].reshape(-1, 2)


def placed(d, flange, camera=None, board=None):
    """(camera, board) in the world with the flange (DH frame 6) at `flange`: the told
    ones, or those given; eye-to-hand the board rides on the flange, eye-in-hand the
    camera does."""
    camera = d["cam_told"] if camera is None else camera
    board = d["board_told"] if board is None else board
    return (flange @ camera, board) if d["eye_in_hand"] else (camera, flange @ board)


def before_board(arm, d, camera_on_flange, board_in_world):
    """Eye-in-hand, as check.json judges a camera: the mean translation (mm) and angle
    (deg) between where the camera stands before the board and where the true one stood,
    over the checked poses."""
    mm, deg = [], []
    for c in d["check"]["checked"]:
        cam = arm.frame("tool0", c["q_deg"]) @ camera_on_flange
        seen, actual = np.linalg.inv(cam) @ board_in_world, np.array(c["true_board_in_camera"])
        mm.append(1000.0 * np.linalg.norm(np.linalg.inv(seen)[:3, 3] - np.linalg.inv(actual)[:3, 3]))
        deg.append(off(seen, actual)[1])
    return float(np.mean(mm)), float(np.mean(deg))


def mean_pose(poses):
    """The mean of rigid poses: the mean translation, and the rotation nearest the mean
    of the rotation matrices."""
    u, _, vt = np.linalg.svd(sum(p[:3, :3] for p in poses))
    t = np.eye(4)
    t[:3, :3] = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    t[:3, 3] = np.mean([p[:3, 3] for p in poses], axis=0)
    return t


def sanity(arm, d, boards):
    """The frame checks: DH frame 1, the judging formula, and DH frame 6 through the board."""
    if d["eye_in_hand"]:
        frame1 = None
        told = before_board(arm, d, d["cam_told"], d["board_told"])
    else:
        zero = np.zeros(6)
        f1 = np.array(d["check"]["nominal_frame1_in_world"])
        frame1 = {link: np.abs(arm.frame(link, zero) - f1).max() for link in ("link_1", "link_2")}
        if frame1["link_2"] > 1e-9:
            sys.exit(f"link_2 at the zero command is not check.json's nominal DH frame 1: {frame1}")
        told = off(np.linalg.inv(d["cam_told"]) @ f1, np.array(d["check"]["true_frame1_in_camera"]))
    # The setup's own camera, judged here, must give check.json's figure for it.
    told_diff = (told[0] - d["check"]["told_camera_mm"], told[1] - d["check"]["told_camera_deg"])
    if max(abs(x) for x in told_diff) > 1e-3:
        sys.exit(f"the told camera judged here is not check.json's: {told_diff}")
    # The board put by the nominal arm and seen by the told camera, against lrmcal's
    # corners (px) and against OpenCV's board poses (the angle between the two, deg):
    # the arm and the camera are off by centimetres and degrees, a wrong frame by more.
    K, D = d["K_D"]
    px, deg = {}, {}
    for link in ("tool0", "flange", "link_6"):
        scene = {n: placed(d, arm.frame(link, q)) for n, q in d["images"]}
        px[link] = np.median(
            [
                np.hypot(
                    *(
                        project(
                            scene[n][1][:3, :3] @ d["tags"][t][k] + scene[n][1][:3, 3], scene[n][0], K, D
                        )[0]
                        - uv
                    )
                )
                for n, seen in d["ours"].items()
                for (t, k), uv in seen.items()
            ]
        )
        deg[link] = np.median(
            [off(np.linalg.inv(scene[n][0]) @ scene[n][1], b)[1] for n, b in boards.items()]
        )
    return frame1, told_diff, px, deg


def measure(arm, detector, run, d, min_tags):
    K, D = d["K_D"]
    found, total, diffs, rms = 0, 0, [], []
    flanges, boards = [], {}
    for name, q in d["images"]:
        tags = detect(detector, run / "images" / name, d["tags"])
        found, total = found + len(tags), total + len(d["tags"])
        for tag, c in tags.items():
            diffs += [
                np.hypot(*(c[k] - d["ours"][name][tag, k])) for k in range(4) if (tag, k) in d["ours"][name]
            ]
        if len(tags) < min_tags:
            continue
        obj = np.concatenate([d["tags"][t] for t in tags])
        img = np.concatenate(list(tags.values()))
        ok, rvec, tvec = cv2.solvePnP(obj, img, K, D, flags=cv2.SOLVEPNP_IPPE)
        if not ok:
            continue
        rvec, tvec = cv2.solvePnPRefineLM(obj, img, K, D, rvec, tvec)
        rms.append(
            np.sqrt(
                np.mean(np.sum((cv2.projectPoints(obj, rvec, tvec, K, D)[0].reshape(-1, 2) - img) ** 2, 1))
            )
        )
        flanges.append(arm.frame("tool0", q))
        boards[name] = from_rt(rvec, tvec)
    cams = {}
    for m in METHODS:
        # Eye-in-hand, gripper-to-base poses in and the camera on the gripper
        # out; eye-to-hand as OpenCV documents it: base-to-gripper poses where
        # the gripper-to-base ones go, and the camera-to-base pose comes out.
        grippers = flanges if d["eye_in_hand"] else [np.linalg.inv(f) for f in flanges]
        r, t = cv2.calibrateHandEye(
            R_gripper2base=[g[:3, :3] for g in grippers],
            t_gripper2base=[g[:3, 3] for g in grippers],
            R_target2cam=[b[:3, :3] for b in boards.values()],
            t_target2cam=[b[:3, 3] for b in boards.values()],
            method=getattr(cv2, f"CALIB_HAND_EYE_{m}"),
        )
        camera = from_rt(r, t)
        if d["eye_in_hand"]:
            board = mean_pose([f @ camera @ b for f, b in zip(flanges, boards.values(), strict=True)])
            cams[m] = before_board(arm, d, camera, board)
        else:
            f1 = np.array(d["check"]["nominal_frame1_in_world"])
            cams[m] = off(np.linalg.inv(camera) @ f1, np.array(d["check"]["true_frame1_in_camera"]))
    return {
        "images": (len(boards), len(d["images"])),
        "found": found / total,
        "ours_found": sum(len(v) for v in d["ours"].values()) / 4 / total,
        "corner_px": float(np.median(diffs)),
        "pnp_rms": float(np.median(rms)),
        "cams": cams,
    }, boards


def spread(values):
    v = np.asarray(values)
    return f"{np.median(v):.2f} ({v.min():.2f}–{v.max():.2f})"


def write(out, argv, rows, checks, versions, refine, eye_in_hand):
    seeds = list(rows)
    judged = (
        [
            "The camera is on the flange (eye-in-hand). Its error is judged as in the demo's",
            "check.json: where the camera stands before the board at the demo's 100 checked poses",
            "against where the true camera stood, the mean translation in mm and angle in degrees;",
            "OpenCV's board is the mean over the images of flange . camera . board.",
        ]
        if eye_in_hand
        else [
            "The camera's error is judged as in the demo's check.json: where the camera puts the arm's",
            "first joint frame at the zero command against where the true camera sees the true arm's,",
            "translation in mm and angle in degrees.",
        ]
    )
    form = "eye-in-hand" if eye_in_hand else "eye-to-hand"
    lines = [
        "# OpenCV hand-eye calibration with the nominal arm, beside lrmcal's camera",
        "",
        f"Written by `tools/camera/hand_eye.py` ({versions}); see its docstring for what is measured.",
        "",
        "```",
        " ".join(argv),
        "```",
        "",
        *judged,
        "OpenCV: ArUco detection (DICT_APRILTAG_36h11,",
        f"CORNER_REFINE_{refine}), solvePnP (IPPE, then LM) with the known intrinsics, the flange",
        "from the nominal URDF at the commanded joint angles, all images of both loads, and",
        f"calibrateHandEye in its {form} form. 'Told' is the camera pose the setup file states.",
        "",
        "## Median (min–max) over the seeds",
        "",
        "| camera | mm | deg |",
        "| --- | --- | --- |",
    ]
    for label, key in [("lrmcal (ours)", "ours"), *[(f"OpenCV {m}", m) for m in METHODS], ("told", "told")]:
        mm, deg = spread([rows[s][key][0] for s in seeds]), spread([rows[s][key][1] for s in seeds])
        lines.append(f"| {label} | {mm} | {deg} |")
    lines += [
        "",
        "## Per seed: camera error, mm / deg",
        "",
        "| seed | ours | " + " | ".join(METHODS) + " | told |",
        "| --- | --- | " + " | ".join("---" for _ in METHODS) + " | --- |",
    ]
    for s in seeds:
        cells = [f"{rows[s][k][0]:.2f} / {rows[s][k][1]:.3f}" for k in ["ours", *METHODS, "told"]]
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "## Per seed: detection and checks",
        "",
        "Tags found: the share of the 12 tags per image found by OpenCV and by lrmcal's detector.",
        "Corner diff: median distance between OpenCV's corners and lrmcal's for the tags both found.",
        "PnP RMS: median per-image reprojection RMS of OpenCV's board poses. Nominal px and",
        "nominal deg: the told board and camera, the one on the flange placed by the nominal",
        "arm's DH frame 6 (the URDF's tool0), against lrmcal's corners (median px) and OpenCV's",
        "board poses (median angle); beside them the same through `flange` and `link_6`, the",
        "wrong frames. Frame 1 (eye-to-hand): max |difference| between check.json's nominal DH",
        "frame 1 and the URDF's link_1 and link_2 at the zero command. Told check: this script's",
        "figure for the told camera minus check.json's (mm, deg).",
        "",
        "| seed | images used | tags found OpenCV / ours | corner diff px | PnP RMS px "
        "| nominal px tool0 / flange / link_6 | nominal deg tool0 / flange / link_6 "
        "| frame 1 link_1 / link_2 | told check |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for s in seeds:
        r, (frame1, told, px, deg) = rows[s], checks[s]
        lines.append(
            f"| {s} | {r['images'][0]}/{r['images'][1]} | {r['found']:.3f} / {r['ours_found']:.3f} "
            f"| {r['corner_px']:.3f} | {r['pnp_rms']:.3f} "
            f"| {px['tool0']:.1f} / {px['flange']:.1f} / {px['link_6']:.1f} "
            f"| {deg['tool0']:.1f} / {deg['flange']:.1f} / {deg['link_6']:.1f} "
            + (f"| {frame1['link_1']:.3g} / {frame1['link_2']:.3g} " if frame1 else "| – ")
            + f"| {told[0]:.1e} / {told[1]:.1e} |"
        )
    pathlib.Path(out).write_text("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lrmcal", default="target/release/lrmcal", help="the lrmcal binary")
    ap.add_argument(
        "--runs", type=pathlib.Path, default=pathlib.Path("/tmp/he"), help="demo folders: RUNS/seed-S"
    )
    ap.add_argument("--seeds", type=int, nargs=2, default=[1, 10], metavar=("FIRST", "LAST"))
    ap.add_argument("--refine", choices=REFINE, default="SUBPIX", help="ArUco corner refinement")
    ap.add_argument("--min-tags", type=int, default=4, help="tags an image needs for its board pose")
    ap.add_argument("--eye-in-hand", action="store_true", help="the camera on the flange")
    ap.add_argument("--out", default="tools/camera/hand_eye_results.md")
    args = ap.parse_args()

    args.runs.mkdir(parents=True, exist_ok=True)
    urdf = args.runs / "lrm_world.urdf"
    subprocess.run(
        [args.lrmcal, "export", "--urdf", "--arm", "lrm", "--world", "--out", str(urdf)],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    arm = Arm(urdf)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = getattr(cv2.aruco, f"CORNER_REFINE_{args.refine}")
    detector = cv2.aruco.ArucoDetector(
        cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11), params
    )

    rows, checks = {}, {}
    for seed in range(args.seeds[0], args.seeds[1] + 1):
        run = args.runs / f"seed-{seed}"
        d = read_seed(run, args.lrmcal, seed, args.eye_in_hand)
        rows[seed], boards = measure(arm, detector, run, d, args.min_tags)
        checks[seed] = sanity(arm, d, boards)
        c = d["check"]
        rows[seed]["ours"] = (c["camera_mm"], c["camera_deg"])
        rows[seed]["told"] = (c["told_camera_mm"], c["told_camera_deg"])
        rows[seed].update(rows[seed].pop("cams"))
        print(
            f"seed {seed}: "
            + ", ".join(
                f"{k} {rows[seed][k][0]:.1f} mm {rows[seed][k][1]:.2f} deg" for k in ["ours", *METHODS]
            ),
            flush=True,
        )
    version = subprocess.run([args.lrmcal, "--version"], capture_output=True, text=True).stdout.strip()
    write(
        args.out,
        [sys.executable, *sys.argv],
        rows,
        checks,
        f"OpenCV {cv2.__version__}, {version}",
        args.refine,
        args.eye_in_hand,
    )


if __name__ == "__main__":
    main()
