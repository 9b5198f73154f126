#!/usr/bin/env bash
# Instructions per camera ray, counted by callgrind on lavapipe: for each
# method, the instructions of a 64x64 and of a 192x192 render of SCENE,
# and their difference over the 32,768 rays between them (the fixed cost
# of a run, device start and pipeline building, cancels out). callgrind
# counts what the CPU executes, deterministically: two identical runs
# differ by a few dozen instructions in a billion, whatever else the
# machine is doing. On lavapipe time follows instructions (issue 43);
# what instructions do not show is memory traffic and the lanes a SIMD
# group idles while its other rays march on (divergence).
#
# Each render runs once under valgrind first, not counted: the first run
# under valgrind compiles the pipelines even when Mesa's cache is warm
# natively. Beside the count: steps, turns and evaluations per ray from
# the 192x192 render's --stats, and instructions per evaluation.
#
# Usage: bash scripts/instructions.sh SCENE METHOD... [-- EXTRA RENDER ARGS]
# Example: bash scripts/instructions.sh scenes/fig10.ron segment quadratic-taylor
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
if [ $# -lt 2 ]; then
    sed -n '2,19p' "$0" >&2
    exit 2
fi
command -v valgrind >/dev/null || { echo "instructions.sh: valgrind is missing (apt-get install valgrind)" >&2; exit 1; }
SCENE=$1
shift
source "$(dirname "${BASH_SOURCE[0]}")/measure-args.sh"
measure_args "$@"
# The instructions callgrind counted in a run of `render` at SIZE.
count() {
    local method=$1 size=$2
    shift 2
    valgrind --tool=callgrind --callgrind-out-file="$TMP/cg.out" "$B" render "$SCENE" -o "$TMP/f.png" --size "$size" \
        --method "$method" --stats "$TMP/s-$size.json" "$@" >/dev/null 2>"$TMP/err" || { cat "$TMP/err" >&2; exit 1; }
    sed -n 's/^summary: //p' "$TMP/cg.out" | awk '{print $1}'
}
echo "| method | instructions/ray | steps/ray | turns/ray | evals/ray | instructions/eval |"
echo "|---|---:|---:|---:|---:|---:|"
for m in "${METHODS[@]}"; do
    count "$m" 64x64 "${EXTRA[@]}" >/dev/null
    small=$(count "$m" 64x64 "${EXTRA[@]}")
    large=$(count "$m" 192x192 "${EXTRA[@]}")
    python3 - "$m" "$small" "$large" "$TMP/s-192x192.json" <<'PY'
import json, sys
m, small, large, stats = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), json.load(open(sys.argv[4]))
per_ray = (large - small) / (192 * 192 - 64 * 64)
evals = stats["evals_per_ray"]
print(f"| {m} | {per_ray:,.0f} | {stats['steps_per_ray']:.2f} | {stats['turns_per_ray']:.2f} | {evals:.2f} | {per_ray / evals if evals else float('nan'):,.0f} |")
PY
done
