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
# dtaidistance, tslearn, ruptures, numpy), which also cross-check results. Numbers:
# crates/*/benches/README.md, bench/README.md. (The cold-build measure, bench/cold_build.sh,
# empties a target dir and is run on its own.)
bench:
    cargo bench -p motionlab-io
    cargo bench -p motionlab-features
    cargo bench -p motionlab-segment
    cargo bench -p motionlab-match
    cargo bench -p motionlab-eval
    cargo bench -p motionlab-gait
    bench/hull_vs_scipy.py
    bench/multistream_vs_peers.py
    bench/dtw_crosscheck.py
    bench/matching_vs_scipy.py
    bench/retrieval_vs_peers.py
    bench/butterworth_vs_scipy.py
    bench/metrics_crosscheck.py
    bench/python_binding_vs_peers.py
    bench/osafune_check.py reports/osafune_fast/record

# Fuzz every parser for the given number of seconds each (needs nightly-free cargo-fuzz setup, see fuzz/README.md).
fuzz seconds="600":
    fuzz/run_all.sh {{seconds}}
