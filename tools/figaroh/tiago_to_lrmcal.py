#!/usr/bin/env python3
"""Converts the TIAGo mocap data to lrmcal measurement files, per fold.

Reads host/tests/data/tiago/mocap.csv (FIGAROH's TIAGo data: points 1-4 in m,
torso_lift_joint in m, arm_1_joint .. arm_7_joint in rad) and split.csv, and
writes into host/tests/data/tiago/lrmcal/ (or --out):

- all.csv: every row, points 1-3;
- train-K.csv / test-K.csv for each fold K: the rows of the other folds / of
  fold K, points 1-3;
- all-p1.csv, train-K-p1.csv, test-K-p1.csv: the same with point 1 only.

Columns: pose = the mocap row (0-based, header excluded), load_kg = 0,
q1_mm = torso lift in mm, q2_deg .. q8_deg = arm_1 .. arm_7 in degrees,
x_mm, y_mm, z_mm, target = p1, p2, p3 (one row per point). Point 4 is an
exact copy of point 3 in every row and is left out. The rows keep the mocap
file's order, the order the poses were visited in (lrmcal reads which way
each joint arrived from it), the points of a pose together.

Standard library only; the output is a pure function of the two inputs.
Numbers are written as lrmcal's own writers write them: 6 decimals in mm
(1 nm), 9 in degrees, trailing zeros dropped, far below the data's
resolution.
"""

import argparse
import csv
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.normpath(os.path.join(HERE, "..", "..", "host", "tests", "data", "tiago"))

JOINTS = ["torso_lift_joint"] + [f"arm_{i}_joint" for i in range(1, 8)]
HEADER = (
    ["pose", "load_kg", "q1_mm"]
    + [f"q{i}_deg" for i in range(2, 9)]
    + ["x_mm", "y_mm", "z_mm", "target"]
)
POINTS = (1, 2, 3)


def num(value, decimals):
    """`value` to `decimals` decimals, trailing zeros dropped (as lrmcal's
    own writers do: 6 decimals in mm, 1 nm; 9 in degrees)."""
    s = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if s in ("", "-0") else s


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def measurement_rows(mocap, rows, points):
    """The lrmcal rows of the mocap rows `rows` (in the given order)."""
    out = []
    for r in rows:
        m = mocap[r]
        q = [float(m["torso_lift_joint"]) * 1e3] + [
            math.degrees(float(m[j])) for j in JOINTS[1:]
        ]
        for p in points:
            xyz = [float(m[f"{c}{p}"]) * 1e3 for c in "xyz"]
            out.append(
                [str(r), "0", num(q[0], 6)]
                + [num(v, 9) for v in q[1:]]
                + [num(v, 6) for v in xyz]
                + [f"p{p}"]
            )
    return out


def write(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(HEADER)
        w.writerows(rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mocap", default=os.path.join(DATA, "mocap.csv"))
    ap.add_argument("--split", default=os.path.join(DATA, "split.csv"))
    ap.add_argument("--out", default=os.path.join(DATA, "lrmcal"))
    args = ap.parse_args()

    mocap = read_rows(args.mocap)
    fold_of = {int(r["row"]): int(r["fold"]) for r in read_rows(args.split)}
    if sorted(fold_of) != list(range(len(mocap))):
        sys.exit(f"{args.split} does not assign each of the {len(mocap)} rows once")
    for i, m in enumerate(mocap):
        for c in "xyz":
            if m[f"{c}3"] != m[f"{c}4"]:
                sys.exit(f"row {i}: point 4 differs from point 3; this converter drops it")

    os.makedirs(args.out, exist_ok=True)
    every = list(range(len(mocap)))
    folds = sorted(set(fold_of.values()))
    for suffix, points in (("", POINTS), ("-p1", (1,))):
        write(os.path.join(args.out, f"all{suffix}.csv"), measurement_rows(mocap, every, points))
        for k in folds:
            train = [r for r in every if fold_of[r] != k]
            test = [r for r in every if fold_of[r] == k]
            write(
                os.path.join(args.out, f"train-{k}{suffix}.csv"),
                measurement_rows(mocap, train, points),
            )
            write(
                os.path.join(args.out, f"test-{k}{suffix}.csv"),
                measurement_rows(mocap, test, points),
            )
    print(f"wrote {2 + 4 * len(folds)} files to {args.out}")


if __name__ == "__main__":
    main()
