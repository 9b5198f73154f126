#!/usr/bin/env bash
# Fuzzes isomarch's readers (docs/fuzzing.md): each target named (default:
# all of isomarch::inputs::TARGETS) for SECONDS, with libFuzzer through
# cargo-fuzz. New inputs go to a work folder outside the clone; afterwards
# only those that add coverage are merged into fuzz/corpus/TARGET (which is
# committed and replayed by tests/fuzz_corpus.rs). A crash stops that
# target: its input is copied to fuzz/regressions/TARGET/ (commit it with
# the fix). Each run appends a row to fuzz/runs.tsv: date, target,
# seconds, executions, crashes. cargo-fuzz wants nightly features; the
# stable toolchain gets them with RUSTC_BOOTSTRAP=1.
#
# Usage: bash scripts/fuzz.sh SECONDS [TARGET...]
ISOMARCH_WITH="${ISOMARCH_WITH:-} fuzz"
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$ISOMARCH_ROOT"
seconds="${1:?usage: bash scripts/fuzz.sh SECONDS [TARGET...]}"
shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scene pdb cif gro gzip psf xtc dcd)
export RUSTC_BOOTSTRAP=1
fuzz_dir="$HOME/.cache/isomarch-fuzz-target"
mkdir -p fuzz/artifacts
if ! cargo fuzz build -O --target-dir "$fuzz_dir" >fuzz/artifacts/build.log 2>&1; then
    tail -n 20 fuzz/artifacts/build.log >&2
    echo "isomarch: building the fuzz targets failed (fuzz/artifacts/build.log)" >&2
    exit 1
fi
for t in "${targets[@]}"; do
    mkdir -p "fuzz/artifacts/$t" "fuzz/regressions/$t"
    log="fuzz/artifacts/$t/last-run.log"
    start=$(date +%s)
    set +e
    work="$fuzz_dir/corpus/$t"
    mkdir -p "$work"
    cargo fuzz run -O --target-dir "$fuzz_dir" "$t" "$work" "fuzz/corpus/$t" -- \
        -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=8192 \
        -artifact_prefix="fuzz/artifacts/$t/" -print_final_stats=1 >"$log" 2>&1
    status=$?
    set -e
    ran=$(($(date +%s) - start))
    execs=$(grep -a -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1 || true)
    crashes=0
    for a in "fuzz/artifacts/$t"/crash-* "fuzz/artifacts/$t"/oom-* "fuzz/artifacts/$t"/timeout-* "fuzz/artifacts/$t"/leak-*; do
        [ -e "$a" ] || continue
        mv "$a" "fuzz/regressions/$t/" && crashes=$((crashes + 1))
    done
    printf '%s\t%s\t%s\t%s\t%s\n' "$(date -u +%FT%TZ)" "$t" "$ran" "${execs:-?}" "$crashes" >>fuzz/runs.tsv
    echo "isomarch: $t ran $ran s, ${execs:-?} executions, exit $status, $crashes crash inputs (log: $log)" >&2
    # The committed corpus takes only the inputs that add coverage to it.
    cargo fuzz run -O --target-dir "$fuzz_dir" "$t" "fuzz/corpus/$t" "$work" -- -merge=1 \
        >"fuzz/artifacts/$t/merge.log" 2>&1 || echo "isomarch: merging into fuzz/corpus/$t failed (fuzz/artifacts/$t/merge.log)" >&2
done
