#!/usr/bin/env python3
"""motionlab-changepoint against its peers: ruptures' breakpoints, a NumPy BOCPD, and speed.

Equality (the default; CI runs it):
  * kernel_cpd and window against ruptures 1.1.10 — Pelt (l2, rbf, linear, ar), Binseg (pen
    and n_bkps), KernelCPD PELT (linear kernel = l2, rbf) and Window (l2, rbf, linear, ar) — on
    seeded random series (one and three channels, mean and spread changes, regression series
    for the linear cost, autoregressive series for ar; several min_size / jump) and on real TSSB
    series (data/tssb/datasets), ar also in the TSSB scripts' configuration (min_size 5·w, pen
    10; with min-max normalisation too). Our
    BIC-style penalty and ruptures' median-heuristic bandwidth are checked on the way (the
    penalty against its formula in NumPy, the bandwidth against ruptures' own). Any breakpoint
    difference fails the run.
  * bocpd's run-length posterior against a NumPy implementation of Adams & MacKay's recursion
    written here (independent of the Rust), to <= 1e-9, and the change points read from it.
  * bocpd with model = "bocd_package" against the bocd 0.1.2 package itself (installed into the
    venv without its plotting dependencies if missing): run-length posterior to <= 1e-9, most
    probable run lengths and the run-length-drop change points identical.

Speed (--speed): rbf PELT against ruptures' C KernelCPD on the same inputs (identical
breakpoints required), rounds interleaved, and rbf PELT on n = 100,000 samples with the peak
resident memory of our process. --ar-speed: the ar cost's Pelt, Binseg and Window against
ruptures on TSSB series in the TSSB scripts' configuration (identical breakpoints required).

Our side runs through `cargo run --release -p motionlab-changepoint --example changepoint_json`.

Usage: bench/changepoint_vs_peers.py [--seeds 6] [--tssb-all] [--speed] [--ar-speed] [--rounds 3]
"""
import argparse
import json
import math
import os
import subprocess
import tempfile
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()

import numpy as np  # noqa: E402
import ruptures as rpt  # noqa: E402
from scipy.special import gammaln  # noqa: E402

TSSB = os.path.join(ROOT, "data", "tssb", "datasets")


def ours(jobs):
    """Runs the jobs through the example binary; returns (results, peak RSS in KiB)."""
    payload = json.dumps({"jobs": jobs})
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "motionlab-changepoint", "--example", "changepoint_json"]
    out = subprocess.run(cmd, input=payload, capture_output=True, text=True, cwd=ROOT)
    if out.returncode != 0:
        sys.exit(f"our example failed: {out.stderr}")
    reply = json.loads(out.stdout)
    return reply["results"], reply["peak_rss_kib"]


def job(segmenter, x, params, **extra):
    x = np.asarray(x, dtype=float)
    x2 = x.reshape(len(x), -1)
    # The exact bits (a decimal JSON number would go through a parse, and has no NaN).
    values_hex = np.ascontiguousarray(x2, dtype="<f8").tobytes().hex()
    return {"segmenter": segmenter, "params": params, "values_hex": values_hex, "n_channels": x2.shape[1], **extra}


# ---------------------------------------------------------------------------------------------
# ruptures, called as a user would.

def ruptures_run(seg, x, params, pen):
    """ruptures' breakpoints and the bandwidth it used (None for non-rbf costs)."""
    x = np.asarray(x, dtype=float)
    x = x.reshape(len(x), -1)
    cost = params.get("cost", "rbf" if seg == "kernel_cpd" else "l2")
    min_size = params.get("min_size", 2)
    kparams = {"gamma": params["gamma"]} if "gamma" in params else None
    if "ar_order" in params:
        kparams = {"order": params["ar_order"]}
    if params.get("normalize") == "min_max":
        x = (x - x.min()) / (x.max() - x.min())  # as the TSSB scripts write it
    n_bkps = params.get("n_bkps")
    if seg == "kernel_cpd":
        search = params.get("search", "kernel_pelt")
        if search == "kernel_pelt":
            algo = rpt.KernelCPD(kernel="linear" if cost == "l2" else "rbf", min_size=min_size, params=kparams).fit(x)
            bkps = algo.predict(pen=pen)
        elif search == "pelt":
            algo = rpt.Pelt(model=cost, min_size=min_size, jump=params.get("jump", 5), params=kparams).fit(x)
            bkps = algo.predict(pen=pen)
        else:
            algo = rpt.Binseg(model=cost, min_size=min_size, jump=params.get("jump", 5), params=kparams).fit(x)
            bkps = algo.predict(n_bkps=n_bkps) if n_bkps is not None else algo.predict(pen=pen)
    else:
        algo = rpt.Window(width=params.get("width", 100), model=cost, min_size=min_size, jump=params.get("jump", 5), params=kparams).fit(x)
        bkps = algo.predict(n_bkps=n_bkps) if n_bkps is not None else algo.predict(pen=pen)
    gamma = getattr(algo.cost, "gamma", None) if cost == "rbf" else None
    return [int(b) for b in bkps], gamma


def bic_penalty(x, cost, ar_order=4):
    """The documented BIC-style penalty, from its formula (the ar cost's residuals from
    ruptures' own CostAR of that order, so no number of ours goes into it)."""
    x = np.asarray(x, dtype=float).reshape(len(x), -1)
    n = len(x)
    if cost == "l2":
        return math.log(n) * x.var(axis=0).sum()
    if cost == "rbf":
        return math.log(n)
    if cost == "ar":
        c = rpt.costs.CostAR(order=ar_order).fit(x)
        return math.log(n) * (ar_order + 1) * c.error(0, n) / n
    y, X = x[:, :1], x[:, 1:]
    _, res, _, _ = np.linalg.lstsq(X, y, rcond=None)
    return math.log(n) * X.shape[1] * res.sum() / n


# ---------------------------------------------------------------------------------------------
# Series.

def random_series(rng, n, d, n_changes, spread_changes=False):
    cps = np.sort(rng.choice(np.arange(15, n - 15), n_changes, replace=False)) if n_changes else np.array([], int)
    bounds = [0, *cps.tolist(), n]
    x = np.empty((n, d))
    for a, b in zip(bounds, bounds[1:]):
        loc = rng.normal(0, 2, d) if not spread_changes else np.zeros(d)
        scale = rng.uniform(0.5, 1.5, d) if not spread_changes else rng.choice([0.2, 1.0, 4.0], d)
        x[a:b] = rng.normal(loc, scale, (b - a, d))
    return x


def regression_series(rng, n, n_changes):
    """Columns: response, intercept, time, a random covariate (for the linear cost)."""
    cps = np.sort(rng.choice(np.arange(15, n - 15), n_changes, replace=False))
    bounds = [0, *cps.tolist(), n]
    t = np.arange(n) / n
    z = rng.normal(size=n)
    X = np.column_stack([np.ones(n), t, z])
    y = np.empty(n)
    for a, b in zip(bounds, bounds[1:]):
        beta = rng.normal(0, 3, 3)
        y[a:b] = X[a:b] @ beta + rng.normal(0, 0.5, b - a)
    return np.column_stack([y, X])


def ar_series(rng, n, n_changes):
    """One channel whose AR(2) coefficients change at random points (for the ar cost)."""
    cps = np.sort(rng.choice(np.arange(30, n - 30), n_changes, replace=False))
    bounds = [0, *cps.tolist(), n]
    x = np.zeros(n)
    for a, b in zip(bounds, bounds[1:]):
        phi1, phi2 = rng.uniform(-0.9, 0.9), rng.uniform(-0.4, 0.4)
        for t in range(max(a, 2), b):
            x[t] = phi1 * x[t - 1] + phi2 * x[t - 2] + rng.normal()
    return x + rng.normal(0, 3)


def tssb_series():
    """(name, series) of every TSSB series, shortest first."""
    out = []
    with open(os.path.join(TSSB, "desc.txt")) as f:
        for line in f:
            name = line.strip().split(",")[0]
            out.append((name, np.loadtxt(os.path.join(TSSB, name + ".txt"))))
    return sorted(out, key=lambda s: len(s[1]))


# ---------------------------------------------------------------------------------------------
# Equality with ruptures.

def equality_cases(seeds):
    """(label, segmenter, series, params) of the random cases."""
    cases = []
    grids = [(2, 5), (1, 1), (5, 3), (10, 7)]  # (min_size, jump)
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        d = 1 if seed % 2 == 0 else 3
        n = 160 + 40 * (seed % 3)
        x = random_series(rng, n, d, 2 + seed % 3, spread_changes=seed % 4 == 3)
        xr = regression_series(rng, 150, 2)
        min_size, jump = grids[seed % len(grids)]
        for cost in ("l2", "rbf"):
            base = {"cost": cost, "min_size": min_size, "jump": jump}
            cases.append((f"seed {seed} d{d} Pelt {cost} bic", "kernel_cpd", x, {"search": "pelt", **base}))
            cases.append((f"seed {seed} d{d} Binseg {cost} bic", "kernel_cpd", x, {"search": "binseg", **base}))
            cases.append((f"seed {seed} d{d} Binseg {cost} n_bkps", "kernel_cpd", x, {"search": "binseg", "n_bkps": 3, **base}))
            cases.append((f"seed {seed} d{d} KernelCPD {cost} bic", "kernel_cpd", x, {"search": "kernel_pelt", "cost": cost, "min_size": min_size}))
            cases.append((f"seed {seed} d{d} Window {cost} bic", "window", x, {"width": 30 + 10 * (seed % 3), **base}))
            cases.append((f"seed {seed} d{d} Window {cost} n_bkps", "window", x, {"width": 30, "n_bkps": 2, **base}))
        # A smaller penalty (more breakpoints, more ties to break) and an explicit bandwidth.
        small = 0.25 * bic_penalty(x, "l2")
        cases.append((f"seed {seed} d{d} Pelt l2 pen/4", "kernel_cpd", x, {"search": "pelt", "cost": "l2", "pen": small, "min_size": min_size, "jump": jump}))
        cases.append((f"seed {seed} d{d} KernelCPD rbf gamma", "kernel_cpd", x, {"search": "kernel_pelt", "cost": "rbf", "gamma": 0.3, "pen": 2.0}))
        cases.append((f"seed {seed} d{d} Pelt rbf pen 1", "kernel_cpd", x, {"search": "pelt", "cost": "rbf", "pen": 1.0, "min_size": min_size, "jump": jump}))
        # The linear (regression) cost.
        lin = {"cost": "linear", "min_size": max(min_size, 5), "jump": max(jump, 3)}
        cases.append((f"seed {seed} linear Pelt bic", "kernel_cpd", xr, {"search": "pelt", **lin}))
        cases.append((f"seed {seed} linear Binseg n_bkps", "kernel_cpd", xr, {"search": "binseg", "n_bkps": 2, **lin}))
        cases.append((f"seed {seed} linear Binseg bic", "kernel_cpd", xr, {"search": "binseg", **lin}))
        cases.append((f"seed {seed} linear Window bic", "window", xr, {"width": 40, **lin}))
        # The autoregressive cost (one channel), ruptures' default order and another.
        xa = ar_series(rng, 240 + 30 * (seed % 3), 2)
        ar = {"cost": "ar", "min_size": max(min_size, 10), "jump": jump}
        order = {} if seed % 2 == 0 else {"ar_order": 2 + seed % 3}
        cases.append((f"seed {seed} ar Pelt bic", "kernel_cpd", xa, {"search": "pelt", **ar, **order}))
        cases.append((f"seed {seed} ar Pelt pen 5", "kernel_cpd", xa, {"search": "pelt", "pen": 5.0, **ar, **order}))
        cases.append((f"seed {seed} ar Binseg bic", "kernel_cpd", xa, {"search": "binseg", **ar, **order}))
        cases.append((f"seed {seed} ar Binseg n_bkps", "kernel_cpd", xa, {"search": "binseg", "n_bkps": 2, **ar, **order}))
        cases.append((f"seed {seed} ar Window bic", "window", xa, {"width": 40, **ar, **order}))
        cases.append((f"seed {seed} ar Window min_max", "window", xa, {"width": 40, "pen": 0.05, "normalize": "min_max", **ar}))
    return cases


def tssb_windows():
    with open(os.path.join(TSSB, "desc.txt")) as f:
        return {line.split(",")[0]: int(line.split(",")[1]) for line in f}


def tssb_ar_cases(series, searches=("Pelt", "Binseg", "Window"), normalized=True):
    """The ar cost in the TSSB scripts' configuration: min_size 5·w, Window width 10·w, pen 10
    on the series as given, and pen 0.2 on the min-max normalised series."""
    w = tssb_windows()
    cases = []
    for name, x in series:
        for norm, pen in ((None, 10.0), ("min_max", 0.2)) if normalized else ((None, 10.0),):
            extra = {"normalize": norm} if norm else {}
            tag = f"TSSB {name} (n {len(x)}) {{}} ar{' min_max' if norm else ''}"
            base = {"cost": "ar", "min_size": 5 * w[name], "pen": pen, **extra}
            if "Pelt" in searches:
                cases.append((tag.format("Pelt"), "kernel_cpd", x, {"search": "pelt", "jump": 5, **base}))
            if "Binseg" in searches:
                cases.append((tag.format("Binseg"), "kernel_cpd", x, {"search": "binseg", "jump": 5, **base}))
            if "Window" in searches:
                cases.append((tag.format("Window"), "window", x, {"width": 10 * w[name], **base}))
    return cases


def head_gamma(x):
    """1 / the median squared distance between the first 2000 samples (NumPy)."""
    head = np.asarray(x, dtype=float).ravel()[:2000]
    return float(1.0 / np.median((head[:, None] - head[None, :])[np.triu_indices(len(head), 1)] ** 2))


def tssb_cases(all_series):
    cases = []
    series = tssb_series()
    short = [s for s in series if len(s[1]) <= 1300]
    # ruptures' Pelt with the ar cost solves one regression per (start, end) pair: seconds to
    # minutes per series; CI takes the five shortest, --tssb-all every series.
    cases += tssb_ar_cases(series if all_series else series[:5])
    for name, x in series if all_series else series[:: max(1, len(series) // 12)]:
        for cost in ("l2", "rbf"):
            params = {"search": "kernel_pelt", "cost": cost}
            if cost == "rbf" and len(x) > 4000:
                # ruptures' median heuristic needs the n² matrix: both are given the script's
                # own bandwidth (the median heuristic on the first 2000 samples, in NumPy), so
                # no number of ours reaches ruptures; the heuristic itself is compared with
                # ruptures' on the shorter series.
                params["gamma"] = head_gamma(x)
            cases.append((f"TSSB {name} (n {len(x)}) KernelCPD {cost} bic", "kernel_cpd", x, params))
    for name, x in short:
        for cost in ("l2", "rbf"):
            jump = 5 if cost == "l2" else 10
            cases.append((f"TSSB {name} (n {len(x)}) Pelt {cost} bic", "kernel_cpd", x, {"search": "pelt", "cost": cost, "jump": jump}))
            cases.append((f"TSSB {name} (n {len(x)}) Binseg {cost} bic", "kernel_cpd", x, {"search": "binseg", "cost": cost, "jump": jump}))
            cases.append((f"TSSB {name} (n {len(x)}) Binseg {cost} n_bkps 4", "kernel_cpd", x, {"search": "binseg", "cost": cost, "n_bkps": 4, "jump": jump}))
            cases.append((f"TSSB {name} (n {len(x)}) Window {cost} bic", "window", x, {"cost": cost, "width": 50}))
            cases.append((f"TSSB {name} (n {len(x)}) Window {cost} n_bkps 3", "window", x, {"cost": cost, "width": 50, "n_bkps": 3}))
    return cases


def check_equality(cases, broken=None):
    """Every case against ruptures; (failures, cases compared). `broken` spoils one input on
    purpose (the self-test): "drop" loses our last result, "pen" hands ruptures a penalty 0.05
    times the formula's, "bkps" moves one of our breakpoints."""
    results, _ = ours([job(seg, x, params) for _, seg, x, params in cases])
    if broken == "drop":
        results = results[:-1]
    failures = []
    # One result per case, or the comparison below would silently cover fewer cases.
    if len(results) != len(cases):
        return [f"ruptures cases: {len(results)} results of ours for {len(cases)} cases"], 0
    families = {}
    worst_gamma = 0.0
    worst_pen = 0.0
    gamma_inexact = []
    n_pen = n_gamma = compared = 0
    want_gamma = sum(1 for _, seg, x, p in cases if p.get("cost", "rbf" if seg == "kernel_cpd" else "l2") == "rbf" and "gamma" not in p)
    want_pen = sum(1 for _, _, _, p in cases if "pen" not in p and "n_bkps" not in p)
    for i, ((label, seg, x, params), r) in enumerate(zip(cases, results, strict=True)):
        search = next(w for w in ("Pelt", "Binseg", "KernelCPD", "Window") if f" {w} " in label)
        cost = params.get("cost", "rbf" if seg == "kernel_cpd" else "l2")
        mode = "n_bkps" if "n_bkps" in params else "pen"
        fam = families.setdefault(f"{'TSSB' if label.startswith('TSSB') else 'random'} {search} {cost} {mode}", [0, 0])
        fam[0] += 1
        if "error" in r:
            failures.append(f"{label}: ours failed: {r['error']}")
            continue
        # ruptures gets the penalty the script computes from the documented formula (ruptures'
        # own CostAR for the ar cost), never ours; ours is checked against the same formula for
        # every cost and ar_order used.
        if "pen" in params:
            pen = params["pen"]
        elif "n_bkps" in params:
            pen = None
        else:
            xx = np.asarray(x, dtype=float)
            if params.get("normalize") == "min_max":
                xx = (xx - xx.min()) / (xx.max() - xx.min())
            pen = bic_penalty(xx, cost, params.get("ar_order", 4))
            worst_pen = max(worst_pen, abs(r["pen"] - pen) / pen)
            n_pen += 1
        if broken == "pen" and pen is not None:
            pen = 0.05 * pen
        try:
            theirs, gamma = ruptures_run(seg, x, params, pen)
        except Exception as e:  # noqa: BLE001
            failures.append(f"{label}: ruptures raised {type(e).__name__}: {e}")
            continue
        if gamma is not None and "gamma" not in params:
            if r["gamma"] is None:
                failures.append(f"{label}: ours reports no bandwidth")
            else:
                n_gamma += 1
                worst_gamma = max(worst_gamma, abs(r["gamma"] - gamma) / gamma)
                if r["gamma"] != gamma:
                    gamma_inexact.append(f"{label} ({x.shape[1] if x.ndim > 1 else 1} channel(s))")
        mine = list(r["breakpoints"])
        if broken == "bkps" and i == len(cases) - 1:
            mine[0] += 1
        compared += 1
        if theirs != mine:
            failures.append(f"{label}: ruptures {theirs} ours {mine}")
            continue
        fam[1] += 1
    print(f"{'family':<34} {'cases':>6} {'identical':>10}")
    for fam, (n, ok) in sorted(families.items()):
        print(f"{fam:<34} {n:>6} {ok:>10}")
    print(f"BIC penalty vs its NumPy formula ({n_pen} cases, every cost and ar_order used): max relative difference {worst_pen:.1e}")
    print(f"median-heuristic bandwidth vs ruptures' ({n_gamma} cases): max relative difference {worst_gamma:.1e}; not bit-identical in: {', '.join(gamma_inexact) or 'none'}")
    if worst_pen > 1e-12:
        failures.append(f"BIC penalty differs from its formula by {worst_pen:.1e} (relative)")
    # scipy may sum a multichannel distance in another order: a few units in the last place.
    if worst_gamma > 1e-15:
        failures.append(f"median-heuristic bandwidth differs from ruptures' by {worst_gamma:.1e} (relative)")
    if compared != len(cases):
        failures.append(f"ruptures cases: {compared} compared of {len(cases)}")
    if n_pen != want_pen:
        failures.append(f"BIC penalty: {n_pen} compared of {want_pen}")
    if n_gamma != want_gamma:
        failures.append(f"median-heuristic bandwidth: {n_gamma} compared of {want_gamma}")
    return failures, compared


# ---------------------------------------------------------------------------------------------
# BOCPD: Adams & MacKay's recursion in NumPy, Normal-Gamma model (Murphy 2007), channels
# independent, missing samples skipped.

def bocpd_reference(x, lam=100.0, mu0=0.0, kappa0=1.0, alpha0=1.0, beta0=1.0, normalize="z_score", truncate=0.0):
    x = np.array(x, dtype=float).reshape(len(x), -1)
    n, d = x.shape
    if normalize == "z_score":
        for c in range(d):
            m = np.nanmean(x[:, c])
            s = np.nanstd(x[:, c], ddof=1) if np.sum(~np.isnan(x[:, c])) > 1 else 0.0
            x[:, c] = (x[:, c] - m) / s if s > 0 else x[:, c] - m
    h = 1.0 / lam
    R = np.array([1.0])
    mu = np.full((1, d), mu0)
    kappa = np.full((1, d), kappa0)
    alpha = np.full((1, d), alpha0)
    beta = np.full((1, d), beta0)
    rows = []
    for t in range(n):
        xt = x[t]
        seen = ~np.isnan(xt)
        nu = 2 * alpha
        s2 = beta * (kappa + 1) / (alpha * kappa)
        lp = gammaln((nu + 1) / 2) - gammaln(nu / 2) - 0.5 * np.log(np.pi * nu * s2) - (nu + 1) / 2 * np.log1p((xt - mu) ** 2 / (nu * s2))
        lp = np.where(seen, lp, 0.0).sum(axis=1)
        w = R * np.exp(lp - lp.max())
        new = np.concatenate([[h * w.sum()], (1 - h) * w])
        R = new / new.sum()
        x_or_mu = np.where(seen, xt, mu)
        mu_new = np.where(seen, (kappa * mu + x_or_mu) / (kappa + 1), mu)
        beta_new = np.where(seen, beta + kappa * (x_or_mu - mu) ** 2 / (2 * (kappa + 1)), beta)
        kappa_new = np.where(seen, kappa + 1, kappa)
        alpha_new = np.where(seen, alpha + 0.5, alpha)
        mu = np.vstack([np.full((1, d), mu0), mu_new])
        beta = np.vstack([np.full((1, d), beta0), beta_new])
        kappa = np.vstack([np.full((1, d), kappa0), kappa_new])
        alpha = np.vstack([np.full((1, d), alpha0), alpha_new])
        if truncate > 0:
            keep = np.nonzero(R >= truncate)[0]
            last = keep[-1] + 1
            if last < len(R):
                R, mu, beta, kappa, alpha = R[:last] / R[:last].sum(), mu[:last], beta[:last], kappa[:last], alpha[:last]
        rows.append(R.copy())
    return rows


def bocpd_candidates(rows):
    """The documented rule: MAP run lengths read backwards from the last sample."""
    n = len(rows)
    r_map = [int(np.argmax(r)) for r in rows]
    out = set()
    t = n - 1
    while t >= 0:
        r = r_map[t]
        if r == 0:
            if t + 1 < n:
                out.add(t + 1)
            t -= 1
            continue
        start = t + 1 - r
        if start > 0:
            out.add(start)
        t = start - 1
    return sorted(out)


def check_bocpd(broken=None):
    cases = []
    for seed in range(4):
        rng = np.random.default_rng(77 + seed)
        d = 1 + seed % 2
        x = random_series(rng, 240, d, 2, spread_changes=seed == 2) * (50.0 if seed == 1 else 1.0) + (1000.0 if seed == 3 else 0.0)
        if seed == 3:
            x[40:55, 0] = np.nan  # a gap
        params = {}
        if seed == 1:
            params = {"lambda": 40.0, "prior_kappa": 0.5, "prior_alpha": 2.0, "prior_beta": 0.5}
        if seed == 2:
            params = {"normalize": "none", "prior_mean": 0.3}
        if seed == 3:
            params = {"truncate_below": 1e-6}
        cases.append((f"seed {seed} d{d} {params}", x, params))
    x = tssb_series()[0][1]  # Chinatown, 240 samples
    cases.append(("TSSB Chinatown", x, {}))
    results, _ = ours([job("bocpd", x, params, posterior=True) for _, x, params in cases])
    if broken == "posterior":
        results[0]["posterior"][-1][0] += 1e-6
    failures = []
    if len(results) != len(cases):
        return [f"bocpd: {len(results)} results of ours for {len(cases)} series"], 0
    worst = 0.0
    compared = n_cps = 0
    for (label, x, params), r in zip(cases, results, strict=True):
        if "error" in r:
            failures.append(f"bocpd {label}: ours failed: {r['error']}")
            continue
        ref = bocpd_reference(
            x,
            lam=params.get("lambda", 100.0),
            mu0=params.get("prior_mean", 0.0),
            kappa0=params.get("prior_kappa", 1.0),
            alpha0=params.get("prior_alpha", 1.0),
            beta0=params.get("prior_beta", 1.0),
            normalize=params.get("normalize", "z_score"),
            truncate=params.get("truncate_below", 0.0),
        )
        post = r["posterior"]
        if [len(a) for a in post] != [len(a) for a in ref]:
            failures.append(f"bocpd {label}: posterior row lengths differ")
            continue
        diff = max(float(np.max(np.abs(np.array(a) - b))) for a, b in zip(post, ref))
        worst = max(worst, diff)
        if diff > 1e-9:
            failures.append(f"bocpd {label}: run-length posterior differs by {diff:.2e}")
        if bocpd_candidates(ref) != r["candidates"]:
            failures.append(f"bocpd {label}: change points {r['candidates']} vs the reference's {bocpd_candidates(ref)}")
        compared += 1
        n_cps += len(bocpd_candidates(ref))
    print(f"bocpd: {compared} of {len(cases)} series compared, run-length posterior (every row, full length) max |difference| {worst:.1e} "
          f"(<= 1e-9 required), change points ({n_cps} in all) identical: {not any('change points' in f for f in failures)}")
    if compared != len(cases):
        failures.append(f"bocpd: {compared} series compared of {len(cases)}")
    if n_cps == 0:
        failures.append("bocpd: no change point was compared")
    return failures, compared


def import_bocd():
    """The bocd 0.1.2 package (numpy and scipy are all it imports; its declared matplotlib and
    pandas dependencies are left out)."""
    try:
        import bocd
    except ImportError:
        subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-deps", "bocd==0.1.2"], check=True)
        import bocd
    return bocd


# TSSB series (2,080–4,000 samples) on which the package's most probable run length climbs
# past 250 samples: on five of them it then falls by 250 or more (6 change points in all, the
# package's own answer), on OSULeaf it peaks at 251 and does not.
BOCD_LONG_TSSB = ("Car", "ShapeletSim", "DistalPhalanxTW", "UWaveGestureLibraryX", "ProximalPhalanxTW", "OSULeaf")
BOCD_MIN_CPS = 6


def check_bocd_package(broken=None):
    """bocpd's bocd_package model against the bocd package, as the TSSB scripts call it: the
    run-length posterior of every sample (full length: ours, zero-padded, against the package's
    whole belief vector) on the series whose posterior is asked for, and on every series the
    most probable run lengths and the run-length-drop change points. The series are long enough
    for runs of more than 250 samples, so the drop fires: the check fails unless change points
    were compared."""
    import warnings
    from importlib.metadata import version

    bocd = import_bocd()
    cases = []
    rng = np.random.default_rng(31)
    cases.append(("random, mean and spread changes", random_series(rng, 700, 1, 3)[:, 0], True))
    cases.append(("random AR, 2 changes", ar_series(rng, 900, 2), True))
    for name, x in tssb_series()[:3]:
        cases.append((f"TSSB {name}", x, True))
    # TSSB series with runs longer than the threshold (the package's drop fires on them); the
    # posterior of a series this long (n² / 2 numbers) is not exported, only its MAP path.
    for name, x in tssb_series():
        if name in BOCD_LONG_TSSB:
            cases.append((f"TSSB {name}", x, False))
    params = {"model": "bocd_package", "normalize": "min_max", "lambda": 100.0, "change_points": "run_length_drop", "drop_threshold": 250.0}
    results, _ = ours([job("bocpd", x, params, posterior=post) for _, x, post in cases])
    if broken == "drop":
        results = results[:-1]
    if broken == "posterior":
        results[0]["posterior"][-1][-1] += 1e-6  # the last entry: a prefix comparison would miss it
    if len(results) != len(cases):
        return [f"bocd package: {len(results)} results of ours for {len(cases)} series"], 0
    failures = []
    worst = 0.0
    n_cps = compared = n_post = 0
    for (label, x, post), r in zip(cases, results, strict=True):
        if "error" in r:
            failures.append(f"bocd package {label}: ours failed: {r['error']}")
            continue
        xs = (x - x.min()) / (x.max() - x.min())
        bc = bocd.BayesianOnlineChangePointDetection(bocd.ConstantHazard(100), bocd.StudentT())
        rt, diff = [], 0.0
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for t, v in enumerate(xs):
                bc.update(v)
                rt.append(int(bc.rt[0]))
                if post:
                    belief = bc.belief
                    mine = np.array(r["posterior"][t], dtype=float)
                    if len(mine) > len(belief):
                        failures.append(f"bocd package {label}: sample {t}: our posterior has {len(mine)} run lengths, the package's {len(belief)}")
                        break
                    full = np.zeros(len(belief))
                    full[: len(mine)] = mine
                    diff = max(diff, float(np.max(np.abs(full - belief))))
        if post:
            n_post += 1
            if len(r["posterior"]) != len(xs):
                failures.append(f"bocd package {label}: our posterior has {len(r['posterior'])} rows for {len(xs)} samples")
        worst = max(worst, diff)
        theirs = np.where(np.diff(np.array(rt, dtype=float)) <= -250)[0].tolist()
        n_cps += len(theirs)
        compared += 1
        if diff > 1e-9:
            failures.append(f"bocd package {label}: run-length posterior differs by {diff:.2e}")
        if rt != r["map_run_length"]:
            failures.append(f"bocd package {label}: most probable run lengths differ")
        if theirs != r["candidates"]:
            failures.append(f"bocd package {label}: change points {r['candidates']} vs the package's {theirs}")
    print(f"bocd {version('bocd')} package: {compared} of {len(cases)} series compared ({n_post} with their full run-length posterior: "
          f"max |difference| {worst:.1e}, <= 1e-9 required); MAP run lengths and run-length-drop change points ({n_cps} in all) "
          f"identical: {not any('differ' in f or 'change points' in f for f in failures)}")
    if compared != len(cases):
        failures.append(f"bocd package: {compared} series compared of {len(cases)}")
    if n_cps < BOCD_MIN_CPS:
        failures.append(f"bocd package: only {n_cps} change points compared, expected at least {BOCD_MIN_CPS} (the long TSSB series')")
    return failures, compared


def check_inlined_exp():
    """KernelCPD's C calls glibc's exp; ours inlines it: every argument the kernel can produce."""
    r = ours([{"segmenter": "verify_exp", "stride": 1}])[0][0]
    if r["compared"] == 0:
        # Ours inlines exp only on x86-64 Linux with glibc and FMA + AVX2; where the CPU has
        # them, nothing compared means the check did not run.
        flags = open("/proc/cpuinfo").read().split() if os.path.exists("/proc/cpuinfo") else []
        if "fma" in flags and "avx2" in flags:
            return ["inlined exp: the CPU has FMA and AVX2 but no argument was compared"]
        print("inlined exp: NOT CHECKED: not used on this machine (no FMA/AVX2); the system exp is called")
        return []
    print(f"inlined exp vs the system's on all {r['compared']:,} single-precision kernel arguments: {r['differ']} differ")
    return [f"inlined exp differs from the system's on {r['differ']} arguments"] if r["differ"] else []


# ---------------------------------------------------------------------------------------------
# Speed.

def repetitions_for(seconds_once, at_least=0.25):
    """Repetitions so that a run of `seconds_once` lasts `at_least` seconds in all: the thread
    CPU clock ours reads (/proc/thread-self/schedstat) moves in scheduler ticks (4 ms), so a
    short run timed once could read 0."""
    return max(1, math.ceil(at_least / max(seconds_once, 1e-6)))


def speed(rounds, quick=False):
    print(f"\nrbf PELT: ours (kernel_pelt) vs ruptures' C KernelCPD(kernel='rbf'), same inputs, gamma given, "
          f"median of {rounds} interleaved rounds; CPU time of the computing thread (wall time on a shared machine counts waits), "
          "each round repeated to last at least 0.25 s and divided by the repetitions")
    print(f"{'input':<28} {'n':>7} {'bkps':>5} {'ruptures CPU s':>15} {'ours CPU s':>11} {'ratio':>7} {'wall ratio':>11}")
    inputs = []
    rng = np.random.default_rng(5)
    for n in (2000,) if quick else (2000, 5000, 10000, 20000):
        inputs.append(("random, 10 segments", random_series(rng, n, 1, 9)))
    for name, x in tssb_series():
        if name in (("Chinatown",) if quick else ("Crop", "Yoga", "InsectWingbeatSound", "ECG200")):
            inputs.append((f"TSSB {name}", x))
    totals = np.zeros(4)
    for label, x in inputs:
        x = np.asarray(x, dtype=float).ravel()
        n = len(x)
        # The median heuristic on the first 2000 samples (ruptures' own would need the n² matrix).
        head = x[:2000]
        gamma = 1.0 / np.median((head[:, None] - head[None, :])[np.triu_indices(len(head), 1)] ** 2)
        pen = math.log(n)
        cpu_theirs, wall_theirs, cpu_ours, wall_ours = [], [], [], []
        params = {"search": "kernel_pelt", "cost": "rbf", "gamma": gamma, "pen": pen}
        t0 = time.perf_counter()
        rpt.KernelCPD(kernel="rbf", params={"gamma": gamma}).fit(x.reshape(-1, 1)).predict(pen=pen)
        reps_theirs = repetitions_for(time.perf_counter() - t0)
        reps_ours = repetitions_for(ours([job("kernel_cpd", x, params)])[0][0]["seconds"][0])
        for _ in range(rounds):
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(reps_theirs):
                theirs = rpt.KernelCPD(kernel="rbf", params={"gamma": gamma}).fit(x.reshape(-1, 1)).predict(pen=pen)
            cpu_theirs.append((time.process_time() - c0) / reps_theirs)
            wall_theirs.append((time.perf_counter() - t0) / reps_theirs)
            r = ours([job("kernel_cpd", x, params, repeats=reps_ours)])[0][0]
            if len(r["cpu_seconds"]) != reps_ours or None in r["cpu_seconds"]:
                sys.exit(f"speed input {label}: ours gave {r['cpu_seconds']} CPU times for {reps_ours} repetitions")
            cpu_ours.append(sum(r["cpu_seconds"]) / reps_ours)
            wall_ours.append(sum(r["seconds"]) / reps_ours)
            if r["breakpoints"] != [int(b) for b in theirs]:
                sys.exit(f"speed input {label}: breakpoints differ: ruptures {theirs} ours {r['breakpoints']}")
        m = [float(np.median(v)) for v in (cpu_theirs, cpu_ours, wall_theirs, wall_ours)]
        if min(m) <= 0:
            sys.exit(f"speed input {label}: a timer read zero ({m}) even over {reps_theirs} / {reps_ours} repetitions")
        totals += m
        print(f"{label:<28} {n:>7} {len(theirs) - 1:>5} {m[0]:>15.3f} {m[1]:>11.3f} {m[0] / m[1]:>6.1f}× {m[2] / m[3]:>10.1f}×")
    print(f"{'all inputs (sums)':<28} {'':>7} {'':>5} {totals[0]:>15.3f} {totals[1]:>11.3f} {totals[0] / totals[1]:>6.1f}× {totals[2] / totals[3]:>10.1f}×")
    if quick:
        return

    print("\nrbf PELT on n = 100,000 samples (10 segments, one channel, median-heuristic bandwidth), one process each:")
    x = random_series(np.random.default_rng(9), 100_000, 1, 9)
    for search in ("kernel_pelt", "pelt"):
        params = {"search": search, "cost": "rbf"}
        if search == "pelt":
            params["jump"] = 5
        r, rss = ours([job("kernel_cpd", x, params)])
        r = r[0]
        print(f"  {search:<12} {r['cpu_seconds'][0]:7.2f} s CPU ({r['seconds'][0]:.2f} s wall), {len(r['breakpoints']) - 1} change points, "
              f"peak RSS {rss / 1024:.1f} MiB (the process, JSON input included)")
    print("  ruptures: Pelt(model='rbf') and KernelCPD's median heuristic build the Gram matrix, "
          f"{100_000 ** 2 * 8 / 2 ** 30:.0f} GiB of float64 (plus the {100_000 * 99_999 / 2 * 8 / 2 ** 30:.0f} GiB condensed distances) — not run.")
    # What ruptures can do at this n: given the bandwidth, its C KernelCPD needs no Gram matrix.
    # Both sides get the same gamma (the median heuristic on the first 2000 samples) and
    # penalty; each runs in a fresh process so the peak RSS is that run's alone.
    head = x[:2000]
    gamma = 1.0 / np.median((head[:, None] - head[None, :])[np.triu_indices(len(head), 1)] ** 2)
    pen = math.log(len(x))
    r, rss_ours = ours([job("kernel_cpd", x, {"search": "kernel_pelt", "cost": "rbf", "gamma": gamma, "pen": pen})])
    r = r[0]
    theirs = ruptures_subprocess_kernelcpd(x, gamma, pen)
    if theirs["breakpoints"] != r["breakpoints"]:
        sys.exit(f"n = 100,000 given gamma: breakpoints differ: ruptures {theirs['breakpoints']} ours {r['breakpoints']}")
    print(f"  given gamma {gamma:.4g} and pen log n: ours {r['cpu_seconds'][0]:.2f} s CPU, peak RSS {rss_ours / 1024:.1f} MiB; "
          f"ruptures KernelCPD(kernel='rbf', params={{'gamma': …}}) {theirs['cpu_seconds']:.2f} s CPU, peak RSS {theirs['peak_rss_kib'] / 1024:.1f} MiB "
          f"(a Python process with NumPy and ruptures loaded): ruptures / ours {theirs['cpu_seconds'] / r['cpu_seconds'][0]:.1f}× CPU; "
          f"breakpoints identical ({len(r['breakpoints']) - 1} change points)")


def ruptures_subprocess_kernelcpd(x, gamma, pen):
    """ruptures' KernelCPD(rbf, gamma given) on x in a fresh Python process: its breakpoints,
    thread CPU seconds and the process's peak RSS (KiB, from getrusage)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "x.npy")
        np.save(path, x.reshape(-1, 1))
        code = (
            "import json, resource, sys, time, numpy as np, ruptures as rpt\n"
            "x = np.load(sys.argv[1]); t = time.thread_time()\n"
            "b = rpt.KernelCPD(kernel='rbf', params={'gamma': float(sys.argv[2])}).fit(x).predict(pen=float(sys.argv[3]))\n"
            "print(json.dumps({'breakpoints': [int(v) for v in b], 'cpu_seconds': time.thread_time() - t, "
            "'peak_rss_kib': resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))\n"
        )
        out = subprocess.run([sys.executable, "-c", code, path, repr(float(gamma)), repr(float(pen))], capture_output=True, text=True)
        if out.returncode != 0:
            sys.exit(f"ruptures at n = 100,000 failed: {out.stderr}")
        return json.loads(out.stdout)


def ar_speed():
    """The ar cost's searches against ruptures on TSSB series, the TSSB scripts' settings."""
    picks = ["Coffee", "SonyAIBORobotSurface1", "UMD", "ECG200", "ToeSegmentation2", "Plane", "InsectWingbeatSound"]
    series = [s for s in tssb_series() if s[0] in picks]
    print("ar cost, TSSB scripts' settings (min_size 5·w, pen 10, Window width 10·w); CPU seconds, identical breakpoints required")
    print(f"{'search':<8} {'series':<24} {'n':>6} {'ruptures s':>11} {'ours s':>9} {'ratio':>8}")
    totals = {}
    for search in ("Pelt", "Binseg", "Window"):
        for label, seg, x, params in tssb_ar_cases(series, searches=(search,), normalized=False):
            c0 = time.process_time()
            theirs, _ = ruptures_run(seg, x, params, params["pen"])
            cpu_theirs = time.process_time() - c0
            r = ours([job(seg, x, params)])[0][0]
            if r["breakpoints"] != theirs:
                sys.exit(f"{label}: breakpoints differ: ruptures {theirs} ours {r['breakpoints']}")
            cpu_ours = r["cpu_seconds"][0]
            t = totals.setdefault(search, [0.0, 0.0])
            t[0] += cpu_theirs
            t[1] += cpu_ours
            print(f"{search:<8} {label.split(' (')[0][5:]:<24} {len(x):>6} {cpu_theirs:>11.3f} {cpu_ours:>9.4f} {cpu_theirs / cpu_ours:>7.0f}×")
    for search, (a, b) in totals.items():
        print(f"{search:<8} {'all (sums)':<24} {'':>6} {a:>11.3f} {b:>9.4f} {a / b:>7.0f}×")


def self_test():
    """Each deliberately broken input must fail its check: our last result dropped, ruptures
    fed a penalty 0.05 times the formula's, one of our breakpoints moved, a posterior entry moved
    by 1e-6 (bocpd against NumPy, and the bocd package's last run length, which a prefix
    comparison would miss), a bocd package result dropped."""
    few = [c for c in equality_cases(1) if " bic" in c[0] and ("Pelt" in c[0] or "Binseg" in c[0])]
    checks = [("ruptures: drop", lambda: check_equality(list(few), "drop")),
              ("ruptures: pen", lambda: check_equality(list(few), "pen")),
              ("ruptures: bkps", lambda: check_equality(list(few), "bkps")),
              ("bocpd: posterior", lambda: check_bocpd("posterior")),
              ("bocd package: posterior", lambda: check_bocd_package("posterior")),
              ("bocd package: drop", lambda: check_bocd_package("drop"))]
    for what, run in checks:
        failures, _ = run()
        if not failures:
            sys.exit(f"self-test: {what}: the check passed with a broken input")
        print(f"self-test ({what}): fails as it should: {failures[0]}", flush=True)
    print("self-test passed: every broken input failed its check")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--tssb-all", action="store_true", help="KernelCPD on all 75 TSSB series (else every sixth)")
    ap.add_argument("--speed", action="store_true")
    ap.add_argument("--ar-speed", action="store_true", help="the ar cost against ruptures, TSSB configuration")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--speed-quick", action="store_true", help="with --speed: two short inputs only (CI: the timers must not read zero)")
    ap.add_argument("--self-test", action="store_true", help="broken inputs must fail (a few cases; CI runs it)")
    args = ap.parse_args()
    if args.self_test:
        self_test()
        return
    if args.speed:
        speed(args.rounds, args.speed_quick)
        return
    if args.ar_speed:
        ar_speed()
        return
    t0 = time.time()
    cases = equality_cases(args.seeds) + tssb_cases(args.tssb_all)
    failures, n_cases = check_equality(cases)
    f2, n_bocpd = check_bocpd()
    failures += f2
    f3, n_package = check_bocd_package()
    failures += f3
    n_bocpd += n_package
    failures += check_inlined_exp()
    print(f"{n_cases} of {len(cases)} ruptures cases and {n_bocpd} BOCPD series compared in {time.time() - t0:.0f} s")
    if failures:
        print(f"\n{len(failures)} FAILED:")
        for f in failures:
            print("  " + f)
        sys.exit(1)
    print("all identical")


if __name__ == "__main__":
    main()
