#!/usr/bin/env bash
# Two isomarch binaries' images side by side (issue 51 compared a9d30b5's
# with its own): every shipped scene and 1A8O, plain and with each look
# flag, rendered by OLD and by NEW at SIZE; prints per case the pixels more
# than one 8-bit level apart, and where. Images already in OUTDIR are kept
# (delete them to render again). Needs Python with numpy and Pillow
# (scripts/python-test.sh makes such a venv; PYTHON picks one).
# Usage: bash scripts/compare-images.sh OLD NEW OUTDIR [SIZE]
set -u
if [ $# -lt 3 ]; then echo "usage: $0 OLD_BINARY NEW_BINARY OUTDIR [SIZE, default 128x128]" >&2; exit 2; fi
OLD=$1; NEW=$2; OUT=$(realpath -m "$3"); SIZE=${4:-128x128}
PYTHON=${PYTHON:-${CARGO_TARGET_DIR:-$HOME/.cache/isomarch-target}/python-venv/bin/python}
if ! "$PYTHON" -c 'import numpy, PIL' 2>/dev/null; then
  echo "$0: $PYTHON has no numpy and Pillow: run scripts/python-test.sh once, or set PYTHON" >&2; exit 1
fi
cd "$(dirname "${BASH_SOURCE[0]}")/.."
mkdir -p "$OUT"
export ISOMARCH_SHADER_CACHE=${ISOMARCH_SHADER_CACHE:-$HOME/.cache/isomarch/spirv}
scenes="scenes/default.ron scenes/fig1.ron scenes/fig10-gauss.ron scenes/fig10.ron scenes/fig16.ron scenes/fig17.ron scenes/hrbf17.ron scenes/hrbf8.ron tests/data/molecules/1A8O.pdb"
"$NEW" scene tests/data/molecules/1A8O.pdb -o "$OUT/1A8O.ron" >/dev/null 2>&1
dist() { # eye-target distance of a scene file
  python3 - "$1" <<'PY'
import re,sys,math
t=open(sys.argv[1]).read()
f=lambda k: [float(x) for x in re.search(k+r':\s*\(([^)]*)\)', t).group(1).split(',')[:3]]
e,g=f('eye'),f('target'); print(round(math.dist(e,g),3))
PY
}
for s in $scenes; do
  name=$(basename "${s%.*}")
  case $s in *.pdb) d=$(dist "$OUT/1A8O.ron");; *) d=$(dist "$s");; esac
  for v in plain samples4 lit cue outline transparent clip ortho; do
    case $v in
      plain) args=();;
      samples4) args=(--samples 4);;
      lit) args=(--shadows --ao 8);;
      cue) args=(--depth-cue);;
      outline) args=(--outline);;
      transparent) args=(--transparent-background);;
      clip) args=(--clip "near:$d");;
      ortho) args=(--ortho);;
    esac
    for which in old new; do
      bin=$OLD; [ $which = new ] && bin=$NEW
      png="$OUT/$name-$v-$which.png"
      [ -s "$png" ] && continue
      if ! timeout 900 "$bin" render "$s" -o "$png" --size "$SIZE" "${args[@]}" >"$OUT/$name-$v-$which.log" 2>&1; then
        echo "$name $v $which: failed: $(tail -1 "$OUT/$name-$v-$which.log")"
      fi
    done
  done
done
"$PYTHON" - "$OUT" <<'PY'
import sys,glob,os
from PIL import Image
import numpy as np
out=sys.argv[1]
tot_moved=0; tot=0
for old in sorted(glob.glob(out+'/*-old.png')):
    new=old[:-8]+'-new.png'
    case=os.path.basename(old[:-8])
    if not os.path.exists(new): print(case, 'no new image'); continue
    a=np.asarray(Image.open(old).convert('RGBA')).astype(int); b=np.asarray(Image.open(new).convert('RGBA')).astype(int)
    if a.shape!=b.shape: print(case,'shapes differ',a.shape,b.shape); continue
    d=np.abs(a-b).max(axis=2); n=d.size
    off=int((d>1).sum()); tot_moved+=off; tot+=n
    worst=int(d.max())
    ys,xs=np.nonzero(d>1)
    where=', '.join(f'({x},{y}):{d[y,x]}' for y,x in list(zip(ys,xs))[:6])
    print(f'{case:28s} off>1: {off:5d}/{n} ({100*(1-off/n):.2f}% within 1)  max {worst:3d}  {where}')
print(f'total pixels off by more than one level: {tot_moved} of {tot}')
PY
