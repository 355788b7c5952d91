# motionlab tasks. `just` is optional: every recipe is a plain cargo/script command (see README).

export CARGO_TARGET_DIR := env_var_or_default("CARGO_TARGET_DIR", env_var("HOME") + "/.cache/motionlab-target")

# Run the test suite (README's test command).
test:
    cargo test --workspace

# Reproduce every experiment in experiments/ into reports/.
reproduce:
    cargo run --release -p motionlab-cli -- reproduce

# Reproduce and refresh the committed runs of record (reports/<experiment>/record/).
record:
    cargo run --release -p motionlab-cli -- reproduce --record

# Benchmarks: Rust (divan) and the side-by-side scripts against the Python peers (scipy,
# dtaidistance, tslearn, ruptures, claspy, stumpy, ezc3d, numpy), which also cross-check results. Numbers:
# crates/*/benches/README.md, bench/README.md. (The cold-build measure, bench/cold_build.sh,
# empties a target dir and is run on its own.)
bench:
    # The peer ratios README quotes, in one sitting with the load stated: bench/speed_ratios.sh
    # (runs the side-by-side scripts below three times each; idle machine).
    cargo bench -p motionlab-io
    cargo bench -p motionlab-features
    cargo bench -p motionlab-segment
    cargo bench -p motionlab-match
    cargo bench -p motionlab-eval
    cargo bench -p motionlab-gait
    cargo bench -p motionlab-changepoint
    cargo bench -p motionlab-profile
    bench/hull_vs_scipy.py
    bench/multistream_vs_peers.py
    bench/dtw_crosscheck.py
    bench/matching_vs_scipy.py
    bench/retrieval_vs_peers.py
    bench/butterworth_vs_scipy.py
    bench/metrics_crosscheck.py
    bench/python_binding_vs_peers.py
    bench/osafune_check.py reports/osafune_fast/record
    bench/changepoint_vs_peers.py --speed
    bench/profile_vs_peers.py --all --min-agree 10
    python3 bench/conformance_crosscheck.py check
    python3 bench/tssb_published_settings.py
    python3 bench/tssb_differences.py
    python3 bench/crops_vs_ruptures_rs.py
    python3 bench/label_metrics_vs_sklearn.py
    # Not benchmarks, run by CI (.ci/run): bench/bocd_package_snapshot.py (bocpd.rs's snapshot
    # recomputed by the bocd package), bench/check_records.py (a fresh reproduce against the
    # runs of record, needs its reports folder) and bench/analog_fixtures.py (writes the analog
    # C3D fixtures of tests/fixtures/analog/).
    python3 bench/opensim_crosscheck.py
    python3 bench/pose_crosscheck.py

# Rewrite the generated crate graph and crate table of docs/ARCHITECTURE.md from
# crates/*/Cargo.toml, then run every docs check (after adding a crate: also give it a row in
# README's crate table).
bless-docs:
    MOTIONLAB_BLESS_DOCS=1 cargo test -p motionlab-cli --test integration docs_truth::

# Fuzz every parser for the given number of seconds each (needs nightly-free cargo-fuzz setup, see fuzz/README.md).
fuzz seconds="600":
    fuzz/run_all.sh {{seconds}}
