#!/usr/bin/env python3
"""Independent recomputation of the change-rate analysis of Osafune et al. (numpy only).

Reads the tables the ``change_rates`` evaluator exports (CSV, from the engine's run directory or
from ``cargo run --release -p motionlab-gait --example osafune_export -- DIR``):

  gait_parameters.csv      subject, condition, channel, dc_deg, amplitude_deg, frequency_hz
  change_rates.csv         normal_condition, condition, subject, channel, component,
                           normal_value, changed_value, k_pct, excluded, reason
  change_rate_summary.csv  normal_condition, condition, channel, component, mean_pct, sd_pct,
                           cv_pct, feature, n_subjects, n_excluded, note
  frequency_changes.csv    normal_condition, condition, subject, normal_hz, changed_hz, k_pct

and recomputes, from gait_parameters.csv alone, for every condition X other than the normal G:
K_ij = (X_ij - G_ij) / G_ij * 100 per subject, channel and component (excluding pairs whose
values are missing or whose |G| is below the near-zero thresholds), mu_i, the population sigma_i
and the signed CV_i = sigma_i / mu_i * 100, the feature flag (|CV| <= max, enough subjects) and
the frequency K_j with its mu, sigma and CV. Every number must agree with the exported tables to
1e-9 (relative, for magnitudes above 1; absolute below); exits 1 otherwise.

Usage: bench/osafune_check.py DIR [--max-abs-cv-pct 250] [--min-abs-normal-dc-deg 5]
                                  [--min-normal-amplitude-deg 2] [--min-subjects 5]
(the defaults are the evaluator's).
"""
import argparse
import csv
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
TOL = 1e-9


def ensure_venv():
    """Re-runs this script under bench/.venv (created by setup_venv.sh) if needed."""
    python = subprocess.run([os.path.join(HERE, "setup_venv.sh")], check=True, capture_output=True, text=True).stdout.strip()
    if os.path.realpath(sys.prefix) != os.path.realpath(os.path.dirname(os.path.dirname(python))):
        os.execv(python, [python] + sys.argv)


ensure_venv()
import numpy as np  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(s):
    return float(s) if s not in ("", "null") else math.nan


def close(a, b):
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= TOL * max(1.0, abs(a), abs(b))


def stats(k):
    """mu, population sigma and signed CV (%) as eqs. 2-4; NaN CV when mu == 0."""
    if len(k) == 0:
        return math.nan, math.nan, math.nan
    k = np.asarray(k, dtype=np.float64)
    mu = float(np.mean(k))
    sd = float(np.sqrt(np.mean((k - mu) ** 2)))
    cv = math.nan if mu == 0.0 else sd / mu * 100.0
    return mu, sd, cv


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir")
    ap.add_argument("--max-abs-cv-pct", type=float, default=250.0)
    ap.add_argument("--min-abs-normal-dc-deg", type=float, default=5.0)
    ap.add_argument("--min-normal-amplitude-deg", type=float, default=2.0)
    ap.add_argument("--min-subjects", type=int, default=5)
    a = ap.parse_args()

    params = read(os.path.join(a.dir, "gait_parameters.csv"))
    per_subject = read(os.path.join(a.dir, "change_rates.csv"))
    summary = read(os.path.join(a.dir, "change_rate_summary.csv"))
    freq = read(os.path.join(a.dir, "frequency_changes.csv"))
    normal = {r["normal_condition"] for r in summary}
    if len(normal) != 1:
        sys.exit(f"expected one normal condition in change_rate_summary.csv, found {normal}")
    g = normal.pop()

    # (subject, condition) -> {channel: (dc, amplitude)}, frequency
    values, frequency, subjects, channels, conditions = {}, {}, [], [], []
    for r in params:
        key = (r["subject"], r["condition"])
        values.setdefault(key, {})[r["channel"]] = {"dc": num(r["dc_deg"]), "amplitude": num(r["amplitude_deg"])}
        frequency[key] = num(r["frequency_hz"])
        for lst, v in ((subjects, r["subject"]), (channels, r["channel"]), (conditions, r["condition"])):
            if v not in lst:
                lst.append(v)
    others = [c for c in conditions if c != g]

    failures = []
    checked = {"K": 0, "mu/sigma/CV": 0, "feature": 0, "frequency": 0}
    exported_k = {(r["condition"], r["subject"], r["channel"], r["component"]): r for r in per_subject}
    exported_s = {(r["condition"], r["channel"], r["component"]): r for r in summary}
    for x in others:
        pairs = [s for s in subjects if (s, g) in values and (s, x) in values]
        for comp, near_zero in (("dc", lambda v: abs(v) < a.min_abs_normal_dc_deg),
                                ("amplitude", lambda v: v < a.min_normal_amplitude_deg)):
            for ch in channels:
                k, excluded = [], 0
                for s in pairs:
                    gv = values[(s, g)].get(ch, {}).get(comp, math.nan)
                    xv = values[(s, x)].get(ch, {}).get(comp, math.nan)
                    row = exported_k.get((x, s, ch, comp))
                    if row is None:
                        failures.append(f"change_rates.csv lacks {x}/{s}/{ch}/{comp}")
                        continue
                    if math.isnan(gv) or math.isnan(xv) or near_zero(gv):
                        excluded += 1
                        if row["excluded"] != "true" or not math.isnan(num(row["k_pct"])):
                            failures.append(f"{x}/{s}/{ch}/{comp}: should be excluded, exported {row['excluded']} {row['k_pct']}")
                        continue
                    kv = (xv - gv) / gv * 100.0
                    k.append(kv)
                    checked["K"] += 1
                    if row["excluded"] != "false" or not close(kv, num(row["k_pct"])):
                        failures.append(f"{x}/{s}/{ch}/{comp}: K {kv!r} vs exported {row['k_pct']} ({row['excluded']})")
                mu, sd, cv = stats(k)
                row = exported_s.get((x, ch, comp))
                if row is None:
                    failures.append(f"change_rate_summary.csv lacks {x}/{ch}/{comp}")
                    continue
                checked["mu/sigma/CV"] += 1
                for name, ours in (("mean_pct", mu), ("sd_pct", sd), ("cv_pct", cv)):
                    if not close(ours, num(row[name])):
                        failures.append(f"{x}/{ch}/{comp}: {name} {ours!r} vs exported {row[name]}")
                feature = len(k) >= a.min_subjects and not math.isnan(cv) and abs(cv) <= a.max_abs_cv_pct
                checked["feature"] += 1
                if (row["feature"] == "true") != feature or int(row["n_subjects"]) != len(k) or int(row["n_excluded"]) != excluded:
                    failures.append(f"{x}/{ch}/{comp}: feature/n {feature} {len(k)} {excluded} vs exported {row['feature']} {row['n_subjects']} {row['n_excluded']}")
        # Frequency change per subject and its summary row.
        kf = []
        exported_f = {r["subject"]: r for r in freq if r["condition"] == x}
        for s in pairs:
            gf, xf = frequency[(s, g)], frequency[(s, x)]
            kv = (xf - gf) / gf * 100.0 if gf > 0 and xf > 0 else math.nan
            if not math.isnan(kv):
                kf.append(kv)
            checked["frequency"] += 1
            if s not in exported_f or not close(kv, num(exported_f[s]["k_pct"])):
                failures.append(f"{x}/{s}: frequency K {kv!r} vs exported {exported_f.get(s, {}).get('k_pct')}")
        row = exported_s.get((x, "gait", "frequency"))
        mu, sd, cv = stats(kf)
        for name, ours in (("mean_pct", mu), ("sd_pct", sd), ("cv_pct", cv)):
            if row is None or not close(ours, num(row[name])):
                failures.append(f"{x}/frequency: {name} {ours!r} vs exported {None if row is None else row[name]}")

    print(f"normal condition {g!r}, conditions {others}, {len(subjects)} subjects, {len(channels)} channels")
    print("checked: " + ", ".join(f"{v} {k}" for k, v in checked.items()))
    if failures:
        print(f"{len(failures)} disagreements (tolerance {TOL}):")
        for f in failures[:30]:
            print("  " + f)
        sys.exit(1)
    print(f"all agree to {TOL}")


if __name__ == "__main__":
    main()
