# Sourced by the measuring scripts (instructions.sh, render-medians.sh)
# after env.sh: `measure_args "$@"` takes the methods up to `--` into
# METHODS and the rest, render's own arguments, into EXTRA; builds the
# release binary into B; and makes a scratch folder TMP, removed on exit.
measure_args() {
    METHODS=()
    while [ $# -gt 0 ] && [ "$1" != "--" ]; do METHODS+=("$1"); shift; done
    [ "${1:-}" = "--" ] && shift
    EXTRA=("$@")
    cargo build --release --locked
    B="${CARGO_TARGET_DIR:-$HOME/.cache/isomarch-target}/release/isomarch"
    TMP=$(mktemp -d)
    trap 'rm -rf "$TMP"' EXIT
}
