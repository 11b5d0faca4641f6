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

With --splits seeded, the same fits run on the seeded splits of splits.py
(5-fold permutations and leave-10-out draws, the ones lrmcal_tiago_cv.py
uses too), by default with the models nominal, full_params and
full_params_elastic (full_params with FIGAROH's include_non_geometric
switch: one gravity-torque compliance per active joint), and write
results/tiago_splits.json: per split the mean held-out error.
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

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import splits as splits_mod  # noqa: E402  (beside this script)

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
DATA_DIR = os.path.join(REPO, "host", "tests", "data", "tiago")

EXAMPLE_CONFIG = os.path.join("examples", "tiago", "config", "tiago_unified_config.yaml")
EXAMPLE_TOOLS = os.path.join("examples", "tiago", "utils", "tiago_tools.py")

MODELS = ("nominal", "joint_offset", "full_params")
# full_params_elastic: level full_params with parameters.include_non_geometric
# true (FIGAROH 1.0.2 reads it in calibration/config.py
# _extract_calibration_params; calc_updated_fkm then adds one compliance per
# active joint, a deflection proportional to the joint's gravity torque).
ALL_MODELS = MODELS + ("full_params_elastic",)
SEEDED_MODELS = ("nominal", "full_params", "full_params_elastic")
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


def make_config(example_config, path, train_csv, test_csv, level, markers, seed,
                non_geometric=False):
    """The example's unified configuration with the fold's files.

    Changed: data.source_file, data.validation_data_file, the calibration
    level, and (for several markers) one marker entry per marker, each a
    copy of the example's single marker on arm_7_joint; with ``seed`` not
    None, parameters.random_seed (the seed of the random configurations of
    FIGAROH's structural parameter selection, 0 when unset); with
    ``non_geometric``, parameters.include_non_geometric = true (the example
    has false).
    """
    cfg = copy.deepcopy(example_config)
    task = cfg["tasks"]["calibration"]
    task["data"]["source_file"] = train_csv
    task["data"]["validation_data_file"] = test_csv
    task["parameters"]["calibration_level"] = level
    if non_geometric:
        task["parameters"]["include_non_geometric"] = True
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
    level = "full_params" if level_model in ("nominal", "full_params_elastic") else level_model
    make_config(example_config, cfg_path, train_csv, test_csv, level, markers, seed,
                non_geometric=level_model == "full_params_elastic")

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


def cpu_name():
    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(l.split(":", 1)[1].strip() for l in f if l.startswith("model name"))
    except Exception:
        pass
    return cpu


def environment(figaroh, pinocchio, scipy):
    """The versions and machine a run measured with, for its JSON."""
    return {
        "figaroh": getattr(figaroh, "__version__", None),
        "pinocchio": pinocchio.__version__,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "python": platform.python_version(),
        "cpu": cpu_name(),
        "cpus": os.cpu_count(),
    }


def examples_record(examples):
    """Which figaroh-examples checkout, configuration and tools a run used."""
    return {
        "commit": git_commit(examples),
        "config_sha256": sha256(os.path.join(examples, EXAMPLE_CONFIG)),
        "tiago_tools_sha256": sha256(os.path.join(examples, EXAMPLE_TOOLS)),
    }


def summary(values):
    """median, min, max of a list (None for an empty one)."""
    if not values:
        return None
    return {"n": len(values), "median": float(np.median(values)),
            "min": float(min(values)), "max": float(max(values))}


def run_seeded(args, fig, example_config, examples, header, rows, modules):
    """Every model and marker set on every seeded split of splits.py.

    Per split, the mean of the held-out 3D errors (every held-out row and
    marker of the split's folds pooled: all 34 rows of a 5-fold
    permutation, the 10 of a leave-10-out draw). A fit whose solver reports
    no success or raises is counted "diverged"; as FIGAROH marks it FAILED
    and refuses to export it, its held-out rows then take the nominal
    model's errors of the same fold (what the user is left with), and the
    as-fitted errors are kept beside them.
    """
    figaroh, pinocchio, scipy = modules
    n = len(rows)
    splits = splits_mod.seeded(n, splits_mod.parse_seeds(args.seeds))
    splits_mod.check(splits, n)
    models = args.models.split(",")
    models = sorted(models, key=lambda m: m != "nominal")  # nominal first
    marker_sets = args.marker_sets.split(",")
    urdf = os.path.abspath(args.urdf)
    log_path = args.log or os.path.splitext(args.out)[0] + ".log"
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)

    per_split = []
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as workdir, open(log_path, "w") as log:
        for sp in splits:
            entry = {"split": sp["id"], "kind": sp["kind"], "seed": sp["seed"], "runs": {}}
            for ms in marker_sets:
                markers = MARKER_SETS[ms]
                for model in models:
                    folds, used = [], []
                    for k, test_idx in enumerate(sp["folds"]):
                        train_idx = splits_mod.train_rows(test_idx, n)
                        tag = f"{sp['id']}_{ms}_{model}_fold{k}"
                        fold = {"fold": k, "test_rows": test_idx}
                        try:
                            res = fit_and_evaluate(
                                fig, example_config, urdf, workdir, tag, model, markers,
                                header, [rows[r] for r in train_idx],
                                [rows[r] for r in test_idx], train_idx, log, args.random_seed,
                            )
                        except Exception as e:  # FIGAROH's own failure: recorded
                            log.write(f"===== {tag}\nraised {type(e).__name__}: {e}\n")
                            res = None
                            fold |= {"diverged": True, "error": f"{type(e).__name__}: {e}"}
                        if res is not None:
                            held = np.asarray(res["held_out_errors_m"]) * 1e3
                            ok = res["solver_success"] and bool(np.all(np.isfinite(held)))
                            fold |= {
                                "n_parameters": len(res["parameters"]),
                                "solver_success": res["solver_success"],
                                "status": res["status"],
                                "diverged": not ok,
                                "excluded_training_rows": res["excluded_training_rows"],
                                "time_initialize_s": res["time_initialize_s"],
                                "time_solve_s": res["time_solve_s"],
                                "held_out_errors_mm": np.round(held, 6).tolist(),
                                "held_out_mean_mm": float(np.mean(held)),
                                "training_rms_mm": res["training_kept"]["rms_mm"],
                            }
                        if fold["diverged"]:
                            nominal = entry["runs"].get(f"{ms}/nominal")
                            if nominal is None or nominal["folds"][k]["diverged"]:
                                sys.exit(f"{tag} diverged and no nominal fit to fall back on")
                            used.append(np.asarray(nominal["folds"][k]["held_out_errors_mm"]))
                        else:
                            used.append(np.asarray(fold["held_out_errors_mm"]))
                        folds.append(fold)
                    e = np.concatenate(used, axis=1)
                    entry["runs"][f"{ms}/{model}"] = {
                        "folds": folds,
                        "mean_mm": float(np.mean(e)),
                        "rms_mm": float(np.sqrt(np.mean(e**2))),
                        "max_mm": float(np.max(e)),
                        "diverged": sum(f["diverged"] for f in folds),
                        "time_solve_s": sum(f.get("time_solve_s", 0.0) for f in folds),
                    }
                    print(f"{sp['id']:11s} {ms:5s} {model:19s} mean "
                          f"{entry['runs'][f'{ms}/{model}']['mean_mm']:6.2f} mm", file=sys.stderr)
            per_split.append(entry)
    wall = time.perf_counter() - t_start

    kinds = [k for k in ("kfold5", "leave10") if any(s["kind"] == k for s in splits)]
    table = {}
    for ms in marker_sets:
        for model in models:
            key = f"{ms}/{model}"
            row = {}
            for kind in kinds:
                runs = [e["runs"][key] for e in per_split if e["kind"] == kind]
                fits = [f for r in runs for f in r["folds"]]
                npar = [f["n_parameters"] for f in fits if "n_parameters" in f]
                row[kind] = {
                    "split_mean_mm": summary([r["mean_mm"] for r in runs]),
                    "split_rms_mm": summary([r["rms_mm"] for r in runs]),
                    "split_max_mm": summary([r["max_mm"] for r in runs]),
                    "fits": len(fits),
                    "diverged": sum(f["diverged"] for f in fits),
                    "n_parameters": [min(npar), max(npar)] if npar else None,
                    "time_solve_s_total": sum(r["time_solve_s"] for r in runs),
                }
            table[key] = row

    result = {
        "what": "FIGAROH 1.0.2 TIAGo mocap calibration on the seeded splits of splits.py",
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join([os.path.basename(sys.executable)] + sys.argv),
        "inputs": {
            "data": {"path": os.path.relpath(os.path.abspath(args.data), REPO), "sha256": sha256(args.data)},
            "urdf": {"path": os.path.relpath(urdf, REPO), "sha256": sha256(urdf)},
            "splits_py_sha256": sha256(os.path.join(HERE, "splits.py")),
            "figaroh_examples": examples_record(examples),
        },
        "environment": environment(figaroh, pinocchio, scipy),
        "figaroh_random_seed": args.random_seed,
        "robust_weighting": (
            "not available: FIGAROH 1.0.2 calls scipy.optimize.least_squares "
            "without a loss argument (BaseCalibration._optimize_with_outlier_removal, "
            "method 'lm' by default, which takes only the linear loss); no config key "
            "sets one. Its only robust device is the hard outlier threshold "
            "(parameters.outlier_threshold, 0.05 m in the example), kept."
        ),
        "splits_digest": splits_mod.digest(splits),
        "splits": splits,
        "units": "errors in mm (3D Euclidean distance per marker per held-out row); times in s",
        "split_mean": "per split: the mean of its held-out errors, all its folds and markers pooled",
        "wall_time_s": wall,
        "summary": table,
        "per_split": per_split,
    }
    with open(args.out, "w") as f:
        json.dump(result, f, indent=1)
        f.write("\n")

    print(f"FIGAROH {result['environment']['figaroh']}, {n} rows, seeds {args.seeds}; "
          "per-split mean held-out 3D error (mm): median (min-max) over the splits")
    print("| points | model | parameters | " + " | ".join(
        f"{k} x{len([s for s in splits if s['kind'] == k])}" for k in kinds)
          + " | diverged | solve, all fits |")
    print("|---" * (5 + len(kinds)) + "|")
    for key, row in table.items():
        ms, model = key.split("/")
        cells = []
        for kind in kinds:
            sm = row[kind]["split_mean_mm"]
            cells.append(f"{sm['median']:.2f} ({sm['min']:.2f}-{sm['max']:.2f})")
        npar = sorted({p for kind in kinds for p in (row[kind]["n_parameters"] or [])})
        npar = f"{npar[0]}" if len(npar) == 1 else f"{npar[0]}-{npar[-1]}"
        div = sum(row[k]["diverged"] for k in kinds)
        fits = sum(row[k]["fits"] for k in kinds)
        t = sum(row[k]["time_solve_s_total"] for k in kinds)
        print(f"| {ms} | {model} | {npar} | " + " | ".join(cells)
              + f" | {div} of {fits} | {t:.1f} s |")
    print(f"results: {os.path.relpath(os.path.abspath(args.out))}; FIGAROH's reports: "
          f"{os.path.relpath(log_path)}; wall time {wall:.1f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", required=True,
                    help="checkout of github.com/thanhndv212/figaroh-examples "
                         "(commit c0b5c7f0fda10078be55104f9ee76ac106b7a5ee)")
    ap.add_argument("--data", default=os.path.join(DATA_DIR, "mocap.csv"))
    ap.add_argument("--split", default=os.path.join(DATA_DIR, "split.csv"))
    ap.add_argument("--urdf", default=os.path.join(DATA_DIR, "tiago.urdf"))
    ap.add_argument("--out", default=None,
                    help="results JSON (default: results/tiago_cv.json, with "
                         "--splits seeded results/tiago_splits.json)")
    ap.add_argument("--log", default=None,
                    help="FIGAROH's printed reports (default: beside --out, .log)")
    ap.add_argument("--models", default=None,
                    help=f"comma-separated, of {','.join(ALL_MODELS)} (default: "
                         f"{','.join(MODELS)}; with --splits seeded {','.join(SEEDED_MODELS)})")
    ap.add_argument("--marker-sets", default=",".join(MARKER_SETS))
    ap.add_argument("--random-seed", type=int, default=None,
                    help="FIGAROH's parameters.random_seed (default: unset, i.e. 0)")
    ap.add_argument("--splits", choices=("committed", "seeded"), default="committed",
                    help="committed: the 5 folds of --split (default); seeded: the "
                         "5-fold permutations and leave-10-out draws of splits.py "
                         "for --seeds")
    ap.add_argument("--seeds", default="1-10",
                    help="with --splits seeded: the seeds, e.g. 1-10 or 1,2,5")
    args = ap.parse_args()
    seeded = args.splits == "seeded"
    if args.out is None:
        name = "tiago_splits.json" if seeded else "tiago_cv.json"
        args.out = os.path.join(HERE, "results", name)
    if args.models is None:
        args.models = ",".join(SEEDED_MODELS if seeded else MODELS)
    unknown = set(args.models.split(",")) - set(ALL_MODELS)
    if unknown:
        ap.error(f"unknown models {sorted(unknown)}")

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
    if seeded:
        return run_seeded(args, fig, example_config, examples, header, rows,
                          (figaroh, pinocchio, scipy))
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

    result = {
        "what": "FIGAROH 1.0.2 TIAGo mocap calibration, cross-validated on split.csv",
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join([os.path.basename(sys.executable)] + sys.argv),
        "inputs": {
            "data": {"path": os.path.relpath(os.path.abspath(args.data), REPO), "sha256": sha256(args.data)},
            "split": {"path": os.path.relpath(os.path.abspath(args.split), REPO), "sha256": sha256(args.split)},
            "urdf": {"path": os.path.relpath(urdf, REPO), "sha256": sha256(urdf)},
            "figaroh_examples": examples_record(examples),
        },
        "environment": environment(figaroh, pinocchio, scipy),
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
