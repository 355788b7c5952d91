#!/usr/bin/env python3
"""Independent recomputation of the change-rate analysis of Osafune et al. (numpy only).

Reads the tables the ``change_rates`` evaluator exports as CSV — from a run directory of the
``[gait]`` workflow (``motionlab run experiments/osafune_fast.toml`` → ``reports/osafune_fast/<run>/``,
whose ``tables/`` holds them) or from a folder of CSVs
(``cargo run --release -p motionlab-gait --example osafune_export -- DIR``):

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
the frequency K_j with its mu, sigma and CV. When the run also exported the paper's Tables 2-3
(``table2_posture.csv``, ``table3_size.csv``: the feature channels of DC and amplitude, plus the
channels the paper lists), their rows are checked against the same recomputation. Every number
must agree with the exported tables to 1e-9 (relative, for magnitudes above 1; absolute below);
exits 1 otherwise. The largest deviation found is printed (0 when the CSV round-trips the
engine's doubles exactly).

Usage: bench/osafune_check.py DIR [--max-abs-cv-pct 250] [--min-abs-normal-dc-deg 5]
                                  [--min-normal-amplitude-deg 2] [--min-subjects 5]
The thresholds default to the run's own (``[[evaluate]] type = "change_rates"`` in the run
directory's ``config.toml``), else to the evaluator's defaults; flags override both.
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
TOL = 1e-9


sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()
import numpy as np  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(s):
    return float(s) if s not in ("", "null") else math.nan


WORST = [0.0]


def close(a, b):
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    dev = abs(a - b) / max(1.0, abs(a), abs(b))
    WORST[0] = max(WORST[0], dev)
    return dev <= TOL


DEFAULTS = {"max_abs_cv_pct": 250.0, "min_abs_normal_dc_deg": 5.0, "min_normal_amplitude_deg": 2.0, "min_subjects": 5}


def tables_dir_and_params(path):
    """The folder holding the CSVs (DIR/tables for a run directory) and the change_rates
    parameters the run used (from DIR/config.toml; the evaluator's defaults otherwise)."""
    params = dict(DEFAULTS)
    config = os.path.join(path, "config.toml")
    if os.path.isfile(config):
        with open(config, "rb") as f:
            doc = tomllib.load(f)
        rates = [e for e in doc.get("evaluate", []) if e.get("type") == "change_rates"]
        if rates:
            params.update({k: v for k, v in rates[0].items() if k in DEFAULTS})
    tables = os.path.join(path, "tables")
    return (tables if os.path.isdir(tables) else path), params


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
    ap.add_argument("dir", help="a run directory (with tables/ and config.toml) or a folder of CSVs")
    ap.add_argument("--max-abs-cv-pct", type=float)
    ap.add_argument("--min-abs-normal-dc-deg", type=float)
    ap.add_argument("--min-normal-amplitude-deg", type=float)
    ap.add_argument("--min-subjects", type=int)
    a = ap.parse_args()
    tables, run_params = tables_dir_and_params(a.dir)
    for k, v in run_params.items():
        if getattr(a, k) is None:
            setattr(a, k, v)
    print(f"tables {tables}; thresholds: |CV| <= {a.max_abs_cv_pct} %, |G_DC| >= {a.min_abs_normal_dc_deg} deg, "
          f"G_A >= {a.min_normal_amplitude_deg} deg, >= {a.min_subjects} subjects")

    params = read(os.path.join(tables, "gait_parameters.csv"))
    per_subject = read(os.path.join(tables, "change_rates.csv"))
    summary = read(os.path.join(tables, "change_rate_summary.csv"))
    freq = read(os.path.join(tables, "frequency_changes.csv"))
    paper_tables = {comp: read(os.path.join(tables, name)) for comp, name in (("dc", "table2_posture.csv"), ("amplitude", "table3_size.csv"))
                    if os.path.isfile(os.path.join(tables, name))}
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
    checked = {"K": 0, "mu/sigma/CV": 0, "feature": 0, "frequency": 0, "Table 2-3 rows": 0}
    recomputed = {}  # (condition, channel, component) -> (mu, sd, cv, feature, n)
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
                recomputed[(x, ch, comp)] = (mu, sd, cv, feature, len(k))
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

    # Tables 2-3: every feature channel of the component appears, and every row matches.
    for comp, rows in paper_tables.items():
        name = "table2_posture.csv" if comp == "dc" else "table3_size.csv"
        shown = {(r["condition"], r["channel"]) for r in rows}
        for (x, ch, c), (mu, sd, cv, feature, n) in recomputed.items():
            if c == comp and feature and (x, ch) not in shown:
                failures.append(f"{name} lacks the feature channel {x}/{ch}")
        for r in rows:
            want = recomputed.get((r["condition"], r["channel"], comp))
            if want is None:
                failures.append(f"{name}: row {r['condition']}/{r['channel']} is no channel of the study")
                continue
            mu, sd, cv, feature, n = want
            checked["Table 2-3 rows"] += 1
            for col, ours in (("mean_pct", mu), ("sd_pct", sd), ("cv_pct", cv)):
                if not close(ours, num(r[col])):
                    failures.append(f"{name} {r['condition']}/{r['channel']}: {col} {ours!r} vs exported {r[col]}")
            if (r["feature"] == "true") != feature or int(r["n_subjects"]) != n:
                failures.append(f"{name} {r['condition']}/{r['channel']}: feature/n {feature} {n} vs exported {r['feature']} {r['n_subjects']}")

    print(f"normal condition {g!r}, conditions {others}, {len(subjects)} subjects, {len(channels)} channels")
    print("checked: " + ", ".join(f"{v} {k}" for k, v in checked.items()))
    if failures:
        print(f"{len(failures)} disagreements (tolerance {TOL}):")
        for f in failures[:30]:
            print("  " + f)
        sys.exit(1)
    print(f"all agree to {TOL} (largest relative deviation {WORST[0]:.3g})")


if __name__ == "__main__":
    main()
