#!/usr/bin/env bash
# The figures of docs/figures.md: each view and look option on fig10 and on
# the protein 1TII, 200x200, with the command that makes it.
#   bash scripts/figures.sh BIN DIR
set -euo pipefail
bin=${1:?usage: figures.sh BIN DIR}
dir=${2:?usage: figures.sh BIN DIR}
mkdir -p "$dir"
options=(
    "plain|"
    "turn|--turn y:60 --turn x:-25"
    "zoom|--zoom 1.6"
    "ortho|--ortho"
    "outline|--outline 2 --outline-jump 0.06 --samples 4"
    "depth-cue|--depth-cue 0:0.6"
    "clip|--clip near:CLIP"
    "background|--background white"
    "transparent|--transparent-background --samples 4"
)
for scene in scenes/fig10.ron tests/data/molecules/1TII.pdb.gz; do
    name=$(basename "$scene"); name=${name%%.*}
    # The near plane through each one's target: fig10's eye is 17.2 from
    # it, 1TII's 193.2.
    case $name in fig10) clip=17.2 ;; *) clip=193.2 ;; esac
    for entry in "${options[@]}"; do
        label=${entry%%|*}
        flags=${entry#*|}
        flags=${flags//CLIP/$clip}
        # shellcheck disable=SC2086
        "$bin" render "$scene" --size 200x200 $flags -o "$dir/$name-$label.png" >/dev/null 2>&1
        echo "isomarch render $scene --size 200x200 $flags -o $name-$label.png"
    done
done
