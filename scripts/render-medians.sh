#!/usr/bin/env bash
# Median GPU time of a frame per method, from interleaved repeats: each
# repeat renders the scene once with every method in turn (so that a slow
# spell of the machine hits every method alike), after one warm-up round
# that is not counted (the first run of a build includes shader JIT).
#
# Usage: bash scripts/render-medians.sh N WxH SCENE METHOD... [-- EXTRA RENDER ARGS]
# Example: bash scripts/render-medians.sh 5 750x750 tests/data/molecules/6WG6.cif.gz quadratic-taylor field-inversion segment
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
if [ $# -lt 4 ]; then
    sed -n '2,9p' "$0" >&2
    exit 2
fi
N=$1 SIZE=$2 SCENE=$3
shift 3
METHODS=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do METHODS+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
cargo build --release --locked
B="${CARGO_TARGET_DIR:-$HOME/.cache/isomarch-target}/release/isomarch"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
for i in $(seq 0 "$N"); do
    for m in "${METHODS[@]}"; do
        "$B" render "$SCENE" -o "$TMP/f.png" --size "$SIZE" --method "$m" --stats "$TMP/s.json" "$@" >/dev/null 2>"$TMP/err" \
            || { cat "$TMP/err" >&2; exit 1; }
        [ "$i" -gt 0 ] && python3 -c "import json,sys; print(sys.argv[1], json.load(open(sys.argv[2]))['gpu_ms'])" "$m" "$TMP/s.json"
    done
done | python3 -c "
import sys, statistics, collections
runs = collections.defaultdict(list)
for line in sys.stdin:
    m, v = line.split()
    runs[m].append(float(v))
print('| method | GPU ms, median | runs |')
print('|---|---:|---|')
for m, v in runs.items():
    print(f'| {m} | {statistics.median(v):.0f} | {\", \".join(f\"{x:.0f}\" for x in v)} |')
"
