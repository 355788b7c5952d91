#!/usr/bin/env python3
"""Where tssb_benchmark's covering differs from TSSB's published one, series by series.

Reads the run of record's benchmark_covering.csv (or the file given) and, per method, sorts
every series into: equal (|ours - published| <= 0.01), lower or higher, and within each by
what we found against the truth — more change points than the truth has (over-segmented),
fewer (under-segmented) or as many (placed elsewhere). `--list METHOD` prints each differing
series of METHOD with its numbers. Standard library only.

    python3 bench/tssb_differences.py [reports/tssb_benchmark/record/tables/benchmark_covering.csv] [--list PELT]
"""
import argparse
import csv

parser = argparse.ArgumentParser(description="Where tssb_benchmark's covering differs from TSSB's published one.")
parser.add_argument("path", nargs="?", default="reports/tssb_benchmark/record/tables/benchmark_covering.csv")
parser.add_argument("--list", metavar="METHOD", help="print each differing series of METHOD")
args = parser.parse_args()
listed = args.list
rows = [r for r in csv.DictReader(open(args.path)) if r["sequence"] != "mean"]
methods = list(dict.fromkeys(r["method"] for r in rows))


def kind(r):
    found, truth = int(r["n_found"]), int(r["n_truth"])
    return "over-segmented" if found > truth else "under-segmented" if found < truth else "as many, placed elsewhere"


print(f"{'method':8} {'equal':>5} {'lower':>5} {'(over/under/placed)':>20} {'higher':>6} {'(over/under/placed)':>20}  points lost/gained")
for m in methods:
    rs = [r for r in rows if r["method"] == m]
    diff = lambda r: float(r["covering_minus_published"])
    lower = [r for r in rs if diff(r) < -0.01]
    higher = [r for r in rs if diff(r) > 0.01]
    split = lambda v: "/".join(str(sum(kind(r) == k for r in v)) for k in ("over-segmented", "under-segmented", "as many, placed elsewhere"))
    lost = sum(diff(r) for r in lower) / len(rs) * 100
    gained = sum(diff(r) for r in higher) / len(rs) * 100
    print(f"{m:8} {len(rs) - len(lower) - len(higher):5} {len(lower):5} {split(lower):>20} {len(higher):6} {split(higher):>20}  {lost:+.2f} / {gained:+.2f}")
    if m == listed:
        for r in lower + higher:
            print(f"    {r['sequence']:30} ours {float(r['covering']):.3f} published {float(r['published_covering']):.3f}  found {r['n_found']:>4} truth {r['n_truth']:>2}  {kind(r)}")
