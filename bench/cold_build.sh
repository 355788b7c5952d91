#!/usr/bin/env bash
# Cold-build cost of the README's two commands, each from an empty target directory, with
# `cargo build --timings` (HTML report kept beside the numbers): wall time, CPU time, peak RSS
# and the `motionlab` binary's size. Usage: bench/cold_build.sh [OUT_DIR]
# Takes the whole machine for several minutes: run it when nothing else is building.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/motionlab-cold-build}
mkdir -p "$out"
measure() { # name, cargo args…
  local name=$1; shift
  local target="$out/target-$name"
  rm -rf "$target"
  /usr/bin/time -f "%e %U %S %M" -o "$out/$name.time" env CARGO_TARGET_DIR="$target" cargo "$@" --timings >"$out/$name.log" 2>&1
  read -r wall user sys rss <"$out/$name.time"
  cp "$target"/cargo-timings/cargo-timing.html "$out/$name-timings.html" 2>/dev/null || true
  printf '%-28s wall %6.0f s   CPU %6.0f s   peak RSS %5.0f MB\n' "$name" "$wall" "$(echo "$user + $sys" | bc)" "$(echo "$rss / 1024" | bc)"
}
# README command 1 builds the release binary (then runs reproduce, ~1 min of work).
measure reproduce_release build --release -p motionlab-cli
ls -l "$out/target-reproduce_release/release/motionlab" | awk '{ printf "motionlab binary (release)   %.0f MB\n", $5 / 1e6 }'
# README command 2: the test suite's build (`cargo test --workspace` compiles, then runs).
measure test_workspace test --workspace --no-run
