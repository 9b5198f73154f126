#!/usr/bin/env bash
# The first picture: renders scenes/default.ron with its marcher (quadratic
# Taylor) to out/default.png with its step heatmap and statistics, and the
# step heatmaps of segment tracing and quadratic Taylor side by side on one
# scale to out/default-steps-grid.png (the paper's result, on this machine).
# Installs what is missing and builds first. Extra arguments go to `render`.
# Builds isomarch without the window (the `window` feature: winit and its
# protocols are nearly half of a first build): scripts/view.sh, the test
# suite and a plain `cargo build` add it. The march kernel is compiled on
# first use and kept in ~/.cache/isomarch/spirv.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
cargo build --release --locked --no-default-features
B="$CARGO_TARGET_DIR/release/isomarch"
"$B" render scenes/default.ron -o out/default.png \
    --heatmap out/default-steps.png --stats out/default-stats.json "$@"
# The protocol table on 16,384 rays (printed), then the two heatmaps, on a
# scale of 0 to 16 steps that this scene fills (the paper's 75 leaves it dark).
"$B" bench scenes/default.ron --methods segment,quadratic-taylor --rays 16384 \
    --heatmap-grid out/default-steps-grid.png --size 256x256 --steps-max 16
echo "wrote out/default.png, out/default-steps.png, out/default-stats.json and out/default-steps-grid.png"
