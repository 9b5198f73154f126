#!/usr/bin/env bash
# The cost of a marching turn on the particle scene of issue 25: 1,000
# compact blobs (`generate particles --count 1000 --seed 1`) at 500x500,
# each method rendered REPEATS times, interleaved, with `render --stats`;
# prints the medians (and ranges) of GPU time, ns per kernel evaluation and
# per loop turn, with steps, turns, evaluations and list visits per ray.
# Usage:
#   bash scripts/turn-cost.sh [REPEATS] [METHODS...]
# ISOMARCH_BIN=path compares another build (the default: this checkout's);
# extra render flags go in TURN_COST_FLAGS (e.g. "--max-steps 1").
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
repeats="${1:-5}"
shift || true
methods=("$@")
((${#methods[@]})) || methods=(segment quadratic-taylor)
if [ -z "${ISOMARCH_BIN:-}" ]; then
    cargo build --release --quiet
    ISOMARCH_BIN="$CARGO_TARGET_DIR/release/isomarch"
fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
"$ISOMARCH_BIN" generate particles --count 1000 --seed 1 -o "$out/p1000.ron" 2>/dev/null
for ((r = 0; r < repeats; r++)); do
    for m in "${methods[@]}"; do
        # shellcheck disable=SC2086
        "$ISOMARCH_BIN" render "$out/p1000.ron" --size 500x500 --method "$m" ${TURN_COST_FLAGS:-} \
            -o "$out/$m.png" --stats "$out/$m-$r.json" 2>/dev/null
    done
done
python3 - "$out" "$repeats" "${methods[@]}" <<'EOF'
import json, statistics, sys
out, repeats, methods = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
print(f"1,000 compact blobs, 500x500, {repeats} interleaved repeats: median (fastest-slowest)\n")
print("| method | steps/ray | turns/ray | evals/ray | visits/eval | GPU ms | ns/eval | ns/turn |")
print("|---|---:|---:|---:|---:|---:|---:|---:|")
for m in methods:
    runs = [json.load(open(f"{out}/{m}-{r}.json")) for r in range(repeats)]
    first = runs[0]
    # Computed here rather than read, so that builds older than these
    # statistics are measured the same way (their turns and visits: n/a).
    def spread(per):
        v = [r["gpu_ms"] * 1e6 / (r["rays"] * per(r)) if per else r["gpu_ms"] for r in runs if r.get("gpu_ms") is not None]
        return f"{statistics.median(v):.1f} ({min(v):.1f}-{max(v):.1f})" if v else "n/a"
    turns = first.get("turns_per_ray")
    visits = first.get("visits_per_ray")
    f = lambda v, d: "n/a" if v is None else f"{v:.{d}f}"
    print(f"| {m} | {first['steps_per_ray']:.2f} | {f(turns, 2)} | {first['evals_per_ray']:.1f} "
          f"| {f(None if visits is None else visits / max(first['evals_per_ray'], 1e-9), 1)} "
          f"| {spread(None)} | {spread(lambda r: r['evals_per_ray'])} | {spread(lambda r: r['turns_per_ray']) if turns else 'n/a'} |")
EOF
