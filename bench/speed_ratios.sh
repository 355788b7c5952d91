#!/usr/bin/env bash
# Every speed ratio README quotes against a peer, re-measured in one sitting: each side-by-side
# script run RUNS times in a row (each script already interleaves its own rounds), with the load
# average printed before and after every run, so a range over runs and the machine's state can
# be quoted together. Run it on an idle machine (nothing else building): the ratios of a loaded
# machine are inflated or deflated by whichever side the load hits.
#   bench/speed_ratios.sh [RUNS] [OUT_LOG]          (RUNS defaults to 3; clasp over all 75 TSSB
#                                                    series runs min(RUNS, 2) times: ~10 min each)
# The release examples each script builds are built first, untimed (a warm-up run of each).
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
log=${2:-/tmp/motionlab-speed-ratios.log}
: > "$log"
say() { echo "$*" | tee -a "$log"; }
load() { cut -d' ' -f1-3 /proc/loadavg; }
failed=0
measure() { # name, command… — a script whose check fails is said and counted; the sitting goes on
  local name=$1; shift
  say ""; say "### $name: $* — $(date -u +%FT%TZ), load average before: $(load)"
  local status=0
  "$@" 2>&1 | tee -a "$log" || status=$?
  [ "$status" -eq 0 ] || { failed=$((failed + 1)); say "### $name: the script FAILED (exit $status)"; }
  say "### $name done — load average after: $(load)"
}
say "speed ratios: $runs runs each, $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //')"
# Warm-ups: venvs, wheels and release examples (untimed).
bench/hull_vs_scipy.py >/dev/null 2>&1 || true
bench/multistream_vs_peers.py --rounds 1 --repeats 1 >/dev/null 2>&1 || true
bench/retrieval_vs_peers.py --rounds 1 --repeats 1 >/dev/null 2>&1 || true
bench/python_binding_vs_peers.py --rounds 1 --repeats 1 >/dev/null 2>&1 || true
bench/changepoint_vs_peers.py --speed --speed-quick --rounds 1 >/dev/null 2>&1 || true
bench/profile_vs_peers.py --series ArrowHead >/dev/null 2>&1 || true
cargo bench -p motionlab-io --bench binary_formats --no-run >/dev/null 2>&1
say "warm-ups done — $(date -u +%FT%TZ), load average: $(load)"
for i in $(seq "$runs"); do
  measure "hull vs scipy, run $i" bench/hull_vs_scipy.py
  measure "multistream DP vs dtaidistance, run $i" bench/multistream_vs_peers.py
  measure "retrieval vs dtaidistance, run $i" bench/retrieval_vs_peers.py
  measure "Python binding vs pure Python / ezc3d / py-c3d / dtaidistance, run $i" bench/python_binding_vs_peers.py
  measure "kernel_cpd vs ruptures KernelCPD (and n = 100,000), run $i" bench/changepoint_vs_peers.py --speed
  measure "C3D reading vs c3dio (divan), run $i" cargo bench -p motionlab-io --bench binary_formats -- c3d
done
for i in $(seq "$(( runs < 2 ? runs : 2 ))"); do
  measure "clasp vs claspy BinaryClaSPSegmentation, all 75 TSSB series, run $i" bench/profile_vs_peers.py --all
done
say ""; say "all done — $(date -u +%FT%TZ), load average: $(load); scripts failed: $failed"
[ "$failed" -eq 0 ]
