#!/usr/bin/env bash
# The long fuzz run of issue 10: each cargo-fuzz target of fuzz/ (mjcf, urdf,
# mesh, step; see fuzz/src/lib.rs for what they check) for RUNS executions.
#
#   scripts/fuzz.sh [RUNS]          RUNS defaults to 1000000 per target
#   FUZZ_TARGETS="step" scripts/fuzz.sh 10000
#
# Installs what it needs on first use: the nightly toolchain (cargo-fuzz's
# instrumentation needs it) and cargo-fuzz, both from the network. Builds
# with overflow checks and debug assertions but no sanitizer: the code is
# safe Rust, and AddressSanitizer would cost 2-3x the executions. Seeds each
# corpus (fuzz/corpus/TARGET, kept between runs, not committed) with
# reference_models/, tests/data/, fuzz/seeds/ and gymnasium's MJCF assets from
# .venv when present. Logs go to fuzz/logs/TARGET.log; a crash or a hang
# (an input running over 10 s) stops the run with its input in
# fuzz/artifacts/TARGET/. Prints the executions of each target at the end.
# The stable smoke run of the same checks is tests/fuzz_smoke.rs.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-1000000}
TARGETS=${FUZZ_TARGETS:-mjcf urdf mesh step}

rustup toolchain list | grep -q '^nightly' || rustup toolchain install nightly --profile minimal
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked

seed() { # seed DIR FILES...: copies the existing FILES into DIR
    local dir=$1; shift
    mkdir -p "$dir"
    for f in "$@"; do
        [ -f "$f" ] && cp "$f" "$dir/"
    done
    return 0
}
gym=$(ls -d .venv/lib/python3*/site-packages/gymnasium/envs/mujoco/assets 2>/dev/null | head -n1 || true)
seed fuzz/corpus/mjcf reference_models/*.xml tests/data/*.xml fuzz/seeds/mjcf/* ${gym:+$gym/*.xml}
seed fuzz/corpus/urdf reference_models/*.urdf fuzz/seeds/urdf/*
seed fuzz/corpus/mesh fuzz/seeds/mesh/*
mkdir -p fuzz/corpus/step fuzz/logs

for t in $TARGETS; do
    dict=()
    [ -f "fuzz/$t.dict" ] && dict=("-dict=fuzz/$t.dict")
    echo "fuzzing $t for $RUNS executions (log: fuzz/logs/$t.log)"
    cargo +nightly fuzz run --sanitizer none "$t" "fuzz/corpus/$t" -- \
        -runs="$RUNS" -timeout=10 -max_len=65536 -print_final_stats=1 "${dict[@]}" \
        >"fuzz/logs/$t.log" 2>&1 || { tail -n 40 "fuzz/logs/$t.log"; exit 1; }
done
for t in $TARGETS; do
    printf '%-5s %s executions\n' "$t" \
        "$(grep -o 'stat::number_of_executed_units: *[0-9]*' "fuzz/logs/$t.log" | grep -o '[0-9]*$')"
done
