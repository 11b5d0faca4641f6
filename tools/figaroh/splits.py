"""The train / held-out splits of the 34 TIAGo rows, defined once.

Imported by tiago_cv.py (FIGAROH) and lrmcal_tiago_cv.py (lrmcal), so both
sides fit and hold out exactly the same rows. Standard library only.

A split is a dict ``{"id", "kind", "seed", "folds"}``; ``folds`` is a list
of held-out row lists (0-based data rows of mocap.csv, ascending); a fold's
training rows are all the other rows. Kinds:

``committed``
    host/tests/data/tiago/split.csv: 5 folds (7, 7, 7, 7, 6 rows).
``kfold5``, seed s
    A seeded permutation cut into 5 folds: the rows sorted by the lowercase
    hex SHA-256 of the ASCII string ``lrmcal-tiago-kfold5-v1:<s>:<row>``,
    the row at sorted position i to fold i mod 5 (folds of 7, 7, 7, 7, 6
    rows; every row held out once per permutation).
``leave10``, seed s
    One draw: the rows sorted by the SHA-256 of
    ``lrmcal-tiago-leave10-v1:<s>:<row>``, the first 10 held out, the other
    24 fitted.

The hash order is a seeded shuffle reproducible in any language (the same
method as split.csv's, with another seed string).
"""

import csv
import hashlib
import json

N_FOLDS = 5
N_HELD = 10


def _order(tag, seed, n_rows):
    key = lambda r: hashlib.sha256(f"{tag}:{seed}:{r}".encode("ascii")).hexdigest()
    return sorted(range(n_rows), key=key)


def kfold5(seed, n_rows):
    order = _order("lrmcal-tiago-kfold5-v1", seed, n_rows)
    folds = [sorted(order[i::N_FOLDS]) for i in range(N_FOLDS)]
    return {"id": f"kfold5-s{seed}", "kind": "kfold5", "seed": seed, "folds": folds}


def leave10(seed, n_rows):
    order = _order("lrmcal-tiago-leave10-v1", seed, n_rows)
    return {
        "id": f"leave10-s{seed}",
        "kind": "leave10",
        "seed": seed,
        "folds": [sorted(order[:N_HELD])],
    }


def committed(path):
    """split.csv's folds (columns row, fold)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    fold_of = {int(r["row"]): int(r["fold"]) for r in rows}
    if sorted(fold_of) != list(range(len(fold_of))):
        raise ValueError(f"{path} does not assign each row once")
    folds = [
        sorted(r for r in fold_of if fold_of[r] == k) for k in sorted(set(fold_of.values()))
    ]
    return {"id": "committed", "kind": "committed", "seed": None, "folds": folds}


def seeded(n_rows, seeds):
    """The 5-fold permutations, then the leave-10-out draws, of ``seeds``."""
    return [kfold5(s, n_rows) for s in seeds] + [leave10(s, n_rows) for s in seeds]


def parse_seeds(text):
    """'1-10' or '1,3,5' (or a mix) -> [1, ..., 10]."""
    seeds = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        seeds += list(range(int(lo), int(hi or lo) + 1))
    return seeds


def train_rows(fold, n_rows):
    held = set(fold)
    return [r for r in range(n_rows) if r not in held]


def digest(splits):
    """SHA-256 of the splits' ids and held-out rows: equal on both sides iff
    they fitted and held out the same rows."""
    text = json.dumps([[s["id"], s["folds"]] for s in splits], separators=(",", ":"))
    return hashlib.sha256(text.encode("ascii")).hexdigest()


def check(splits, n_rows):
    """Every fold non-empty, and a k-fold split holds every row out once."""
    for s in splits:
        for fold in s["folds"]:
            assert fold and all(0 <= r < n_rows for r in fold), s["id"]
        if s["kind"] in ("committed", "kfold5"):
            assert sorted(r for f in s["folds"] for r in f) == list(range(n_rows)), s["id"]
        else:
            assert len(s["folds"]) == 1 and len(s["folds"][0]) == N_HELD, s["id"]


if __name__ == "__main__":
    import os
    import sys

    here = os.path.dirname(os.path.abspath(__file__))
    data = os.path.join(here, "..", "..", "host", "tests", "data", "tiago")
    c = committed(os.path.join(data, "split.csv"))
    n = sum(len(f) for f in c["folds"])
    splits = seeded(n, parse_seeds(sys.argv[1] if len(sys.argv) > 1 else "1-10"))
    check([c] + splits, n)
    for s in [c] + splits:
        print(s["id"], " | ".join(" ".join(map(str, f)) for f in s["folds"]))
    print("digest", digest(splits))
