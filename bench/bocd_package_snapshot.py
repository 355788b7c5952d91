#!/usr/bin/env python3
"""The known answer of crates/motionlab-changepoint/src/bocpd.rs's test `degenerate_inputs`
(`bocd_package` on 300 equal samples, min-max normalised to zeros, drop_threshold 20), computed
by the bocd 0.1.2 package itself, as the TSSB scripts call it (ConstantHazard(100), StudentT()
at its defaults, the change points where the most probable run length falls by at least the
threshold).

Prints (change points, most probable run length at samples 195 and 196) and fails unless the
tuple the Rust test asserts is exactly this one. CI runs it.

Usage: bench/bocd_package_snapshot.py [--self-test]
"""
import os
import re
import subprocess
import sys
import warnings

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from bench_env import ensure_venv  # noqa: E402

ensure_venv()

import numpy as np  # noqa: E402

RUST_TEST = os.path.join(ROOT, "crates", "motionlab-changepoint", "src", "bocpd.rs")


def import_bocd():
    try:
        import bocd
    except ImportError:
        subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-deps", "bocd==0.1.2"], check=True)
        import bocd
    return bocd


def package_answer(values, threshold):
    from importlib.metadata import version

    bocd = import_bocd()  # installs it on first use: the version is read after
    assert version("bocd") == "0.1.2", version("bocd")
    x = np.asarray(values, dtype=float)
    span = x.max() - x.min()
    xs = (x - x.min()) / span if span > 0 else np.zeros_like(x)  # motionlab's min_max of a constant: zeros
    bc = bocd.BayesianOnlineChangePointDetection(bocd.ConstantHazard(100), bocd.StudentT())
    rt = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for v in xs:
            bc.update(v)
            rt.append(int(bc.rt[0]))
    cps = np.where(np.diff(np.array(rt, dtype=float)) <= -threshold)[0].tolist()
    return cps, rt


def asserted_by_the_test():
    """The (candidates, map_run_length[195], map_run_length[196]) tuple of the Rust test."""
    text = open(RUST_TEST).read()
    m = re.search(r"\(vec!\[([0-9, ]*)\], (\d+), (\d+)\)", text)
    if not m:
        sys.exit(f"{RUST_TEST}: the snapshot tuple (vec![..], .., ..) was not found")
    return [int(c) for c in m.group(1).split(",") if c.strip()], int(m.group(2)), int(m.group(3))


def compare(want):
    """The failure text (None: the package gives `want`)."""
    cps, rt = package_answer([3.0] * 300, 20.0)
    got = (cps, rt[195], rt[196])
    print(f"bocd 0.1.2 on 300 equal samples (min-max normalised, drop_threshold 20): change points {cps}, "
          f"most probable run length {rt[195]} at sample 195 and {rt[196]} at 196")
    return None if tuple(got) == tuple(want) else f"the Rust test asserts {want}, the package gives {got}"


def main():
    want = asserted_by_the_test()
    if "--self-test" in sys.argv:
        # A test asserting another run length, or another change point, must fail.
        for broken in ((want[0], want[1] + 1, want[2]), ([c + 1 for c in want[0]], want[1], want[2])):
            if compare(broken) is None:
                sys.exit(f"self-test: {broken} passed")
        print("self-test passed: every other tuple fails the comparison")
        return
    failure = compare(want)
    if failure:
        sys.exit(failure)
    print(f"equals the tuple asserted in {os.path.relpath(RUST_TEST, ROOT)}")


if __name__ == "__main__":
    main()
