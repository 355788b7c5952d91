#!/usr/bin/env bash
# Fuzzes every parser for SECONDS each (default 600), two targets at a time (the machine has
# two cores), and prints each target's run time, executions and executions per second from
# libFuzzer's final stats. Usage: fuzz/run_all.sh [SECONDS] [TARGET…]
#
# Needs cargo-fuzz (`cargo install cargo-fuzz`). The toolchain is stable: cargo-fuzz passes
# `-Z` sanitizer flags, which RUSTC_BOOTSTRAP=1 allows on stable (see README.md).
# Logs, crashes and the summary go to fuzz/artifacts/ (not committed).
set -euo pipefail
cd "$(dirname "$0")"

seconds="${1:-600}"
shift || true
all=(bvh asf amc c3d qualisys_tsv trc mot openpose coco_keypoints mediapipe mvnx cmu86_labels mocap6_labels boundaries_csv elan_eaf plugin_reply gunzip experiment_toml)
if [ "$#" -gt 0 ]; then targets=("$@"); else targets=("${all[@]}"); fi

export RUSTC_BOOTSTRAP=1
target_dir="${FUZZ_TARGET_DIR:-${CARGO_TARGET_DIR:-$HOME/.cache/ml-target-fuzz}}"
triple=x86_64-unknown-linux-gnu
bin_dir="$target_dir/$triple/release"

./seed.sh >/dev/null

# Build first, once: the parser targets without the engine, then the experiment target (its
# feature links the engine and polars).
cargo fuzz build --target-dir "$target_dir"
for t in "${targets[@]}"; do
    if [ "$t" = experiment_toml ]; then
        cargo fuzz build experiment_toml --features experiment --target-dir "$target_dir"
    fi
done

mkdir -p artifacts/logs
run_one() {
    local t="$1"
    mkdir -p "artifacts/$t"
    local status=0
    # -timeout: an input taking 30 s is a hang (reported like a crash); -rss_limit_mb: 2 GB.
    "$bin_dir/$t" "corpus/$t" -max_total_time="$seconds" -print_final_stats=1 -timeout=30 \
        -rss_limit_mb=2048 -artifact_prefix="artifacts/$t/" >"artifacts/logs/$t.log" 2>&1 || status=$?
    echo "$status" >"artifacts/logs/$t.status"
}

echo "fuzzing ${targets[*]} for ${seconds}s each, two at a time"
running=0
for t in "${targets[@]}"; do
    run_one "$t" &
    running=$((running + 1))
    if [ "$running" -ge 2 ]; then
        wait -n || true
        running=$((running - 1))
    fi
done
wait || true

summary=artifacts/summary.tsv
printf 'target\tseconds\truns\texec_per_s\tcorpus\tstatus\n' >"$summary"
failed=0
for t in "${targets[@]}"; do
    log="artifacts/logs/$t.log"
    runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
    secs=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log" | tail -1)
    corpus=$(ls "corpus/$t" | wc -l)
    status=$(cat "artifacts/logs/$t.status")
    [ "$status" = 0 ] || failed=1
    printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$t" "${secs:-?}" "${runs:-?}" "${rate:-?}" "$corpus" \
        "$([ "$status" = 0 ] && echo ok || echo "CRASH (exit $status, see $log)")" >>"$summary"
done
column -t -s $'\t' "$summary"
exit "$failed"
