#!/usr/bin/env bash
# The README's headline table: steps and GPU time per ray of quadratic
# Taylor and bottom-up quadratic relative to segment tracing on the paper's
# scenes, its protocol (131,072 rays), 5 interleaved repeats per scene, and
# the paper's CPU figures beside them. Prints the Markdown table with the
# date, commit and device; each scene's JSON stays in OUT_DIR.
# Usage: bash scripts/headline.sh [OUT_DIR]
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
out="${1:-/tmp/isomarch-headline}"
mkdir -p "$out"
cargo build --release --locked --quiet
bin="$CARGO_TARGET_DIR/release/isomarch"
# scene, the row's label, the paper's (steps, time) for quadratic Taylor
# and for bottom-up quadratic (Tables 1, 3, 4 and 5).
rows=(
    "fig10|fig10, opaque (Table 1)|0.54x, 0.58x|0.62x, 0.72x"
    "fig1|fig1, transparent (Table 3)|0.34x, 0.41x|0.40x, 0.50x"
    "fig17|fig17, transparent (Table 4)|0.31x, 0.33x|0.37x, 0.44x"
    "fig16|fig16, refraction (Table 5: per frame of its animation)|–, 0.76x|–, 0.82x"
)
for row in "${rows[@]}"; do
    IFS='|' read -r scene _ _ _ <<<"$row"
    "$bin" bench "scenes/$scene.ron" --rays 131072 --methods segment,quadratic-taylor,quadratic \
        --repeat 5 --json "$out/$scene.json" >&2
done
echo "Measured $(date -u +%Y-%m-%d) at commit $(git rev-parse --short HEAD) on $(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['device'])" "$out/fig10.json")."
echo
echo "| scene | quadratic Taylor: steps, time | paper | bottom-up quadratic: steps, time | paper |"
echo "|---|---|---|---|---|"
for row in "${rows[@]}"; do
    IFS='|' read -r scene label paper_qt paper_q <<<"$row"
    python3 - "$out/$scene.json" "$label" "$paper_qt" "$paper_q" <<'PY'
import json, sys
report, label, paper_qt, paper_q = json.load(open(sys.argv[1])), *sys.argv[2:]
by = {m["method"]: m for m in report["methods"]}
def cell(name):
    m = by[name]
    return f"{m['step_ratio']:.3f}x, {m['time_ratio']:.3f}x ({m['time_ratio_min']:.2f}–{m['time_ratio_max']:.2f})"
print(f"| {label} | {cell('quadratic-taylor')} | {paper_qt} | {cell('quadratic')} | {paper_q} |")
PY
done
