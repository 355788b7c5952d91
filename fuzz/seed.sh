#!/usr/bin/env bash
# Builds the seed corpora fuzz/corpus/<target>/ from data/ and tests/fixtures/ (not committed).
# Adds to an existing corpus (what the fuzzer found stays); `rm -r fuzz/corpus` starts afresh.
set -euo pipefail
cd "$(dirname "$0")"
exec python3 seed.py
