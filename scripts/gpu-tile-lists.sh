#!/usr/bin/env bash
# GPU-built tile lists against the host's and the grid (issue 52), on a device: docs/gpu.md.
# Usage, from the repository root, with the stripped release binary in the folder of this script:
#   bash scripts/gpu-tile-lists.sh OUTDIR   (SMALL=1: tiny sizes, to check it on lavapipe first)
set -u
OUTD=${1:-/tmp/t52}; SMALL=${SMALL:-0}; mkdir -p "$OUTD"
D=$(cd "$(dirname "$0")" && pwd); B=$D/isomarch; ROOT=$(pwd); T=$(mktemp -d)
M=$ROOT/tests/data/molecules; J=$ROOT/tests/data/trajectories
if [ "$SMALL" = 1 ]; then S750=96x96; S1080=64x36; NBIG=20000; R=2; else S750=750x750; S1080=1920x1080; NBIG=1000000; R=5; fi
row() { local tag=$1; shift; local t0=$(date +%s.%N)
  env "$@" -o "$T/f.png" --stats "$T/s.json" >"$T/o" 2>"$T/e" || { echo "FAIL $tag: $(tail -2 "$T/e")" | tee -a "$OUTD/t52.tsv"; return; }
  local t1=$(date +%s.%N)
  python3 - "$tag" "$T/s.json" "$(python3 -c "print(round($t1 - $t0, 3))")" <<'PY' | tee -a "$OUTD/t52.tsv"
import json, sys
tag, js, wall = sys.argv[1:4]; s = json.load(open(js)); t = s.get('tiles'); i = s.get('index')
b = (t['build_ms'] if t else 0.0) + (i['build_ns'] * 1e-6 if i else 0.0)
print(f"{tag}\t{s['acceleration']}\tgpu_ms={s['gpu_ms']:.3f}\tbuild_ms={b:.3f}\tframe_ms={s['gpu_ms'] + b:.3f}\tgpu_build={t and t.get('gpu')}\tentries={t and t['entries']}\tlongest={t and t['longest_list']}\tsubmits={s.get('submits')}\twall_s={wall}")
PY
}
"$B" info 2>&1 | head -14 > "$OUTD/info.txt"
"$B" generate particles --count $NBIG --seed 1 -o "$T/pbig.ron" >/dev/null
ISOMARCH_TILE_PROFILE=1 "$B" render "$M/6WG6.cif.gz" --select all --size $S750 --method quadratic-taylor -o "$T/p.png" 2> "$OUTD/profile-6wg6.txt" >/dev/null
ISOMARCH_TILE_PROFILE=1 "$B" render "$T/pbig.ron" --size $S1080 --method quadratic-taylor -o "$T/p.png" 2> "$OUTD/profile-pbig.txt" >/dev/null
for i in $(seq 1 $R); do
  row "6wg6 qt gpu-lists" ISOMARCH_TILE_BUILD=on "$B" render "$M/6WG6.cif.gz" --select all --size $S750 --method quadratic-taylor
  row "6wg6 qt host-lists" ISOMARCH_TILE_BUILD=off "$B" render "$M/6WG6.cif.gz" --select all --size $S750 --method quadratic-taylor
  row "6wg6 qt grid" ISOMARCH_TILES=off "$B" render "$M/6WG6.cif.gz" --select all --size $S750 --method quadratic-taylor
done
for i in 1 2; do
  row "p$NBIG qt gpu-lists $S1080" ISOMARCH_TILE_BUILD=on "$B" render "$T/pbig.ron" --size $S1080 --method quadratic-taylor --timeout 300
  row "p$NBIG qt grid $S1080" ISOMARCH_TILES=off "$B" render "$T/pbig.ron" --size $S1080 --method quadratic-taylor --timeout 300
  row "6zu5 qt gpu-lists" ISOMARCH_TILE_BUILD=on "$B" render "$M/6ZU5.cif.gz" --size $S750 --timeout 300
done
row "p$NBIG qt host-lists $S1080" ISOMARCH_TILE_BUILD=off "$B" render "$T/pbig.ron" --size $S1080 --method quadratic-taylor --timeout 300
for sz in 256x256 $S750; do
  ISOMARCH_TILE_BUILD=on timeout 120 "$B" bench "$J/adk.psf" "$J/adk_dims.dcd" --frames 98 --size $sz --methods quadratic-taylor 2>&1 | tail -1 | sed "s/^/gpu-lists $sz: /" | tee -a "$OUTD/t52.tsv"
  ISOMARCH_TILE_BUILD=off timeout 120 "$B" bench "$J/adk.psf" "$J/adk_dims.dcd" --frames 98 --size $sz --methods quadratic-taylor 2>&1 | tail -1 | sed "s/^/host-lists $sz: /" | tee -a "$OUTD/t52.tsv"
done
echo done | tee -a "$OUTD/t52.tsv"
