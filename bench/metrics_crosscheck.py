#!/usr/bin/env python3
"""Cross-check of motionlab's boundary metrics against independent implementations on random
cases: every difference must be <= 1e-12.

- Max-matching precision / recall / F1 (motionlab_eval::boundaries): against a maximum
  bipartite matching written here (Kuhn's augmenting paths) on the same time rule |a - r| <= tol.
- Hausdorff distance: against ruptures.metrics.hausdorff.
- ruptures.metrics.precision_recall counts a truth as found when some prediction lies strictly
  within `margin` of it (greedy over the product of truths and predictions, each prediction
  used once, the series' last index excluded) - not a one-to-one maximum matching. The two
  agree when the truths are more than 2*margin apart (every prediction then lies in at most one
  truth's window, and both count the windows hit) with motionlab's tolerance = margin - 1
  (strict < on integer frames); those cases are generated separately and compared.
- TCPDBench's F1 with several annotators and its segment covering (motionlab_eval::cpd_metrics):
  against the formulas of TCPDBench's metrics.py re-implemented below with Python sets, truths
  visited in ascending order.

motionlab's side runs `cargo run -p motionlab-eval --example metrics_json` (JSON on stdin).
Run: bench/metrics_crosscheck.py [N_CASES]   (default 400 general + 300 ruptures cases)
"""
import json
import os
import random
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_modules  # noqa: E402

ensure_modules("numpy", "ruptures")

from ruptures.metrics import hausdorff as rpt_hausdorff  # noqa: E402
from ruptures.metrics import precision_recall as rpt_precision_recall  # noqa: E402

TOL = 1e-12


# --- independent implementations -------------------------------------------------------------
def max_matching(found, truth, tol):
    """Size of a maximum one-to-one matching with |a - r| <= tol (Kuhn's algorithm)."""
    adj = [[j for j, r in enumerate(truth) if abs(a - r) <= tol] for a in found]
    match_truth = [-1] * len(truth)

    def augment(u, seen):
        for v in adj[u]:
            if v in seen:
                continue
            seen.add(v)
            if match_truth[v] == -1 or augment(match_truth[v], seen):
                match_truth[v] = u
                return True
        return False

    return sum(augment(u, set()) for u in range(len(found)))


def tcpd_true_positives(T, X, margin):
    X = set(X)
    TP = set()
    for tau in sorted(T):
        close = sorted((abs(tau - x), x) for x in X if abs(tau - x) <= margin)
        if not close:
            continue
        _, xstar = close[0]
        TP.add(tau)
        X.remove(xstar)
    return TP


def tcpd_f_measure(annotations, predictions, margin, alpha=0.5):
    Tks = {k + 1: set(a) | {0} for k, a in enumerate(annotations)}
    X = set(predictions) | {0}
    Tstar = set().union(*Tks.values())
    K = len(Tks)
    P = len(tcpd_true_positives(Tstar, X, margin)) / len(X)
    R = 1 / K * sum(len(tcpd_true_positives(Tks[k], X, margin)) / len(Tks[k]) for k in Tks)
    return P * R / (alpha * R + (1 - alpha) * P), P, R


def tcpd_partition(locations, n_obs):
    partition, current = [], set()
    cps = iter(sorted(set(locations)))
    cp = next(cps, None)
    for i in range(n_obs):
        if i == cp:
            if current:
                partition.append(current)
            current = set()
            cp = next(cps, None)
        current.add(i)
    partition.append(current)
    return partition


def tcpd_cover_single(S, Sprime):
    T = sum(map(len, Sprime))
    assert T == sum(map(len, S))
    C = 0
    for R in S:
        C += len(R) * max(len(R & Rp) / len(R | Rp) for Rp in Sprime)
    return C / T


def tcpd_covering(annotations, predictions, n_obs):
    pX = tcpd_partition(predictions, n_obs)
    Cs = [tcpd_cover_single(tcpd_partition(a, n_obs), pX) for a in annotations]
    return sum(Cs) / len(Cs)


# --- cases -------------------------------------------------------------------------------------
def frames(rng, n, k):
    return sorted(rng.sample(range(1, n - 1), min(k, n - 2)))


def general_case(rng):
    n = rng.randint(20, 1500)
    truth = frames(rng, n, rng.randint(0, 12))
    found = frames(rng, n, rng.randint(0, 20))
    annotators = [truth] + [frames(rng, n, rng.randint(0, 10)) for _ in range(rng.randint(0, 3))]
    tol = rng.choice([0, 1, 2, 5, 10, 25, 2.5, 7.25])
    return dict(truth=truth, found=found, annotators=annotators, tolerance_frames=tol, margin_frames=rng.randint(0, 30), n_frames=n)


def separated_case(rng):
    """Truths more than 2*margin apart (ruptures' precision_recall is comparable there)."""
    margin = rng.randint(1, 20)
    n = rng.randint(10 * margin + 20, 3000)
    truth, t = [], rng.randint(1, 3 * margin)
    while t < n - 1 and len(truth) < 12:
        truth.append(t)
        t += 2 * margin + 1 + rng.randint(0, 8 * margin)
    found = frames(rng, n, rng.randint(1, 25))
    return dict(truth=truth, found=found, annotators=[truth], tolerance_frames=margin - 1, margin_frames=margin, n_frames=n,
                rpt_margin=margin)


def motionlab(cases):
    env = dict(os.environ, CARGO_TERM_COLOR="never")
    out = subprocess.run(["cargo", "run", "-q", "-p", "motionlab-eval", "--example", "metrics_json"], cwd=ROOT,
                         input=json.dumps(cases), capture_output=True, text=True, env=env)
    if out.returncode != 0:
        sys.exit(f"metrics_json failed:\n{out.stderr}")
    return json.loads(out.stdout)


def ratio(num, den):
    return None if den == 0 else num / den


def compare(n_general, broken=None):
    """Every case against the formulas; the list of failures (empty when all agree). `broken`
    spoils one input on purpose (the self-test): "drop" loses motionlab's last result,
    "cell" moves one of its precisions by 1e-9."""
    rng = random.Random(16)
    general = [general_case(rng) for _ in range(n_general)]
    separated = [separated_case(rng) for _ in range(300)]
    cases = general + separated
    results = motionlab(cases)
    if broken == "drop":
        results = results[:-1]
    if broken == "cell":
        results[7]["precision"] = (results[7]["precision"] or 0.0) + 1e-9
    worst = {}
    counts = {}
    failures = []
    # One result per case, or the comparison below would silently cover fewer cases.
    if len(results) != len(cases):
        return [f"motionlab returned {len(results)} results for {len(cases)} cases"]

    def check(metric, i, ours, theirs):
        counts[metric] = counts.get(metric, 0) + 1
        if ours is None or theirs is None:
            if ours is not theirs:
                failures.append((metric, i, ours, theirs))
            return
        err = abs(ours - theirs)
        worst[metric] = max(worst.get(metric, 0.0), err)
        if not err <= TOL:
            failures.append((metric, i, ours, theirs))

    compared = 0
    for i, (case, res) in enumerate(zip(cases, results, strict=True)):
        compared += 1
        truth, found, n = case["truth"], case["found"], case["n_frames"]
        m = max_matching(found, truth, case["tolerance_frames"])
        check("n_matched (Kuhn)", i, res["n_matched"], m)
        check("precision (Kuhn)", i, res["precision"], ratio(m, len(found)))
        check("recall (Kuhn)", i, res["recall"], ratio(m, len(truth)))
        check("f1 (Kuhn)", i, res["f1"], ratio(2 * m, len(found) + len(truth)))
        if truth and found:
            check("hausdorff (ruptures)", i, res["hausdorff_frames"], float(rpt_hausdorff(truth + [n], found + [n])))
        if case["annotators"]:
            f, p, r = tcpd_f_measure(case["annotators"], found, case["margin_frames"])
            check("tcpd_f1", i, res["tcpd_f1"], f)
            check("tcpd_precision", i, res["tcpd_precision"], p)
            check("tcpd_recall", i, res["tcpd_recall"], r)
            check("covering", i, res["covering"], tcpd_covering(case["annotators"], found, n))
        if "rpt_margin" in case and truth:
            p, r = rpt_precision_recall(truth + [n], found + [n], margin=case["rpt_margin"])
            check("precision (ruptures)", i, res["precision"], p)
            check("recall (ruptures)", i, res["recall"], r)

    print(f"{len(general)} general + {len(separated)} separated-truth random cases: {compared} compared")
    print("| metric | cases compared | max |difference| |")
    print("|---|---:|---:|")
    for metric in counts:
        print(f"| {metric} | {counts[metric]} | {worst.get(metric, 0.0):.3g} |")
    if compared != len(cases):
        failures.append(f"compared {compared} of {len(cases)} cases")
    # Every metric family must have been exercised by some case.
    for metric in ("n_matched (Kuhn)", "hausdorff (ruptures)", "tcpd_f1", "covering", "precision (ruptures)"):
        if counts.get(metric, 0) == 0:
            failures.append(f"no case compared {metric}")
    return failures


def main():
    args = sys.argv[1:]
    if args[:1] == ["--self-test"]:
        # Each deliberately broken input must fail the comparison.
        for broken in ("drop", "cell"):
            failures = compare(50, broken)
            if not failures:
                sys.exit(f"self-test: the comparison passed with a broken input ({broken})")
            print(f"self-test ({broken}): fails as it should: {failures[0]}")
        print("self-test passed: every broken input failed the check")
        return
    failures = compare(int(args[0]) if args else 400)
    if failures:
        for f in failures[:10]:
            print("MISMATCH", f)
        sys.exit(f"{len(failures)} mismatches")
    print("all metrics agree within 1e-12")


if __name__ == "__main__":
    main()
