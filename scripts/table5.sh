#!/usr/bin/env bash
# Table 5: fig16 animated (reflection and refraction) at 656x508, 100
# frames at 25 fps, mean frame time per method, from the per-frame
# statistics of `isomarch render --frames`. Usage:
#   bash scripts/table5.sh [OUT_DIR] [METHODS...]
# Prints a Markdown table; frames and CSVs stay in OUT_DIR.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
out="${1:-/tmp/isomarch-table5}"
shift || true
methods=("$@")
((${#methods[@]})) || methods=(segment quadratic quadratic-taylor)
cargo build --release --quiet
bin="$CARGO_TARGET_DIR/release/isomarch"
rm -rf "$out"
for m in "${methods[@]}"; do
    "$bin" render scenes/fig16.ron --frames 0..100 --fps 25 --method "$m" \
        -o "$out/$m/frame_####.png" --csv "$out/$m.csv"
done
echo
echo "| method | mean GPU ms/frame | ratio | mean wall ms/frame | steps/ray | evals/ray |"
echo "|---|---:|---:|---:|---:|---:|"
base=""
for m in "${methods[@]}"; do
    # Columns: frame,time_s,file,width,height,method,steps_per_ray,evals_per_ray,hit_rate,gpu_ms,wall_ms
    read -r gpu wall steps evals < <(awk -F, 'NR > 1 { g += $10; w += $11; s += $7; e += $8; n++ }
        END { printf "%.1f %.1f %.2f %.1f\n", g / n, w / n, s / n, e / n }' "$out/$m.csv")
    [ -n "$base" ] || base="$gpu"
    ratio=$(awk -v a="$gpu" -v b="$base" 'BEGIN { printf "%.3f", a / b }')
    echo "| $m | $gpu | ${ratio}x | $wall | $steps | $evals |"
done
