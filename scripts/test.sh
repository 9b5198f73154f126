#!/usr/bin/env bash
# Runs the whole test suite on lavapipe, installing what is missing first.
# Usage: bash scripts/test.sh [extra cargo test arguments]
# The suite includes a SLURM test (tests/slurm.rs), which starts a one-node
# cluster with scripts/slurm-local.sh: install its packages here too.
ISOMARCH_WITH="${ISOMARCH_WITH:-} slurm"
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
# One profile (release) for tests and runs: shaderc is built once.
cargo test --release --locked "$@"
