#!/usr/bin/env python3
"""FIGAROH 1.0.2 on the TIAGo motion-capture data, cross-validated.

For every fold of host/tests/data/tiago/split.csv this runs FIGAROH's own
TIAGo calibration (the class ``TiagoCalibration`` and the configuration
``config/tiago_unified_config.yaml`` of a figaroh-examples checkout, with the
figaroh 1.0.2 package) on the fold's training rows, then predicts the marker
positions of the fold's held-out rows and measures the 3D error of each
marker. Nothing of FIGAROH's method is re-implemented here: the parameters,
the solver, its outlier exclusion and the forward kinematics are FIGAROH's;
this script only writes the per-fold CSV and YAML files, calls FIGAROH and
does the bookkeeping. See README.md beside it.

Three models are fitted on each fold, all with the base (mocap) frame and the
marker position(s) on wrist_ft_tool_link estimated:

  nominal       the URDF's kinematics; only the 6 base-frame parameters and
                the marker position(s) are estimated (the parameter list of
                the full_params run with every joint parameter removed by
                FIGAROH's drop_calibration_parameters);
  joint_offset  FIGAROH calibration level "joint_offset";
  full_params   FIGAROH calibration level "full_params", the level of the
                example's configuration.

and two marker sets: "m1" (marker 1 only, as FIGAROH's example is
configured) and "m123" (markers 1, 2 and 3; marker 4 is an exact copy of
marker 3 in every row of the data and is left out).
"""

import argparse
import contextlib
import copy
import csv
import datetime
import hashlib
import io
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
DATA_DIR = os.path.join(REPO, "host", "tests", "data", "tiago")

EXAMPLE_CONFIG = os.path.join("examples", "tiago", "config", "tiago_unified_config.yaml")
EXAMPLE_TOOLS = os.path.join("examples", "tiago", "utils", "tiago_tools.py")

MODELS = ("nominal", "joint_offset", "full_params")
MARKER_SETS = {"m1": [1], "m123": [1, 2, 3]}


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)


def read_split(path):
    header, rows = read_csv(path)
    assert header == ["row", "fold"], header
    return {int(r): int(k) for r, k in rows}


def git_commit(path):
    try:
        out = subprocess.run(
            ["git", "-C", path, "rev-parse", "HEAD"],
            capture_output=True, text=True, check=True,
        )
        return out.stdout.strip()
    except Exception:
        return None


def stats_mm(errors_m):
    """mean, RMS, max (mm) of an array of 3D error norms in metres."""
    e = np.asarray(errors_m, dtype=float) * 1000.0
    return {
        "n": int(e.size),
        "mean_mm": float(np.mean(e)),
        "rms_mm": float(np.sqrt(np.mean(e**2))),
        "max_mm": float(np.max(e)),
    }


def marker_errors(calibration_tools, calib, var, q, pee_measured):
    """(n_markers, n_samples) 3D error norms, metres, from FIGAROH's FK."""
    cfg = dict(calib.calib_config, NbSample=len(q))
    predicted = calibration_tools.calc_updated_fkm(calib.model, calib.data, var, q, cfg)
    n_markers = cfg["NbMarkers"]
    diff = (predicted - pee_measured).reshape(n_markers, 3, len(q))
    return np.linalg.norm(diff, axis=1)


def make_config(example_config, path, train_csv, test_csv, level, markers, seed):
    """The example's unified configuration with the fold's files.

    Changed: data.source_file, data.validation_data_file, the calibration
    level, and (for several markers) one marker entry per marker, each a
    copy of the example's single marker on arm_7_joint; with ``seed`` not
    None, parameters.random_seed (the seed of the random configurations of
    FIGAROH's structural parameter selection, 0 when unset).
    """
    cfg = copy.deepcopy(example_config)
    task = cfg["tasks"]["calibration"]
    task["data"]["source_file"] = train_csv
    task["data"]["validation_data_file"] = test_csv
    task["parameters"]["calibration_level"] = level
    if seed is not None:
        task["parameters"]["random_seed"] = seed
    marker = task["measurements"]["markers"][0]
    task["measurements"]["markers"] = [
        dict(copy.deepcopy(marker), name=f"marker_{k}") for k in markers
    ]
    with open(path, "w") as f:
        yaml.safe_dump(cfg, f, sort_keys=False)


def fit_and_evaluate(figaroh, example_config, urdf, workdir, tag, level_model,
                     markers, header, train_rows, test_rows, train_idx, log, seed):
    TiagoCalibration, load_robot, calibration_tools = figaroh
    train_csv = os.path.join(workdir, f"{tag}_train.csv")
    test_csv = os.path.join(workdir, f"{tag}_test.csv")
    cfg_path = os.path.join(workdir, f"{tag}.yaml")
    write_csv(train_csv, header, train_rows)
    write_csv(test_csv, header, test_rows)
    level = "full_params" if level_model == "nominal" else level_model
    make_config(example_config, cfg_path, train_csv, test_csv, level, markers, seed)

    out = io.StringIO()
    with contextlib.redirect_stdout(out), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = load_robot(urdf, load_by_urdf=True)
        calib = TiagoCalibration(robot, cfg_path, del_list=[])
        # as the example's calibration.py: base and marker frames unknown
        calib.calib_config["known_baseframe"] = False
        calib.calib_config["known_tipframe"] = False
        t0 = time.perf_counter()
        calib.initialize()
        if level_model == "nominal":
            frames = calib._frame_param_names()
            joints = [n for n in calib.calib_config["param_name"] if n not in frames]
            calibration_tools.drop_calibration_parameters(calib.calib_config, joints)
        t1 = time.perf_counter()
        result = calib.solve(plotting=False, enable_logging=False)
        t2 = time.perf_counter()
    log.write(f"===== {tag}\n{out.getvalue()}\n")

    var = np.asarray(result.x)
    held = marker_errors(calibration_tools, calib, var, calib._q_val, calib._PEE_val)
    train = marker_errors(calibration_tools, calib, var, calib.q_measured, calib.PEE_measured)
    excluded = [int(train_idx[i]) for i in calib.evaluation_metrics.get("excluded_samples", [])]
    kept = np.ones(len(train_idx), dtype=bool)
    kept[[train_idx.index(r) for r in excluded]] = False
    figaroh_val = calib.results_data.get("validation_metrics") or {}
    return {
        "parameters": dict(zip(calib.calib_config["param_name"], var.tolist())),
        "absorbed_parameters": list(calib.calib_config.get("absorbed_param_name", [])),
        "solver_success": bool(result.success),
        "status": calib.STATUS,
        "excluded_training_rows": excluded,
        "time_initialize_s": t1 - t0,
        "time_solve_s": t2 - t1,
        "held_out_errors_m": held.tolist(),
        "held_out": {f"marker_{k}": stats_mm(held[i]) for i, k in enumerate(markers)}
        | {"all": stats_mm(held)},
        "training_kept": stats_mm(train[:, kept]),
        "figaroh_validation_pos_rmse_calibrated_mm": figaroh_val.get("pos_rmse_calibrated_mm"),
        "figaroh_validation_source": figaroh_val.get("validation_source"),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", required=True,
                    help="checkout of github.com/thanhndv212/figaroh-examples "
                         "(commit c0b5c7f0fda10078be55104f9ee76ac106b7a5ee)")
    ap.add_argument("--data", default=os.path.join(DATA_DIR, "mocap.csv"))
    ap.add_argument("--split", default=os.path.join(DATA_DIR, "split.csv"))
    ap.add_argument("--urdf", default=os.path.join(DATA_DIR, "tiago.urdf"))
    ap.add_argument("--out", default=os.path.join(HERE, "results", "tiago_cv.json"))
    ap.add_argument("--log", default=None,
                    help="FIGAROH's printed reports (default: beside --out, .log)")
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--marker-sets", default=",".join(MARKER_SETS))
    ap.add_argument("--random-seed", type=int, default=None,
                    help="FIGAROH's parameters.random_seed (default: unset, i.e. 0)")
    args = ap.parse_args()

    examples = os.path.abspath(args.examples)
    sys.path.insert(0, examples)
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        import figaroh
        import pinocchio
        import scipy
        from figaroh.calibration import calibration_tools
        from figaroh.tools.load_robot import load_robot
        from examples.tiago.utils.tiago_tools import TiagoCalibration
    fig = (TiagoCalibration, load_robot, calibration_tools)

    with open(os.path.join(examples, EXAMPLE_CONFIG)) as f:
        example_config = yaml.safe_load(f)
    header, rows = read_csv(args.data)
    split = read_split(args.split)
    assert sorted(split) == list(range(len(rows))), "split does not cover every row"
    folds = sorted(set(split.values()))
    models = args.models.split(",")
    marker_sets = args.marker_sets.split(",")
    urdf = os.path.abspath(args.urdf)
    log_path = args.log or os.path.splitext(args.out)[0] + ".log"
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)

    runs = {}
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as workdir, open(log_path, "w") as log:
        for ms in marker_sets:
            for model in models:
                per_fold = []
                pooled = np.zeros((len(MARKER_SETS[ms]), len(rows)))
                for k in folds:
                    train_idx = [r for r in range(len(rows)) if split[r] != k]
                    test_idx = [r for r in range(len(rows)) if split[r] == k]
                    res = fit_and_evaluate(
                        fig, example_config, urdf, workdir, f"{ms}_{model}_fold{k}",
                        model, MARKER_SETS[ms], header,
                        [rows[r] for r in train_idx], [rows[r] for r in test_idx],
                        train_idx, log, args.random_seed,
                    )
                    res = {"fold": k, "train_rows": train_idx, "test_rows": test_idx} | res
                    pooled[:, test_idx] = np.asarray(res["held_out_errors_m"])
                    per_fold.append(res)
                    print(f"{ms:5s} {model:13s} fold {k}: held-out RMS "
                          f"{res['held_out']['all']['rms_mm']:7.2f} mm, "
                          f"solve {res['time_solve_s']:.3f} s", file=sys.stderr)
                runs[f"{ms}/{model}"] = {
                    "marker_set": ms,
                    "markers": MARKER_SETS[ms],
                    "model": model,
                    "n_parameters": [len(f["parameters"]) for f in per_fold],
                    "folds": per_fold,
                    "overall_held_out": {
                        f"marker_{m}": stats_mm(pooled[i]) for i, m in enumerate(MARKER_SETS[ms])
                    } | {"all": stats_mm(pooled)},
                    "overall_held_out_errors_m_by_row": pooled.tolist(),
                    "time_solve_s_total": sum(f["time_solve_s"] for f in per_fold),
                    "time_initialize_s_total": sum(f["time_initialize_s"] for f in per_fold),
                }
    wall = time.perf_counter() - t_start

    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except Exception:
        pass
    result = {
        "what": "FIGAROH 1.0.2 TIAGo mocap calibration, cross-validated on split.csv",
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join([os.path.basename(sys.executable)] + sys.argv),
        "inputs": {
            "data": {"path": os.path.relpath(os.path.abspath(args.data), REPO), "sha256": sha256(args.data)},
            "split": {"path": os.path.relpath(os.path.abspath(args.split), REPO), "sha256": sha256(args.split)},
            "urdf": {"path": os.path.relpath(urdf, REPO), "sha256": sha256(urdf)},
            "figaroh_examples": {
                "commit": git_commit(examples),
                "config_sha256": sha256(os.path.join(examples, EXAMPLE_CONFIG)),
                "tiago_tools_sha256": sha256(os.path.join(examples, EXAMPLE_TOOLS)),
            },
        },
        "environment": {
            "figaroh": getattr(figaroh, "__version__", None),
            "pinocchio": pinocchio.__version__,
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "python": platform.python_version(),
            "cpu": cpu,
            "cpus": os.cpu_count(),
        },
        "figaroh_random_seed": args.random_seed,
        "units": "errors in mm (3D Euclidean distance per marker per row); times in s",
        "wall_time_s": wall,
        "runs": runs,
    }
    with open(args.out, "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")

    print(f"FIGAROH {result['environment']['figaroh']}, {len(rows)} rows, "
          f"{len(folds)} folds; held-out 3D marker error (mm), pooled over folds")
    print(f"{'markers':7s} {'model':13s} {'params':>7s} {'mean':>7s} {'RMS':>7s} "
          f"{'max':>7s}   per-fold RMS{'':24s} solve s (5 folds)")
    for key, run in runs.items():
        o = run["overall_held_out"]["all"]
        pf = " ".join(f"{f['held_out']['all']['rms_mm']:6.2f}" for f in run["folds"])
        n = run["n_parameters"]
        n = f"{min(n)}" if min(n) == max(n) else f"{min(n)}-{max(n)}"
        print(f"{run['marker_set']:7s} {run['model']:13s} {n:>7s} "
              f"{o['mean_mm']:7.2f} {o['rms_mm']:7.2f} {o['max_mm']:7.2f}   {pf}   "
              f"{run['time_solve_s_total']:.3f}")
    print("pooled held-out RMS per marker (mm):")
    for key, run in runs.items():
        per = " ".join(f"{m}={v['rms_mm']:.2f}" for m, v in run["overall_held_out"].items() if m != "all")
        init = run["time_initialize_s_total"]
        print(f"  {key:20s} {per:45s} initialize {init:.3f} s (5 folds)")
    print(f"results: {os.path.relpath(os.path.abspath(args.out))}; FIGAROH's reports: "
          f"{os.path.relpath(log_path)}; wall time {wall:.1f} s")


if __name__ == "__main__":
    main()
