#!/usr/bin/env python3
"""lrmcal on FIGAROH's TIAGo mocap data, cross-validated on the same 5 folds.

For each fold k, marker set and model option: `lrmcal identify` on the
fold's training file (host/tests/data/tiago/lrmcal/train-k[-p1].csv, written
by tiago_to_lrmcal.py), then `lrmcal validate` of the calibration on the
fold's held-out file (test-k[-p1].csv). Prints per fold and pooled over the
34 held-out rows the mean / RMS / max 3D error (mm), and the wall time of
the 5 `identify` runs; writes results/lrmcal_tiago_cv.json.

Pooling: `validate` prints each fold's count, mean, RMS and max (to 0.01 mm);
the pooled mean is the count-weighted mean, the pooled RMS the square root
of the count-weighted mean square, the pooled max the largest. Exact up to
the printed rounding (at most 0.005 mm).

"registration" is the nominal URDF arm placed by lrmcal's registration on
the training rows (base and tool point, closed form, nothing else fitted):
the "before" column of `validate`, reported for point 1 only, where it is
that; with several targets `validate`'s "before" takes the other targets'
tool points from the calibration (fitted with the calibrated arm), which is
no registration-only model.

With --splits seeded: the same on the seeded splits of splits.py (5-fold
permutations and leave-10-out draws, the ones tiago_cv.py uses too), for
lrmcal's default option (no --option) and --option kinematic, each with
robust weighting (lrmcal's default) and with --no-robust; the fold files are
written by tiago_to_lrmcal.py's own row writer into a temporary folder.
A fit identify refuses (exit code 5) writes no calibration: its held-out
rows take the registered nominal arm's errors of that fold (see
run_seeded). Writes results/lrmcal_tiago_splits.json.

Usage: python3 tools/figaroh/lrmcal_tiago_cv.py [--lrmcal target/release/lrmcal]
Standard library only. Build the binary first:
CARGO_TARGET_DIR=target cargo build --release -p host
"""

import argparse
import datetime
import glob
import hashlib
import json
import math
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import splits as splits_mod  # noqa: E402  (beside this script)
import tiago_to_lrmcal  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
DATA = os.path.join(ROOT, "host", "tests", "data", "tiago")
FILES = os.path.join(DATA, "lrmcal")
URDF = os.path.join(DATA, "tiago.urdf")
FOLDS = range(5)
OPTIONS = ["kinematic", "elasto-kinematic", "elasto-kinematic-servo", "elastic"]
# --splits seeded: "default" runs identify without --option (lrmcal's default)
SEEDED_OPTIONS = ["default", "kinematic"]
MOCAP = os.path.join(DATA, "mocap.csv")
POINTS = {"m1": (1,), "m123": (1, 2, 3)}
MARKER_SETS = {"m1": "-p1", "m123": ""}
# The arm: the URDF's chain from its root to the link FIGAROH's example
# measures on (the file has a second leaf, torso_fixed_column_link). Row 2's
# torso lift is 0.18 mm above the URDF's upper limit.
ARM = ["--arm", URDF, "--tip-link", "wrist_ft_tool_link"]
IDENTIFY_EXTRA = ["--allow-outside-limits"]

ROW = re.compile(
    r"^\s*(?P<load>[0-9.]+)\s+(?P<n>\d+)\s+\|"
    r"\s*(?P<b>(?:[0-9.]+\s+){4}[0-9.]+)\s*\|"
    r"\s*(?P<a>(?:[0-9.]+\s+){4}[0-9.]+)\s*\|"
)



def write_json(path, report):
    """Writes `report` to `path` whole, its folder made if need be."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(report, f, indent=1)
        f.write("\n")


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


# `identify`'s exit code for a fit it refuses to write (no calibration
# worse than where the arm started): recorded as a refused fold.
REFUSED = 5


def run(cmd, refusable=False):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0 and not (refusable and p.returncode == REFUSED):
        sys.exit(f"failed ({p.returncode}): {' '.join(cmd)}\n{p.stdout}\n{p.stderr}")
    return p.stdout + p.stderr, dt, p.returncode


def parse_validate(text):
    """(count, before {mean, rms, max}, after {...}) of validate's one load."""
    rows = [m for m in map(ROW.match, text.splitlines()) if m]
    if len(rows) != 1:
        sys.exit(f"expected one load in validate's output:\n{text}")
    m = rows[0]

    def stats(s):
        mean, median, rms, p95, mx = map(float, s.split())
        return {"mean": mean, "median": median, "rms": rms, "p95": p95, "max": mx}

    return int(m["n"]), stats(m["b"]), stats(m["a"])


def pool(folds):
    """The held-out rows of the folds calibrated (a refused fold has none)."""
    folds = [f for f in folds if not f.get("refused")]
    if not folds:
        return None
    n = sum(f["n"] for f in folds)
    return {
        "n": n,
        "mean": sum(f["n"] * f["mean"] for f in folds) / n,
        "rms": math.sqrt(sum(f["n"] * f["rms"] ** 2 for f in folds) / n),
        "max": max(f["max"] for f in folds),
    }


def span(values, form):
    """`values`' range, or their one value, formatted (`–` for none)."""
    values = [v for v in values if v is not None]
    if not values:
        return "–"
    lo, hi = min(values), max(values)
    return form.format(lo) if form.format(lo) == form.format(hi) else f"{form.format(lo)}–{form.format(hi)}"


def fmt(s):
    if s is None or s.get("refused"):
        return "refused"
    return f"{s['mean']:.2f} / {s['rms']:.2f} / {s['max']:.2f}"


def check_files():
    """The committed fold files are what the converter writes."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(
            [sys.executable, os.path.join(HERE, "tiago_to_lrmcal.py"), "--out", tmp],
            check=True,
            capture_output=True,
        )
        for name in sorted(os.listdir(tmp)):
            if sha256(os.path.join(tmp, name)) != sha256(os.path.join(FILES, name)):
                sys.exit(f"{FILES}/{name} differs from what tiago_to_lrmcal.py writes")


def pooled_mean(parts):
    """Count-weighted pooling of (n, mean, rms, max) fold figures."""
    n = sum(p["n"] for p in parts)
    return {
        "n": n,
        "mean": sum(p["n"] * p["mean"] for p in parts) / n,
        "rms": math.sqrt(sum(p["n"] * p["rms"] ** 2 for p in parts) / n),
        "max": max(p["max"] for p in parts),
    }


def median_span(values):
    return {
        "n": len(values),
        "median": statistics.median(values),
        "min": min(values),
        "max": max(values),
    }


def figaroh_nominal(path, digest):
    """FIGAROH's nominal fits on the same splits: {(split, ms, fold): figures}."""
    if not os.path.exists(path):
        return None, "missing"
    with open(path) as f:
        fig = json.load(f)
    if fig.get("splits_digest") != digest:
        return None, "other splits"
    out = {}
    for e in fig["per_split"]:
        for ms in MARKER_SETS:
            run_ = e["runs"].get(f"{ms}/nominal")
            for fold in (run_ or {}).get("folds", []):
                errs = [x for marker in fold["held_out_errors_mm"] for x in marker]
                out[(e["split"], ms, fold["fold"])] = {
                    "n": len(errs),
                    "mean": sum(errs) / len(errs),
                    "rms": math.sqrt(sum(x * x for x in errs) / len(errs)),
                    "max": max(errs),
                }
    return fig, out


def run_seeded(args):
    """lrmcal on the seeded splits of splits.py, the same as tiago_cv.py's.

    Per split, fold, marker set, option (default = no --option, and
    kinematic) and weighting (robust = lrmcal's default, no-robust =
    --no-robust): identify on the fold's training rows, validate on its
    held-out rows. Per split, the count-weighted mean of validate's held-out
    means over the split's folds (all 34 rows of a 5-fold permutation, the 10
    of a leave-10-out draw).

    A refused fit (identify's exit code 5: no calibration written) leaves the
    user with the registered nominal arm: its held-out figures replace the
    fold's. With point 1 (m1) that is validate's "before" column on the same
    fold (lrmcal's registration on the same training rows; the same for every
    option and weighting, checked); with points 1-3 (m123) lrmcal has no
    registration-only model with three tool points, so it is FIGAROH's
    nominal model on the same fold (the base and the three tool points
    least-squares fitted to the training rows, the geometry nominal; read
    from --figaroh, whose splits must be these), which with point 1 equals
    lrmcal's registration to 0.01 mm (checked below on every fold).
    """
    mocap = tiago_to_lrmcal.read_rows(MOCAP)
    n_rows = len(mocap)
    splits = splits_mod.seeded(n_rows, splits_mod.parse_seeds(args.seeds))
    splits_mod.check(splits, n_rows)
    digest = splits_mod.digest(splits)
    options = args.options.split(",")
    weightings = args.weightings.split(",")
    marker_sets = args.marker_sets.split(",")
    configs = [(o, w) for o in options for w in weightings]
    cname = lambda o, w: f"{o}/{w}"
    version, _, _ = run([args.lrmcal, "--version"])
    fig, fig_nominal = figaroh_nominal(args.figaroh, digest)

    t_start = time.perf_counter()
    fits = {}  # (split, ms, fold, config) -> record
    with tempfile.TemporaryDirectory() as tmp:
        for sp in splits:
            for k, test in enumerate(sp["folds"]):
                train = splits_mod.train_rows(test, n_rows)
                for ms in marker_sets:
                    pts = POINTS[ms]
                    stem = os.path.join(tmp, f"{sp['id']}-{k}-{ms}")
                    train_csv, test_csv = stem + "-train.csv", stem + "-test.csv"
                    tiago_to_lrmcal.write(
                        train_csv, tiago_to_lrmcal.measurement_rows(mocap, train, pts)
                    )
                    tiago_to_lrmcal.write(
                        test_csv, tiago_to_lrmcal.measurement_rows(mocap, test, pts)
                    )
                    for option, weighting in configs:
                        out = f"{stem}-{option}-{weighting}"
                        cmd = [args.lrmcal, "identify", "--measurements", train_csv]
                        cmd += ARM + IDENTIFY_EXTRA + args.flags.split()
                        cmd += [] if option == "default" else ["--option", option]
                        cmd += ["--no-robust"] if weighting == "no-robust" else []
                        printed, dt, code = run(cmd + ["--out", out], refusable=True)
                        rec = {"identify_s": dt, "exit_code": code}
                        if code == REFUSED:
                            lines = [l for l in printed.splitlines() if l.strip()]
                            rec |= {"refused": True, "message": lines[-1] if lines else ""}
                        else:
                            (cal,) = glob.glob(os.path.join(out, "calibration-*.json"))
                            with open(cal) as f:
                                n_params = len(json.load(f)["parameters"])
                            with open(os.path.join(out, "report.json")) as f:
                                opt = json.load(f)["options"][0]
                            fit_rms = re.search(r"residual RMS ([0-9.]+) mm", printed)
                            vprinted, _, _ = run(
                                [args.lrmcal, "validate", "--calibration", cal,
                                 "--measurements", test_csv]
                            )
                            n, b, a = parse_validate(vprinted)
                            rec |= {
                                "refused": False,
                                "n": n,
                                "parameters": n_params,
                                "model": (opt.get("model") or {}).get("chosen", opt["option"]),
                                "fit_rms": float(fit_rms[1]) if fit_rms else None,
                                "loo_mean": opt["fit"].get("loo_mean_mm"),
                                "outliers": len(opt["fit"].get("outliers") or []),
                                "converged": opt["fit"].get("converged"),
                                "after": a,
                                "before": b,
                            }
                        fits[(sp["id"], ms, k, cname(option, weighting))] = rec
                        shown = "refused" if rec["refused"] else f"{rec['after']['mean']:.2f} mm"
                        print(f"{sp['id']:11s} fold {k} {ms:4s} {option:9s} {weighting:9s} "
                              f"{shown}  ({dt:.2f} s)", file=sys.stderr)
    wall = time.perf_counter() - t_start

    # the registered nominal arm per fold
    baseline, checks = {}, {"m1_before_spread_mm": 0.0, "m1_vs_figaroh_nominal_mm": None}
    for sp in splits:
        for k, test in enumerate(sp["folds"]):
            for ms in marker_sets:
                recs = [fits[(sp["id"], ms, k, cname(*c))] for c in configs]
                befores = [r["before"] for r in recs if not r["refused"]]
                fig_b = (fig_nominal if isinstance(fig_nominal, dict) else {}).get((sp["id"], ms, k))
                if ms == "m1" and befores:
                    means = [b["mean"] for b in befores]
                    checks["m1_before_spread_mm"] = max(
                        checks["m1_before_spread_mm"], max(means) - min(means)
                    )
                    base = {"n": recs[[not r["refused"] for r in recs].index(True)]["n"],
                            **befores[0], "source": "lrmcal registration (validate's before)"}
                    if fig_b:
                        d = abs(base["mean"] - fig_b["mean"])
                        prev = checks["m1_vs_figaroh_nominal_mm"] or 0.0
                        checks["m1_vs_figaroh_nominal_mm"] = max(prev, d)
                elif fig_b:
                    base = {**fig_b, "source": "FIGAROH nominal, same fold"}
                else:
                    base = None
                baseline[(sp["id"], ms, k)] = base

    per_split, refused_without_baseline = [], []
    for sp in splits:
        entry = {"split": sp["id"], "kind": sp["kind"], "seed": sp["seed"], "runs": {}}
        for ms in marker_sets:
            for c in configs:
                folds, parts = [], []
                for k in range(len(sp["folds"])):
                    rec = fits[(sp["id"], ms, k, cname(*c))]
                    fold = {"fold": k, "test_rows": sp["folds"][k]} | rec
                    if rec["refused"]:
                        base = baseline[(sp["id"], ms, k)]
                        fold["used"] = base
                        if base is None:
                            refused_without_baseline.append((sp["id"], ms, k, cname(*c)))
                        else:
                            parts.append(base)
                    else:
                        parts.append({"n": rec["n"], **rec["after"]})
                    folds.append(fold)
                pooled = pooled_mean(parts) if len(parts) == len(folds) else None
                entry["runs"][f"{ms}/{cname(*c)}"] = {
                    "folds": folds,
                    "pooled": pooled,
                    "refused": sum(f["refused"] for f in folds),
                    "identify_s": sum(f["identify_s"] for f in folds),
                }
        per_split.append(entry)
    if refused_without_baseline:
        sys.exit(
            f"refused fits with no nominal baseline (run tiago_cv.py --splits seeded "
            f"first, --figaroh): {refused_without_baseline}"
        )

    kinds = [k for k in ("kfold5", "leave10") if any(s["kind"] == k for s in splits)]
    summary = {}
    for ms in marker_sets:
        for c in configs:
            key = f"{ms}/{cname(*c)}"
            row = {}
            for kind in kinds:
                runs_ = [e["runs"][key] for e in per_split if e["kind"] == kind]
                recs = [f for r in runs_ for f in r["folds"]]
                models = {}
                for f in recs:
                    m = "refused" if f["refused"] else f["model"]
                    models[m] = models.get(m, 0) + 1
                npar = [f["parameters"] for f in recs if not f["refused"]]
                row[kind] = {
                    "split_mean_mm": median_span([r["pooled"]["mean"] for r in runs_]),
                    "split_rms_mm": median_span([r["pooled"]["rms"] for r in runs_]),
                    "fits": len(recs),
                    "refused": sum(f["refused"] for f in recs),
                    # written but the solver did not report convergence
                    "not_converged": sum(
                        (not f["refused"]) and f["converged"] is False for f in recs
                    ),
                    "models_chosen": models,
                    "n_parameters": [min(npar), max(npar)] if npar else None,
                    "identify_s_total": sum(r["identify_s"] for r in runs_),
                }
            summary[key] = row
    ratios = {}
    if "default" in options and "kinematic" in options:
        for ms in marker_sets:
            for w in weightings:
                for kind in kinds:
                    rs = []
                    for e in per_split:
                        if e["kind"] != kind:
                            continue
                        d = e["runs"][f"{ms}/default/{w}"]["pooled"]["mean"]
                        kin = e["runs"][f"{ms}/kinematic/{w}"]["pooled"]["mean"]
                        rs.append({"split": e["split"], "ratio": d / kin})
                    worst = max(rs, key=lambda r: r["ratio"])
                    ratios[f"{ms}/{w}/{kind}"] = {
                        "worst": worst["ratio"],
                        "worst_split": worst["split"],
                        "median": statistics.median(r["ratio"] for r in rs),
                        "over_1.05": sum(r["ratio"] > 1.05 for r in rs),
                        "splits": len(rs),
                        "per_split": rs,
                    }

    print(f"\n{version.strip()}, seeds {args.seeds}: per-split mean held-out 3D error "
          "(mm), median (min-max) over the splits")
    print("| points | option | weighting | parameters | "
          + " | ".join(f"{k} x{sum(s['kind'] == k for s in splits)}" for k in kinds)
          + " | refused | not converged | models chosen | identify, all fits |")
    print("|---" * (8 + len(kinds)) + "|")
    for key, row in summary.items():
        ms, option, w = key.split("/")
        cells = []
        for kind in kinds:
            sm = row[kind]["split_mean_mm"]
            cells.append(f"{sm['median']:.2f} ({sm['min']:.2f}-{sm['max']:.2f})")
        npar = sorted({p for kind in kinds for p in (row[kind]["n_parameters"] or [])})
        npar = "–" if not npar else (f"{npar[0]}" if len(npar) == 1 else f"{npar[0]}-{npar[-1]}")
        models = {}
        for kind in kinds:
            for m, c in row[kind]["models_chosen"].items():
                models[m] = models.get(m, 0) + c
        ref = sum(row[k]["refused"] for k in kinds)
        nc = sum(row[k]["not_converged"] for k in kinds)
        fits_n = sum(row[k]["fits"] for k in kinds)
        t = sum(row[k]["identify_s_total"] for k in kinds)
        chosen = ", ".join(f"{m} {c}" for m, c in sorted(models.items(), key=lambda x: -x[1]))
        print(f"| {ms} | {option} | {w} | {npar} | " + " | ".join(cells)
              + f" | {ref} of {fits_n} | {nc} | {chosen} | {t:.1f} s |")
    if ratios:
        print("\ndefault / kinematic, per split (same weighting): worst (split), median, "
              "splits with default > 1.05 x kinematic")
        print("| points | weighting | splits | worst | median | > 1.05 x |")
        print("|---|---|---|---|---|---|")
        for key, r in ratios.items():
            ms, w, kind = key.split("/")
            print(f"| {ms} | {w} | {kind} x{r['splits']} | {r['worst']:.3f} ({r['worst_split']}) "
                  f"| {r['median']:.3f} | {r['over_1.05']} of {r['splits']} |")
    print(f"\nchecks: m1 registration ('before') spread over configurations "
          f"{checks['m1_before_spread_mm']:.3f} mm; m1 registration vs FIGAROH nominal "
          f"(largest fold difference of the means) {checks['m1_vs_figaroh_nominal_mm']} mm")
    if fig is not None and fig_nominal:
        print("\nFIGAROH on the same splits (results of tiago_cv.py --splits seeded): "
              "median (min-max) of the per-split means")
        for key, row in fig["summary"].items():
            cells = [f"{row[k]['split_mean_mm']['median']:.2f} ({row[k]['split_mean_mm']['min']:.2f}-"
                     f"{row[k]['split_mean_mm']['max']:.2f})" for k in kinds if k in row]
            div = sum(row[k]["diverged"] for k in kinds if k in row)
            print(f"| {key} | " + " | ".join(cells) + f" | diverged {div} |")
    else:
        print(f"(no FIGAROH results on these splits at {args.figaroh}: {fig_nominal})")

    report = {
        "what": "lrmcal on the TIAGo mocap data, on the seeded splits of splits.py",
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": " ".join(["python3", os.path.relpath(__file__, ROOT)] + sys.argv[1:]),
        "lrmcal": version.strip(),
        "lrmcal_sha256": sha256(args.lrmcal),
        "identify_flags": ARM[2:] + IDENTIFY_EXTRA + args.flags.split(),
        "configurations": {
            cname(o, w): ([] if o == "default" else ["--option", o])
            + (["--no-robust"] if w == "no-robust" else [])
            for o, w in configs
        },
        "inputs": {
            "mocap.csv": sha256(MOCAP),
            "splits_py_sha256": sha256(os.path.join(HERE, "splits.py")),
            "figaroh_results": os.path.relpath(args.figaroh, ROOT) if fig else None,
        },
        "environment": {
            "python": platform.python_version(),
            "cpus": os.cpu_count(),
            "machine": platform.machine(),
        },
        "units": "errors in mm (3D Euclidean distance per target per row); times in s",
        "split_mean": "per split: the count-weighted mean of validate's held-out means "
        "over its folds; a refused fold counts with the registered nominal arm's",
        "refused_fold_baseline": "m1: validate's before column on the fold (lrmcal's "
        "registration); m123: FIGAROH's nominal model on the fold",
        "splits_digest": digest,
        "splits": splits,
        "wall_time_s": wall,
        "checks": checks,
        "summary": summary,
        "default_over_kinematic": ratios,
        "per_split": per_split,
    }
    write_json(args.out, report)
    print(f"wrote {os.path.relpath(args.out, ROOT)}; wall time {wall:.1f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lrmcal", default=os.path.join(ROOT, "target", "release", "lrmcal"))
    ap.add_argument(
        "--options",
        default=None,
        help=f"comma-separated identify options (default: {','.join(OPTIONS)}; with "
        f"--splits seeded {','.join(SEEDED_OPTIONS)}, 'default' = no --option)",
    )
    ap.add_argument("--marker-sets", default=",".join(MARKER_SETS))
    ap.add_argument(
        "--flags",
        default="",
        help="further identify flags for every run, e.g. --no-robust or --level-base",
    )
    ap.add_argument(
        "--out",
        default=None,
        help="results JSON (default: results/lrmcal_tiago_cv.json, with --splits "
        "seeded results/lrmcal_tiago_splits.json)",
    )
    ap.add_argument(
        "--splits",
        choices=("committed", "seeded"),
        default="committed",
        help="committed: the 5 committed fold files (default); seeded: the 5-fold "
        "permutations and leave-10-out draws of splits.py for --seeds",
    )
    ap.add_argument("--seeds", default="1-10", help="with --splits seeded, e.g. 1-10 or 1,2,5")
    ap.add_argument(
        "--weightings",
        default="robust,no-robust",
        help="with --splits seeded: robust (lrmcal's default) and/or no-robust",
    )
    ap.add_argument(
        "--figaroh",
        default=os.path.join(HERE, "results", "tiago_splits.json"),
        help="with --splits seeded: tiago_cv.py's results on the same splits, for "
        "the combined table and the m123 nominal baseline of refused fits",
    )
    args = ap.parse_args()
    if args.splits == "seeded":
        if args.out is None:
            args.out = os.path.join(HERE, "results", "lrmcal_tiago_splits.json")
        if args.options is None:
            args.options = ",".join(SEEDED_OPTIONS)
        return run_seeded(args)
    if args.out is None:
        args.out = os.path.join(HERE, "results", "lrmcal_tiago_cv.json")
    if args.options is None:
        args.options = ",".join(OPTIONS)
    options = args.options.split(",")
    marker_sets = args.marker_sets.split(",")
    check_files()
    version, _, _ = run([args.lrmcal, "--version"])

    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for ms in marker_sets:
            suffix = MARKER_SETS[ms]
            baseline = None
            for option in options:
                folds, before = [], []
                for k in FOLDS:
                    out = os.path.join(tmp, f"{ms}-{option}-{k}")
                    train = os.path.join(FILES, f"train-{k}{suffix}.csv")
                    test = os.path.join(FILES, f"test-{k}{suffix}.csv")
                    printed, dt, code = run(
                        [args.lrmcal, "identify", "--measurements", train]
                        + ARM
                        + IDENTIFY_EXTRA
                        + args.flags.split()
                        + ["--option", option, "--out", out],
                        refusable=True,
                    )
                    if code == REFUSED:
                        folds.append({"fold": k, "refused": True, "identify_s": dt})
                        continue
                    fit_rms = re.search(r"residual RMS ([0-9.]+) mm", printed)
                    cal = os.path.join(out, f"calibration-{option}.json")
                    with open(cal) as f:
                        n_params = len(json.load(f)["parameters"])
                    with open(os.path.join(out, "report.json")) as f:
                        loo = json.load(f)["options"][0]["fit"]["loo_mean_mm"]
                    printed, _, _ = run(
                        [args.lrmcal, "validate", "--calibration", cal, "--measurements", test]
                    )
                    n, b, a = parse_validate(printed)
                    folds.append(
                        {
                            "fold": k,
                            "n": n,
                            "parameters": n_params,
                            "fit_rms": float(fit_rms[1]) if fit_rms else None,
                            "loo_mean": loo,
                            "identify_s": dt,
                            **a,
                        }
                    )
                    before.append({"fold": k, "n": n, **b})
                if baseline is None and len(before) == len(FOLDS):
                    baseline = before
                results[f"{ms}/{option}"] = {
                    "folds": folds,
                    "pooled": pool(folds),
                    "identify_s_total": sum(f["identify_s"] for f in folds),
                }
            if ms == "m1" and baseline:
                results["m1/registration"] = {"folds": baseline, "pooled": pool(baseline)}

    order = ["registration"] + options
    rows = [(ms, m) for ms in marker_sets for m in order if f"{ms}/{m}" in results]
    print(f"\n{version.strip()}, held-out 3D error, mean / RMS / max in mm")
    print(
        "| points | model | parameters | "
        + " | ".join(f"fold {k}" for k in FOLDS)
        + " | all 34 rows | fit RMS | fit leave-one-out mean | identify, 5 fits |"
    )
    print("|---" * (7 + len(FOLDS)) + "|")
    for ms, model in rows:
        r = results[f"{ms}/{model}"]
        if model == "registration":
            extra, params = "– | – | (in each identify)", "9"
        else:
            params = span([f.get("parameters") for f in r["folds"]], "{}")
            extra = (
                span([f.get("fit_rms") for f in r["folds"]], "{:.2f}")
                + " | "
                + span([f.get("loo_mean") for f in r["folds"]], "{:.2f}")
                + f" | {r['identify_s_total']:.2f} s"
            )
        print(
            f"| {ms} | {model} | {params} | "
            + " | ".join(fmt(f) for f in r["folds"])
            + f" | **{fmt(r['pooled'])}** | {extra} |"
        )

    figaroh = os.path.join(HERE, "results", "tiago_cv.json")
    if os.path.exists(figaroh):
        with open(figaroh) as f:
            fig = json.load(f)["runs"]
        print("\nBoth tools, the same folds: all 34 held-out rows, mean / RMS / max in mm")
        print("| points | tool | model | parameters | all 34 rows | time, 5 fits |")
        print("|---|---|---|---|---|---|")
        for ms in marker_sets:
            for model in ["nominal", "joint_offset", "full_params"]:
                r = fig.get(f"{ms}/{model}")
                if not r:
                    continue
                o = r["overall_held_out"]["all"]
                o = {"mean": o["mean_mm"], "rms": o["rms_mm"], "max": o["max_mm"]}
                print(
                    f"| {ms} | FIGAROH 1.0.2 | {model} | {span(r['n_parameters'], '{}')} | "
                    f"{fmt(o)} | {r['time_solve_s_total']:.2f} s solve "
                    f"(+ {r['time_initialize_s_total']:.2f} s initialize) |"
                )
            for model in order:
                r = results.get(f"{ms}/{model}")
                if not r:
                    continue
                if model == "registration":
                    params, t = "9", "–"
                else:
                    params = span([f.get("parameters") for f in r["folds"]], "{}")
                    t = f"{r['identify_s_total']:.2f} s identify"
                print(f"| {ms} | lrmcal | {model} | {params} | {fmt(r['pooled'])} | {t} |")

    report = {
        "what": "lrmcal on the TIAGo mocap data, cross-validated on split.csv",
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": "python3 tools/figaroh/lrmcal_tiago_cv.py",
        "lrmcal": version.strip(),
        "identify_flags": ARM[2:] + IDENTIFY_EXTRA + args.flags.split(),
        "inputs": {
            name: sha256(os.path.join(FILES, name)) for name in sorted(os.listdir(FILES))
        },
        "environment": {
            "python": platform.python_version(),
            "cpus": os.cpu_count(),
            "machine": platform.machine(),
        },
        "units": "errors in mm (3D Euclidean distance per target per row); times in s",
        "runs": results,
    }
    write_json(args.out, report)
    print(f"wrote {os.path.relpath(args.out, ROOT)}")


if __name__ == "__main__":
    main()
