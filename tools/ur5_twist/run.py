#!/usr/bin/env python3
"""Simulate the perturbed UR5 for some seeds, calibrate it with lrmcal's
`paper-kinematic` option (plain DH) and ours (`elasto-kinematic-servo`), validate both on the
held-out poses, and print the table of docs/RESULTS.md ("Parallel axes: a UR5
from its URDF").

    python run.py --lrmcal PATH/TO/lrmcal --urdf ur5.urdf --work DIR [--seeds 1 2 3] [--no-register]

For each seed: `simulate_ur5.py` (data and the scipy reference), then

    lrmcal identify --arm ur5.urdf --base-link base_link --tip-link target \
        --measurements fit.csv --option OPTION --out DIR/OPTION
    lrmcal validate --calibration DIR/OPTION/calibration-OPTION.json \
        --measurements held_out.csv         (and held_out_exact.csv)

Everything is written under DIR/seed-N; DIR/summary.json holds the numbers.
"""

import argparse
import json
import pathlib
import re
import statistics
import subprocess
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
OPTIONS = ("paper-kinematic", "elasto-kinematic-servo")
ROW = re.compile(r"^\s*0\s+200\s*\|\s*([\d.]+)\s+[\d.]+\s+([\d.]+)\s+[\d.]+\s+([\d.]+)\s*\|"
                 r"\s*([\d.]+)\s+[\d.]+\s+([\d.]+)\s+[\d.]+\s+([\d.]+)\s*\|", re.M)


def run(cmd, log):
    t0 = time.perf_counter()
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    log.write_text(p.stdout + p.stderr)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(map(str, cmd))}\n{p.stdout}{p.stderr}")
    return p.stdout + p.stderr, seconds


def validate(lrmcal, cal, measurements, log):
    out, seconds = run([lrmcal, "validate", "--calibration", cal, "--measurements", measurements], log)
    m = ROW.search(out)
    if not m:
        sys.exit(f"cannot read the validation of {cal} on {measurements}:\n{out}")
    v = [float(x) for x in m.groups()]
    before = {"mean_mm": v[0], "rms_mm": v[1], "max_mm": v[2]}
    after = {"mean_mm": v[3], "rms_mm": v[4], "max_mm": v[5]}
    return before, after, seconds


def read_points(path):
    """pose -> (x, y, z) mm of a measurement or predictions CSV."""
    rows = [l for l in path.read_text().splitlines() if l and not l.startswith("#")]
    head = rows[0].split(",")
    ix, iy, iz = (head.index(c) for c in ("x_mm", "y_mm", "z_mm"))
    return {r.split(",")[0]: tuple(float(r.split(",")[i]) for i in (ix, iy, iz)) for r in rows[1:]}


def predicted_stats(lrmcal, arm, measurements, out, extra=()):
    """lrmcal predict's points (1e-6 mm) against the file's: finer than validate's 0.01 mm."""
    run([lrmcal, "predict", "--arm", arm, "--poses", measurements, "--out", out, *extra],
        out.with_suffix(".log"))
    pred, meas = read_points(out), read_points(measurements)
    d = [sum((a - b) ** 2 for a, b in zip(pred[k], meas[k])) ** 0.5 for k in meas]
    return {"mean_mm": statistics.mean(d), "rms_mm": statistics.mean(x * x for x in d) ** 0.5,
            "max_mm": max(d)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--lrmcal", required=True, type=pathlib.Path)
    ap.add_argument("--urdf", required=True, type=pathlib.Path)
    ap.add_argument("--work", required=True, type=pathlib.Path)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    ap.add_argument("--no-register", action="store_true",
                    help="keep the URDF's base (the measurements are in base_link's frame)")
    args = ap.parse_args()
    urdf = args.urdf.resolve()
    summary = {"no_register": args.no_register, "seeds": {}}

    for seed in args.seeds:
        d = (args.work / f"seed-{seed}").resolve()
        d.mkdir(parents=True, exist_ok=True)
        run([sys.executable, HERE / "simulate_ur5.py", "--urdf", urdf, "--out", d, "--seed", seed],
            d / "simulate.log")
        ref = json.loads((d / "reference.json").read_text())
        row = {"nominal_python": ref["nominal"], "reference": ref["reference"], "options": {}}
        for option in OPTIONS:
            out = d / option
            cmd = [args.lrmcal, "identify", "--arm", urdf, "--base-link", "base_link",
                   "--tip-link", "target", "--measurements", d / "fit.csv", "--option", option,
                   "--out", out]
            if args.no_register:
                cmd.append("--no-register")
            _, seconds = run(cmd, d / f"identify-{option}.log")
            report = json.loads((out / "report.json").read_text())["options"][0]
            cal = out / f"calibration-{option}.json"
            res = {"identify_seconds": seconds,
                   "fitted": [p["name"] for p in report["fit"]["parameters"]],
                   "held": [p["name"] for p in report["identifiability"]["removed"]],
                   "at_bound": report["fit"]["at_bound"],
                   "fit_rms_mm": report["fit"]["rms_after_mm"]}
            for held in ("held_out", "held_out_exact"):
                before, after, vs = validate(args.lrmcal, cal, d / f"{held}.csv",
                                             d / f"validate-{option}-{held}.log")
                fine = predicted_stats(args.lrmcal, cal, d / f"{held}.csv",
                                       d / f"predict-{option}-{held}.csv")
                for k in after:
                    if abs(after[k] - fine[k]) > 0.0051:
                        sys.exit(f"validate and predict disagree on {cal}, {held}: {after} {fine}")
                res[held] = fine
                res[held + "_before"] = before
                res["validate_seconds"] = vs
            if option == OPTIONS[0]:
                # The nominal arm as the URDF places it (base known), through lrmcal.
                for held in ("held_out", "held_out_exact"):
                    row[f"nominal_{held}"] = predicted_stats(
                        args.lrmcal, urdf, d / f"{held}.csv", d / f"predict-nominal-{held}.csv",
                        ("--base-link", "base_link", "--tip-link", "target"))
            row["options"][option] = res
        summary["seeds"][seed] = row
        print(f"seed {seed} done", file=sys.stderr)

    (args.work / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")

    def cells(s):
        return f"{s['mean_mm']:.3f} / {s['rms_mm']:.3f} / {s['max_mm']:.3f}"

    print("| seed | model | params fitted | held-out (noisy) mean / RMS / max mm "
          "| held-out (exact) mean / RMS / max mm | time s |")
    print("|---|---|---|---|---|---|")
    for seed, row in summary["seeds"].items():
        first = row["options"][OPTIONS[0]]
        print(f"| {seed} | nominal (URDF as is) | 0 | {cells(row['nominal_held_out'])} "
              f"| {cells(row['nominal_held_out_exact'])} | |")
        if not args.no_register:
            print(f"| {seed} | nominal registered (validate's before) | 0 "
                  f"| {cells(first['held_out_before'])} | {cells(first['held_out_exact_before'])} | |")
        for option in OPTIONS:
            r = row["options"][option]
            betas = [p for p in r["fitted"] if p.endswith(".beta")]
            print(f"| {seed} | {option} | {len(r['fitted'])}"
                  f"{' (' + ', '.join(betas) + ')' if betas else ''} | {cells(r['held_out'])} "
                  f"| {cells(r['held_out_exact'])} | {r['identify_seconds']:.2f} |")
        ref = row["reference"]
        print(f"| {seed} | scipy reference | 36 (rank {ref['jacobian_rank']}) "
              f"| {cells(ref['held_out'])} | {cells(ref['held_out_exact'])} | {ref['seconds']:.2f} |")

    def avg(get):
        vals = [get(r) for r in summary["seeds"].values()]
        return {k: statistics.mean(v[k] for v in vals) for k in ("mean_mm", "rms_mm", "max_mm")}

    print(f"\nMean over seeds {', '.join(map(str, summary['seeds']))}:\n")
    print("| model | held-out (noisy) mean / RMS / max mm | held-out (exact) mean / RMS / max mm "
          "| identify time s |")
    print("|---|---|---|---|")
    o0 = OPTIONS[0]
    print(f"| nominal (URDF as is) | {cells(avg(lambda r: r['nominal_held_out']))} "
          f"| {cells(avg(lambda r: r['nominal_held_out_exact']))} | |")
    if not args.no_register:
        print(f"| nominal registered | {cells(avg(lambda r: r['options'][o0]['held_out_before']))} "
              f"| {cells(avg(lambda r: r['options'][o0]['held_out_exact_before']))} | |")
    for option in OPTIONS:
        t = statistics.mean(r["options"][option]["identify_seconds"] for r in summary["seeds"].values())
        print(f"| {option} | {cells(avg(lambda r: r['options'][option]['held_out']))} "
              f"| {cells(avg(lambda r: r['options'][option]['held_out_exact']))} | {t:.2f} |")
    t = statistics.mean(r["reference"]["seconds"] for r in summary["seeds"].values())
    print(f"| scipy reference | {cells(avg(lambda r: r['reference']['held_out']))} "
          f"| {cells(avg(lambda r: r['reference']['held_out_exact']))} | {t:.2f} |")


if __name__ == "__main__":
    main()
