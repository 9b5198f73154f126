#!/usr/bin/env bash
# Median time of a frame per method, from interleaved repeats: each
# repeat renders the scene once with every method in turn (so that a slow
# spell of the machine hits every method alike), after one warm-up round
# that is not counted. A frame is what `render --stats` says it took:
# the march's GPU time, plus the build of what gave its camera rays their
# candidates (the spatial index's GPU time, the tile lists' host time).
# With ACCELERATIONS="tiles grid" every method runs both ways
# (ISOMARCH_TILES=on and off), each row naming the one the frame used.
#
# Usage: [ACCELERATIONS="tiles grid"] bash scripts/render-medians.sh N WxH SCENE METHOD... [-- EXTRA RENDER ARGS]
# Example: bash scripts/render-medians.sh 5 750x750 tests/data/molecules/6WG6.cif.gz quadratic-taylor field-inversion segment
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
if [ $# -lt 4 ]; then
    sed -n '2,13p' "$0" >&2
    exit 2
fi
N=$1 SIZE=$2 SCENE=$3
shift 3
source "$(dirname "${BASH_SOURCE[0]}")/measure-args.sh"
measure_args "$@"
ACCELERATIONS=${ACCELERATIONS:-default}
for i in $(seq 0 "$N"); do
    for m in "${METHODS[@]}"; do
        for a in $ACCELERATIONS; do
            case "$a" in tiles) switch=on ;; grid) switch=off ;; default) switch=on ;; *) echo "ACCELERATIONS: tiles, grid or default, not $a" >&2; exit 2 ;; esac
            ISOMARCH_TILES=$switch "$B" render "$SCENE" -o "$TMP/f.png" --size "$SIZE" --method "$m" --stats "$TMP/s.json" "${EXTRA[@]}" >/dev/null 2>"$TMP/err" \
                || { cat "$TMP/err" >&2; exit 1; }
            [ "$i" -gt 0 ] && python3 -c "
import json, sys
s = json.load(open(sys.argv[2]))
build = (s['index']['build_ns'] * 1e-6 if s['index'] else 0.0) + (s['tiles']['build_ms'] if s['tiles'] else 0.0)
print(sys.argv[1], s['acceleration'], s['gpu_ms'], s['gpu_ms'] + build)" "$m" "$TMP/s.json"
        done
    done
done | python3 -c "
import sys, statistics, collections
march, frame = collections.defaultdict(list), collections.defaultdict(list)
for line in sys.stdin:
    m, a, g, f = line.split()
    march[(m, a)].append(float(g))
    frame[(m, a)].append(float(f))
print('| method | candidates | frame ms, median | march GPU ms, median | frames |')
print('|---|---|---:|---:|---|')
for k, v in frame.items():
    print(f'| {k[0]} | {k[1]} | {statistics.median(v):.0f} | {statistics.median(march[k]):.0f} | {\", \".join(f\"{x:.0f}\" for x in v)} |')
"
