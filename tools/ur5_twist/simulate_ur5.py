#!/usr/bin/env python3
"""A UR5 with perturbed joint origins, measured by a simulated tracker, and
an independent least-squares fit of those origins as the reference.

    python simulate_ur5.py --urdf ur5.urdf --out DIR [--seed 1]

(a) loads the nominal URDF with Pinocchio; (b) makes the "true" robot by
moving every joint's origin (its placement in the parent link) by a random
translation of 1-2 mm and a random rotation of 0.2-0.5 deg (random
directions, --seed), nothing else: no compliance, the base and the tool
offset as nominal; (c) draws random joint configurations, each joint within
+-170 deg, keeping the target and the wrist above the floor, and writes
the tracker's view of the target's position (0.1 mm Gaussian noise on each
coordinate) as lrmcal measurement CSVs in the base_link frame:

    DIR/fit.csv            60 poses to identify from (noisy)
    DIR/held_out.csv       200 other poses (noisy, as a tracker gives them)
    DIR/held_out_exact.csv the same 200 poses without noise (model error only)

(d) fits the 36 joint-origin errors (a 6-vector per joint, applied as the
simulation applied them) to fit.csv with scipy's least_squares, base and
tool known, and reports the held-out error of the nominal arm and of that
fit (mean / RMS / max of the 3D distance, mm) on both held-out files, into
DIR/reference.json and on standard output. DIR/truth.json records the
perturbations.
"""

import argparse
import json
import pathlib
import time

import numpy as np
import pinocchio as pin
from scipy.optimize import least_squares

N_FIT = 60
N_HELD = 200
NOISE_MM = 0.1
LIMIT_DEG = 170.0
MIN_TARGET_Z = 0.10  # m above the base's floor plane
MIN_WRIST_Z = 0.05


def load(urdf, tip):
    model = pin.buildModelFromUrdf(str(urdf))
    if model.nq != 6 or model.nv != 6:
        raise SystemExit(f"{urdf}: expected 6 joints, got nq={model.nq}")
    return model, model.getFrameId(tip)


def with_errors(nominal, xi):
    """The nominal model with joint i's origin moved by exp6(xi[i]) (in the joint's frame)."""
    model = nominal.copy()
    for j in range(1, 7):
        model.jointPlacements[j] = nominal.jointPlacements[j] * pin.exp6(pin.Motion(xi[j - 1]))
    return model


def tip_points(model, frame, qs):
    data = model.createData()
    out = np.empty((len(qs), 3))
    for k, q in enumerate(qs):
        pin.framesForwardKinematics(model, data, q)
        out[k] = data.oMf[frame].translation
    return out


def random_errors(rng):
    xi = np.zeros((6, 6))
    for j in range(6):
        u = rng.normal(size=3)
        t = u / np.linalg.norm(u) * rng.uniform(1e-3, 2e-3)
        w = rng.normal(size=3)
        r = w / np.linalg.norm(w) * np.deg2rad(rng.uniform(0.2, 0.5))
        # exp6 of (v, w) translates by V(w) v: choose v so that it is t.
        xi[j, :3] = np.linalg.solve(_v_matrix(r), t)
        xi[j, 3:] = r
    return xi


def _v_matrix(w):
    """V(w): exp6((v, w)).translation = V(w) v."""
    th = np.linalg.norm(w)
    k = pin.skew(w)
    if th < 1e-12:
        return np.eye(3)
    return (np.eye(3) + (1 - np.cos(th)) / th**2 * k + (th - np.sin(th)) / th**3 * k @ k)


def draw_poses(rng, model, frame, n):
    data = model.createData()
    wrists = [model.getJointId(n_) for n_ in ("wrist_1_joint", "wrist_2_joint", "wrist_3_joint")]
    qs = []
    while len(qs) < n:
        q = np.deg2rad(rng.uniform(-LIMIT_DEG, LIMIT_DEG, size=6))
        pin.framesForwardKinematics(model, data, q)
        if data.oMf[frame].translation[2] < MIN_TARGET_Z:
            continue
        if any(data.oMi[j].translation[2] < MIN_WRIST_Z for j in wrists):
            continue
        qs.append(q)
    return np.array(qs)


def write_csv(path, first_id, qs, points_m):
    with open(path, "w") as f:
        f.write("pose,load_kg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n")
        for k, (q, p) in enumerate(zip(qs, points_m)):
            qd = ",".join(f"{v:.9f}" for v in np.rad2deg(q))
            pm = ",".join(f"{v:.6f}" for v in p * 1e3)
            f.write(f"{first_id + k},0,{qd},{pm}\n")


def stats(pred_m, meas_m):
    d = np.linalg.norm(pred_m - meas_m, axis=1) * 1e3
    return {"mean_mm": float(d.mean()), "rms_mm": float(np.sqrt((d**2).mean())),
            "max_mm": float(d.max())}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--urdf", required=True, type=pathlib.Path)
    ap.add_argument("--tip", default="target")
    ap.add_argument("--out", required=True, type=pathlib.Path)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    rng = np.random.default_rng(args.seed)
    nominal, frame = load(args.urdf, args.tip)
    xi_true = random_errors(rng)
    true = with_errors(nominal, xi_true)

    q_fit = draw_poses(rng, true, frame, N_FIT)
    q_held = draw_poses(rng, true, frame, N_HELD)
    p_fit = tip_points(true, frame, q_fit)
    p_held = tip_points(true, frame, q_held)
    noise = NOISE_MM * 1e-3
    m_fit = p_fit + rng.normal(scale=noise, size=p_fit.shape)
    m_held = p_held + rng.normal(scale=noise, size=p_held.shape)
    write_csv(args.out / "fit.csv", 1, q_fit, m_fit)
    write_csv(args.out / "held_out.csv", 1001, q_held, m_held)
    write_csv(args.out / "held_out_exact.csv", 1001, q_held, p_held)

    truth = {"seed": args.seed, "tip": args.tip, "noise_mm_per_axis": NOISE_MM,
             "joints": []}
    for j in range(6):
        d = pin.exp6(pin.Motion(xi_true[j]))
        truth["joints"].append({
            "joint": nominal.names[j + 1],
            "translation_mm": (d.translation * 1e3).tolist(),
            "rotation_deg": float(np.rad2deg(np.linalg.norm(xi_true[j, 3:]))),
            "rotation_vector_rad": xi_true[j, 3:].tolist()})
    (args.out / "truth.json").write_text(json.dumps(truth, indent=2) + "\n")

    # (d) the reference: the same error model, fitted by least squares.
    def residual(x):
        return (tip_points(with_errors(nominal, x.reshape(6, 6)), frame, q_fit) - m_fit).ravel()

    t0 = time.perf_counter()
    sol = least_squares(residual, np.zeros(36), method="trf", x_scale=1e-3, xtol=1e-12,
                        ftol=1e-12, gtol=1e-12)
    seconds = time.perf_counter() - t0
    fitted = with_errors(nominal, sol.x.reshape(6, 6))
    sv = np.linalg.svd(sol.jac, compute_uv=False)
    rank = int((sv > sv[0] * 1e-8).sum())

    result = {
        "poses": {"fit": N_FIT, "held_out": N_HELD},
        "nominal": {
            "fit": stats(tip_points(nominal, frame, q_fit), m_fit),
            "held_out": stats(tip_points(nominal, frame, q_held), m_held),
            "held_out_exact": stats(tip_points(nominal, frame, q_held), p_held)},
        "reference": {
            "fit": stats(tip_points(fitted, frame, q_fit), m_fit),
            "held_out": stats(tip_points(fitted, frame, q_held), m_held),
            "held_out_exact": stats(tip_points(fitted, frame, q_held), p_held),
            "parameters": 36, "jacobian_rank": rank, "seconds": seconds,
            "evaluations": int(sol.nfev), "status": int(sol.status)},
        "truth": {
            "held_out": stats(p_held, m_held)},
    }
    (args.out / "reference.json").write_text(json.dumps(result, indent=2) + "\n")

    def line(name, s):
        return f"{name:28s} {s['mean_mm']:8.3f} {s['rms_mm']:8.3f} {s['max_mm']:8.3f}"

    print(f"{'held-out error, mm':28s} {'mean':>8s} {'RMS':>8s} {'max':>8s}")
    for name, key in (("nominal", "nominal"), ("scipy reference", "reference")):
        print(line(name + " (noisy)", result[key]["held_out"]))
        print(line(name + " (exact)", result[key]["held_out_exact"]))
    print(line("true arm (noise only)", result["truth"]["held_out"]))
    print(f"reference: 36 parameters, Jacobian rank {rank}, {sol.nfev} evaluations, "
          f"{seconds:.1f} s; fit residual RMS {result['reference']['fit']['rms_mm']:.3f} mm")


if __name__ == "__main__":
    main()
