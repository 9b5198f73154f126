#!/usr/bin/env bash
# The paper's Figure 13 on this machine (docs/hrbf.md): for the two HRBF
# scenes, the transparent and opaque pictures, the step heatmaps of revised
# affine arithmetic (with bisection) and bottom-up quadratic tracing side by
# side on one scale, and the step and time table of every method on the
# protocol's rays (opaque: the bisection baselines march the first crossing
# only), each time a median of interleaved repeats.
#
# Usage: bash scripts/fig13.sh [OUT_DIR] [RAYS] [REPEATS]
# Default: out/fig13, 65536 rays, 5 repeats.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
OUT=${1:-out/fig13}
RAYS=${2:-65536}
REPEATS=${3:-5}
METHODS=segment,sphere,linear-taylor,quadratic-taylor,linear,linear-bisection,raa,quadratic,quadratic-relaxed-t0,quadratic-relaxed-max
cargo build --release --locked
B="$CARGO_TARGET_DIR/release/isomarch"
mkdir -p "$OUT"
for scene in hrbf8 hrbf17; do
    echo "$scene: pictures" >&2
    "$B" render "scenes/$scene.ron" -o "$OUT/$scene.png" --size 256x256
    "$B" render "scenes/$scene.ron" --opaque -o "$OUT/$scene-opaque.png" --size 256x256
    echo "$scene: heatmaps of raa and quadratic, 0 to 24 steps" >&2
    "$B" bench "scenes/$scene.ron" --opaque --methods raa,quadratic --rays 4096 \
        --heatmap-grid "$OUT/$scene-steps-grid.png" --size 256x256 --steps-max 24 > /dev/null
    echo "$scene: every method, $RAYS rays, $REPEATS repeats" >&2
    "$B" bench "scenes/$scene.ron" --opaque --methods "$METHODS" --rays "$RAYS" --repeat "$REPEATS" \
        --json "$OUT/$scene-bench.json" > "$OUT/$scene-bench.md"
    cat "$OUT/$scene-bench.md"
done
echo "wrote $OUT" >&2
