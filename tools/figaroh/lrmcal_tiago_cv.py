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

Usage: python3 tools/figaroh/lrmcal_tiago_cv.py [--lrmcal target/release/lrmcal]
Standard library only. Build the binary first:
CARGO_TARGET_DIR=target cargo build --release -p host
"""

import argparse
import datetime
import hashlib
import json
import math
import os
import platform
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
DATA = os.path.join(ROOT, "host", "tests", "data", "tiago")
FILES = os.path.join(DATA, "lrmcal")
URDF = os.path.join(DATA, "tiago.urdf")
FOLDS = range(5)
OPTIONS = ["kinematic", "elasto-kinematic", "elasto-kinematic-servo", "elastic"]
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lrmcal", default=os.path.join(ROOT, "target", "release", "lrmcal"))
    ap.add_argument("--options", default=",".join(OPTIONS))
    ap.add_argument("--marker-sets", default=",".join(MARKER_SETS))
    ap.add_argument(
        "--flags",
        default="",
        help="further identify flags for every run, e.g. --no-robust or --level-base",
    )
    ap.add_argument("--out", default=os.path.join(HERE, "results", "lrmcal_tiago_cv.json"))
    args = ap.parse_args()
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
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as f:
        json.dump(report, f, indent=1)
        f.write("\n")
    print(f"wrote {os.path.relpath(args.out, ROOT)}")


if __name__ == "__main__":
    main()
