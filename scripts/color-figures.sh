#!/usr/bin/env bash
# The colour figures of docs/molecules.md ("Colours"): each colouring on
# 1A8O (waters left out, the default), chains on 1TII, 200x200.
#   bash scripts/color-figures.sh BIN DIR
set -euo pipefail
bin=${1:?usage: color-figures.sh BIN DIR}
dir=${2:?usage: color-figures.sh BIN DIR}
mkdir -p "$dir"
m=tests/data/molecules
r() { "$bin" render "$@" --size 200x200 2>/dev/null >/dev/null; }
r $m/1A8O.pdb -o "$dir/color-element.png"
r $m/1TII.pdb.gz --color chain -o "$dir/color-chain.png"
r $m/1A8O.pdb --color bfactor --legend -o "$dir/color-bfactor.png"
r $m/1A8O.pdb --color bfactor --palette blue-white-red --legend -o "$dir/color-bwr.png"
r $m/1A8O.pdb --color restype -o "$dir/color-restype.png"
r $m/1A8O.pdb --color resname -o "$dir/color-resname.png"
r $m/1TII.pdb.gz --surfaces per-chain --color chain -o "$dir/surfaces-per-chain.png"
echo "wrote $dir/color-*.png and $dir/surfaces-per-chain.png"
