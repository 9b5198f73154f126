#!/usr/bin/env bash
# Renders scenes/default.ron to out/default.png (and its step heatmap),
# installing what is missing and building first.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
cargo build --release --locked
"$CARGO_TARGET_DIR/release/isomarch" render scenes/default.ron -o out/default.png \
    --heatmap out/default-steps.png --stats out/default-stats.json "$@"
echo "wrote out/default.png, out/default-steps.png and out/default-stats.json"
