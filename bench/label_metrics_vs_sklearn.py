#!/usr/bin/env python3
"""Cross-check of motionlab's label metrics (motionlab_eval::label_metrics: AMI, ARI, NMI per
sample) against scikit-learn's adjusted_mutual_info_score, adjusted_rand_score and
normalized_mutual_info_score (arithmetic normaliser, sklearn's default): every difference must
be <= 1e-12, on every case, and every case must be compared.

Cases:
- random: lengths 0-3,000, 1-12 labels on each side, labels drawn per sample or per segment
  (runs, as states are), including the degenerate ones (one label on a side, both, identical
  labellings renamed, empty);
- real: the six mocap6 takes' per-frame exercise labels (data/mocap6/truelabels, Fox et al.),
  each against every other take's (cut to the shorter), against itself with its labels merged
  two by two, and against its own segments with the labels permuted across them (what the
  chance baseline draws); TSSB's change points (data/tssb/datasets/desc.txt) as one label per
  segment, against every other series' (cut to the shorter) for the first 20 series.

motionlab's side runs `cargo run -p motionlab-eval --example label_metrics_json` (JSON on stdin).
Run: bench/label_metrics_vs_sklearn.py [N_RANDOM]   (default 300)
"""
import json
import os
import random
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

try:
    import sklearn  # noqa: F401
except ImportError:
    ensure_venv("requirements-labels.txt")

from sklearn.metrics import (  # noqa: E402
    adjusted_mutual_info_score,
    adjusted_rand_score,
    normalized_mutual_info_score,
)

TOL = 1e-12


def random_case(rng):
    n = rng.choice([0, 1, 2, 5, 30, 200, 1000, 3000])
    kt, kf = rng.randint(1, 12), rng.randint(1, 12)
    if rng.random() < 0.5:
        truth = [rng.randrange(kt) for _ in range(n)]
        found = [rng.randrange(kf) for _ in range(n)]
    else:
        def runs(k):
            out = []
            while len(out) < n:
                out += [rng.randrange(k)] * rng.randint(1, max(1, n // 5))
            return out[:n]
        truth, found = runs(kt), runs(kf)
    r = rng.random()
    if r < 0.1:
        found = [7 * x + 3 for x in truth]  # the same partition, renamed
    elif r < 0.15:
        found = [0] * n
    return truth, found


def segments_permuted(labels, rng):
    starts = [i for i in range(len(labels)) if i == 0 or labels[i] != labels[i - 1]]
    seg = [labels[s] for s in starts]
    rng.shuffle(seg)
    out = []
    for k, s in enumerate(starts):
        end = starts[k + 1] if k + 1 < len(starts) else len(labels)
        out += [seg[k]] * (end - s)
    return out


def real_cases(rng):
    folder = os.path.join(ROOT, "data", "mocap6", "truelabels")
    takes = {f: [int(x) for x in open(os.path.join(folder, f)).read().split()] for f in sorted(os.listdir(folder))}
    assert len(takes) == 6, sorted(takes)
    cases = []
    for a, la in takes.items():
        for b, lb in takes.items():
            if a != b:
                n = min(len(la), len(lb))
                cases.append((f"mocap6 {a} vs {b}", la[:n], lb[:n]))
        cases.append((f"mocap6 {a} merged", la, [x // 2 for x in la]))
        cases.append((f"mocap6 {a} permuted", la, segments_permuted(la, rng)))
    series = []
    for line in open(os.path.join(ROOT, "data", "tssb", "datasets", "desc.txt")):
        parts = line.strip().split(",")
        if len(parts) < 2:
            continue
        cps = [int(x) for x in parts[2:]]
        n = int(open(os.path.join(ROOT, "data", "tssb", "datasets", parts[0] + ".txt")).read().count("\n"))
        labels = [sum(1 for c in cps if c <= i) for i in range(n)]
        series.append((parts[0], labels))
    for a, la in series[:20]:
        for b, lb in series[:20]:
            if a < b:
                n = min(len(la), len(lb))
                cases.append((f"tssb {a} vs {b}", la[:n], lb[:n]))
    return cases


def main():
    n_random = int(sys.argv[1]) if len(sys.argv) > 1 else 300
    rng = random.Random(36)
    cases = [(f"random {i}", *random_case(rng)) for i in range(n_random)] + real_cases(rng)
    payload = json.dumps([{"truth": t, "found": f} for _, t, f in cases])
    out = subprocess.run(
        ["cargo", "run", "-q", "-p", "motionlab-eval", "--example", "label_metrics_json"],
        cwd=ROOT, input=payload, capture_output=True, text=True,
    )
    if out.returncode != 0:
        sys.exit(f"label_metrics_json failed:\n{out.stderr}")
    ours = json.loads(out.stdout)
    if len(ours) != len(cases):
        sys.exit(f"motionlab answered {len(ours)} cases of {len(cases)}")
    worst = {"ami": 0.0, "ari": 0.0, "nmi": 0.0}
    bad = []
    compared = 0
    for (name, truth, found), mine in zip(cases, ours, strict=True):
        assert len(truth) == len(found)
        theirs = {
            "ami": adjusted_mutual_info_score(truth, found),
            "ari": adjusted_rand_score(truth, found),
            "nmi": normalized_mutual_info_score(truth, found),
        }
        for k, v in theirs.items():
            d = abs(float(v) - mine[k])
            worst[k] = max(worst[k], d)
            if not d <= TOL:
                bad.append(f"{name} ({len(truth)} samples): {k} motionlab {mine[k]!r} sklearn {float(v)!r}")
        compared += 1
    n_real = len(cases) - n_random
    print(f"{compared} cases compared ({n_random} random, {n_real} real); largest differences: "
          + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    if bad:
        print("\n".join(bad[:20]))
        sys.exit(f"{len(bad)} differences above {TOL}")
    assert compared == len(cases) and n_real == 6 * 5 + 12 + 190, (compared, n_real)
    print(f"all {compared} cases within {TOL} of scikit-learn")


if __name__ == "__main__":
    main()
