#!/usr/bin/env bash
# The paper's Table 2 on a molecule (docs/molecules.md): every method renders
# the molecule file at 750x750 with at most 32 and at most 1000 steps
# (GPU time per frame from `render --stats`), and `bench` measures each
# method's miss rate against the f64 reference on protocol rays (the f64
# reference is slow on 20,000 atoms: RAYS rays, default 4096).
#
# Usage: bash scripts/table2.sh [MOLECULE] [OUT_DIR] [RAYS]
# Default: tests/data/molecules/6WG6.cif.gz (in the repository), out/table2, 4096 rays.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
MOL=${1:-tests/data/molecules/6WG6.cif.gz}
OUT=${2:-out/table2}
RAYS=${3:-4096}
METHODS=(segment quadratic quadratic-relaxed-t0 quadratic-relaxed-max quadratic-taylor field-inversion)
cargo build --release --locked
B="${CARGO_TARGET_DIR:-$HOME/.cache/isomarch-target}/release/isomarch"
mkdir -p "$OUT"
for steps in 32 1000; do
    for m in "${METHODS[@]}"; do
        echo "render $m, max steps $steps" >&2
        "$B" render "$MOL" -o "$OUT/$m-$steps.png" --size 750x750 --method "$m" --max-steps "$steps" \
            --heatmap "$OUT/$m-$steps-steps.png" --steps-max 75 --stats "$OUT/$m-$steps.json"
    done
    echo "bench, max steps $steps" >&2
    "$B" bench "$MOL" --methods "$(IFS=,; echo "${METHODS[*]}")" --max-steps "$steps" --rays "$RAYS" \
        --json "$OUT/bench-$steps.json" > "$OUT/bench-$steps.md"
done
# One table: per method and budget, GPU ms per frame and steps per pixel
# (render), miss rate (bench).
python3 - "$OUT" "${METHODS[@]}" <<'EOF'
import json, sys
out, methods = sys.argv[1], sys.argv[2:]
print("| method | GPU ms/frame, 32 steps | GPU ms/frame, 1000 steps | steps/pixel (32, 1000) | out of steps (32, 1000) | miss rate (32, 1000) |")
print("|---|---:|---:|---:|---:|---:|")
bench = {s: {m["method"]: m for m in json.load(open(f"{out}/bench-{s}.json"))["methods"]} for s in (32, 1000)}
for m in methods:
    r = {s: json.load(open(f"{out}/{m}-{s}.json")) for s in (32, 1000)}
    miss = [bench[s].get(m, {}).get("miss_rate", float("nan")) for s in (32, 1000)]
    print(f"| {m} | {r[32]['gpu_ms']:.0f} | {r[1000]['gpu_ms']:.0f} | {r[32]['steps_per_ray']:.2f}, {r[1000]['steps_per_ray']:.2f} "
          f"| {r[32]['out_of_steps_rate']:.4f}, {r[1000]['out_of_steps_rate']:.4f} | {miss[0]:.5f}, {miss[1]:.5f} |")
EOF
