#!/usr/bin/env bash
# The viewer screenshot of docs/viewer.md: `isomarch view` in a real X window under
# Xvfb, captured from the X server (xwd) once the full-resolution frame has
# landed, then closed with Esc. Usage:
#   bash scripts/viewer-screenshot.sh [SCENE] [OUT.png] [extra view args...]
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
scene="${1:-scenes/fig16.ron}"
png="${2:-docs/viewer-fig16.png}"
shift 2 || shift $# || true
for p in x11-apps imagemagick; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' \
        || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$p" >&2
done
cargo build --release --quiet
bin="$CARGO_TARGET_DIR/release/isomarch"
Xvfb :91 -screen 0 1024x768x24 -nolisten tcp >/dev/null 2>&1 &
xvfb=$!
export DISPLAY=:91
trap 'kill $xvfb 2>/dev/null' EXIT
sleep 1
"$bin" view "$scene" --paused --time 1.0 --method quadratic-taylor "$@" &
viewer=$!
window=""
for _ in $(seq 600); do
    window=$(xdotool search --name '^isomarch' 2>/dev/null | head -n 1 || true)
    if [ -n "$window" ]; then
        title=$(xdotool getwindowname "$window")
        # A frame has landed (the title reports its time) and is final.
        case "$title" in *refining*|*preview*) ;; *ms/frame*) break ;; esac
    fi
    sleep 0.5
done
echo "window title: $title"
xwd -silent -id "$window" | convert xwd:- "$png"
xdotool windowfocus --sync "$window" key Escape
wait "$viewer"
echo "wrote $png"
