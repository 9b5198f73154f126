#!/usr/bin/env bash
# Measures Algorithm 1's interval growth k per method on one scene, all on
# the same seeded protocol rays: prints a markdown table of steps and GPU
# time per ray for each k.
# Usage: bash scripts/growth-sweep.sh [SCENE] [RAYS] [METHODS]
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
scene=${1:-scenes/fig10.ron}
rays=${2:-262144}
methods=${3:-linear-taylor,quadratic-taylor}
cargo build --release --locked -q
out=$(mktemp -d)
for k in 1.5 2 3 4 8; do
    "$CARGO_TARGET_DIR/release/isomarch" bench "$scene" --methods "$methods" --rays "$rays" --growth "$k" --json "$out/k$k.json" >/dev/null
done
python3 - "$out" "$scene" "$rays" <<'PY'
import json, sys, glob, os
out, scene, rays = sys.argv[1:]
rows = {}
for path in sorted(glob.glob(os.path.join(out, "k*.json")), key=lambda p: float(os.path.basename(p)[1:-5])):
    k = os.path.basename(path)[1:-5]
    for m in json.load(open(path))["methods"]:
        rows.setdefault(m["method"], []).append((k, m["steps_per_ray"], m["ns_per_ray"]))
print(f"Interval growth k on `{scene}`, {rays} rays (steps/ray, ns/ray):\n")
ks = [k for k, _, _ in next(iter(rows.values()))]
print("| method | " + " | ".join(f"k = {k}" for k in ks) + " |")
print("|---|" + "---:|" * len(ks))
for method, vals in rows.items():
    print(f"| {method} | " + " | ".join(f"{s:.3f} / {t:.0f}" for _, s, t in vals) + " |")
PY
rm -r "$out"
