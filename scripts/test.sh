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
    local started=$SECONDS
    "$@"
    echo "isomarch: $* took $((SECONDS - started)) s" >&2
}
# Formatting and lints first (rustfmt.toml; allowed lints are justified in
# Cargo.toml's [lints] or where they are allowed). Clippy checks the
# release profile, whose build-script outputs (shaderc's) the tests share.
timed cargo fmt --all --check
# The Python crate's pyo3 reads the interpreter's configuration from the
# file that maturin writes (scripts/python-test.sh). Clippy given the same
# file agrees with maturin's last run of pyo3's build script, so a second
# run of this script compiles nothing (without it the two would each
# rebuild pyo3 after the other).
maturin_config=$(ls "$CARGO_TARGET_DIR"/maturin/pyo3-config-*.txt 2>/dev/null | head -n 1 || true)
if [ -n "$maturin_config" ]; then export PYO3_CONFIG_FILE="$maturin_config"; fi
timed cargo clippy --workspace --release --locked --all-targets -- -D warnings
# One profile (release) for tests and runs: shaderc is built once.
timed cargo test --release --locked -p isomarch-shaders
# The build apart from the runs, so that the log says which took the time.
timed cargo test --release --locked --no-run "$@"
timed cargo test --release --locked "$@"
# The Python package (python/): built into a venv, its pytest suite.
timed bash scripts/python-test.sh
echo "isomarch: the whole suite took $((SECONDS - suite_started)) s" >&2
