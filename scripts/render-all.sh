#!/usr/bin/env bash
# Renders every shipped scene (scenes/*.ron) and 1A8O at their own
# resolution with BIN, each with its step heatmap, into DIR: the images a
# refactoring must leave byte for byte the same.
# Usage: bash scripts/render-all.sh BIN DIR
#   then: cmp each DIR/*.png against another run's (diff -r DIR1 DIR2).
set -euo pipefail
[[ $# -eq 2 ]] || { echo "usage: bash scripts/render-all.sh BIN DIR" >&2; exit 2; }
bin=$(realpath "$1")
dir=$2
cd "$(dirname "${BASH_SOURCE[0]}")/.."
mkdir -p "$dir"
for scene in scenes/*.ron tests/data/molecules/1A8O.pdb; do
    name=$(basename "${scene%.*}")
    "$bin" render "$scene" -o "$dir/$name.png" --heatmap "$dir/$name-steps.png" 2>"$dir/$name.log" ||
        { echo "render of $scene failed:" >&2; cat "$dir/$name.log" >&2; exit 1; }
    echo "$scene -> $dir/$name.png"
done
