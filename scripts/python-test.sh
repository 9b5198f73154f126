#!/usr/bin/env bash
# Builds the Python package (python/, docs/python.md) into a virtual
# environment beside the target dir, with the target dir shared, and runs
# its pytest suite against the command line built from the same tree.
# Called by scripts/test.sh. Extra arguments go to pytest.
# The movie tests need ffmpeg (scripts/env.sh's `movie` set).
ISOMARCH_WITH="${ISOMARCH_WITH:-} movie"
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
venv="$CARGO_TARGET_DIR/python-venv"
export PATH="$venv/bin:$PATH"  # maturin, for the build backend
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv" || { echo "isomarch: python3 -m venv failed (Debian: apt-get install python3-venv)" >&2; exit 1; }
fi
"$venv/bin/pip" install -q --disable-pip-version-check "maturin>=1.7,<2" "numpy>=1.21" "pytest>=7" "pillow>=9" "OpenEXR>=3.3"
# The package itself, the way the README installs it (no build isolation:
# the venv's maturin, and no download per build).
"$venv/bin/pip" install -q --disable-pip-version-check --no-build-isolation ./python
cargo build --release --locked -p isomarch-cli --bin isomarch
ISOMARCH_BIN="$CARGO_TARGET_DIR/release/isomarch" "$venv/bin/python" -m pytest -q python/tests "$@"
