#!/usr/bin/env bash
# Runs the whole test suite on lavapipe, installing what is missing first.
# Usage: bash scripts/test.sh [extra cargo test arguments]
# Then the Python package's tests (scripts/python-test.sh).
# The suite includes a SLURM test (tests/slurm.rs), which starts a one-node
# cluster with scripts/slurm-local.sh: install its packages here too; and
# the movie tests (tests/movies.rs, python/tests) need ffmpeg and ffprobe.
ISOMARCH_WITH="${ISOMARCH_WITH:-} slurm movie lint"
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
# Each step says how long it took (stderr), and the whole run at the end:
# where a suite's minutes went, from its log alone (docs/testing.md).
suite_started=$SECONDS
timed() {
    local started=$SECONDS rc=0
    "$@" || rc=$?
    echo "isomarch: $* took $((SECONDS - started)) s$([ $rc = 0 ] || echo ", failed ($rc)")" >&2
    return $rc
}
# Formatting first (rustfmt.toml), then lints (allowed lints are justified
# in Cargo.toml's [workspace.lints] or where they are allowed). Clippy
# checks the release profile, whose build-script outputs (shaderc's) the
# tests share.
timed cargo fmt --all --check
# The Python crate's pyo3 reads the interpreter's configuration from the
# file that maturin writes (scripts/python-test.sh). Clippy given the same
# file agrees with maturin's run of pyo3's build script; without it the
# two would each rebuild pyo3 after the other. So clippy runs once the
# wheel was built: after the Python package here when run with arguments,
# and beside the integration binary after it otherwise, so that even a
# first run leaves nothing to compile for the next.
clippy() {
    local maturin_config
    maturin_config=$(ls "$CARGO_TARGET_DIR"/maturin/pyo3-config-*.txt 2>/dev/null | head -n 1 || true)
    if [ -n "$maturin_config" ]; then export PYO3_CONFIG_FILE="$maturin_config"; fi
    timed cargo clippy --workspace --release --locked --all-targets -- -D warnings
}
# One profile (release) for tests and runs: shaderc is built once.
timed cargo test --release --locked -p isomarch-shaders
# The whole suite needs every kernel: the ones the cache lacks (a fresh
# clone has only the first picture's) are compiled beside the test build,
# at a lower priority, filling the cores the build leaves idle, instead of
# in the tests that first need them (about 85 s of one core; lock files
# keep a test from compiling one again meanwhile).
kernels=""
if [ $# -eq 0 ]; then
    timed cargo build --release --locked -p isomarch-shaders --bin isomarch-kernels
    nice -n 10 "$CARGO_TARGET_DIR/release/isomarch-kernels" &
    kernels=$!
    # Not left running if the suite stops early (a failed build).
    trap 'kill "$kernels" 2>/dev/null || true' EXIT
fi
# The build apart from the runs, so that the log says which took the time.
timed cargo test --release --locked --no-run "$@"
if [ -n "$kernels" ]; then
    # From here on the tests wait for what it has left (only root may
    # raise a priority again; elsewhere it finishes at nice 10).
    renice -n 0 -p "$kernels" >/dev/null 2>&1 || true
fi
if [ $# -gt 0 ]; then
    timed cargo test --release --locked "$@"
    # The Python package (python/): built into a venv, its pytest suite.
    timed bash scripts/python-test.sh
    clippy
else
    # The integration binary keeps both cores busy for minutes; the
    # window's tests (mostly waiting on Xvfb), the cluster's (waiting on
    # slurmd), the Python package (a wheel, then pytest) and clippy run
    # beside it, in that order, their output kept in a log printed after
    # it. Every test runs as before; only the waiting overlaps.
    beside_log="$CARGO_TARGET_DIR/test-beside.log"
    (
        rc=0
        timed cargo test --release --locked --test viewer --test slurm || rc=1
        # The Python package (python/): built into a venv, its pytest suite.
        timed bash scripts/python-test.sh || rc=1
        clippy || rc=1
        exit $rc
    ) >"$beside_log" 2>&1 &
    beside=$!
    failed=0
    timed cargo test --release --locked --lib --bins --test tests || failed=1
    timed cargo test --release --locked --doc || failed=1
    wait "$kernels" || { echo "isomarch: compiling the kernels beside the test build failed (above)" >&2; failed=1; }
    beside_started=$SECONDS
    wait "$beside" || failed=1
    echo "isomarch: the window's, the cluster's and the Python tests and clippy, run beside (waited $((SECONDS - beside_started)) s more for them):" >&2
    cat "$beside_log" >&2
    if [ $failed != 0 ]; then
        echo "isomarch: the suite failed (see above)" >&2
        exit 1
    fi
fi
echo "isomarch: the whole suite took $((SECONDS - suite_started)) s" >&2
