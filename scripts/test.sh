#!/usr/bin/env bash
# Runs the whole test suite on lavapipe, installing what is missing first.
# Usage: bash scripts/test.sh [extra cargo test arguments]
# Then the Python package's tests (scripts/python-test.sh).
# The suite includes a SLURM test (tests/slurm.rs), which starts a one-node
# cluster with scripts/slurm-local.sh: install its packages here too.
ISOMARCH_WITH="${ISOMARCH_WITH:-} slurm lint"
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
# Formatting and lints first (rustfmt.toml; allowed lints are justified in
# Cargo.toml's [lints] or where they are allowed). Clippy checks the
# release profile, whose build-script outputs (shaderc's) the tests share.
cargo fmt --all --check
cargo clippy --workspace --release --locked --all-targets -- -D warnings
# One profile (release) for tests and runs: shaderc is built once.
cargo test --release --locked -p isomarch-shaders
cargo test --release --locked "$@"
# The Python package (python/): built into a venv, its pytest suite.
bash scripts/python-test.sh
