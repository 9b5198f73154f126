#!/usr/bin/env bash
# Opens the window: `isomarch view` with the given arguments, after
# installing what is missing and building isomarch with its window
# (scripts/render-default.sh builds it without, for the first picture).
# Usage: bash scripts/view.sh SCENE [TRAJECTORY] [view options]
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
cargo build --release --locked
exec "$CARGO_TARGET_DIR/release/isomarch" view "$@"
