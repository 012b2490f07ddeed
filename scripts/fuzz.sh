#!/usr/bin/env bash
# Build the libFuzzer targets of tests/fuzz with clang (address and undefined sanitizers, a
# static library instrumented for coverage) in build-fuzz/, and run each for a while.
#   scripts/fuzz.sh [SECONDS] [TARGET...]
# default: 60 seconds each for fuzz_graph, fuzz_image and fuzz_batch_list (the batch LIST reader).
# Each run starts from the committed seeds in tests/fuzz/corpus/<target> plus what earlier runs
# found (build-fuzz/corpus/<target>, not committed). A crash, sanitizer report, time-out (one
# input taking over 30 s) or out-of-memory leaves its input in build-fuzz/crashes/ and fails the
# target; reproduce it with `build-fuzz/tests/fuzz/<target> FILE`. Ends with the line
# "fuzz: N passed, M failed" and a non-zero exit if any target failed (or the build did).
set -uo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[[ ${#targets[@]} -eq 0 ]] && targets=(fuzz_graph fuzz_image fuzz_batch_list)
dir=build-fuzz

if [[ ! -f $dir/build.ninja ]]; then
    if ! CC=clang CXX=clang++ meson setup "$dir" --buildtype=debugoptimized -Dfuzzing=true \
        -Ddefault_library=static -Db_sanitize=address,undefined -Db_lundef=false >/dev/null; then
        echo "fuzz: the build-fuzz setup failed (needs clang and libclang-rt-14-dev)" >&2
        echo "fuzz: 0 passed, ${#targets[@]} failed"
        exit 1
    fi
fi
# the OpenImageIO module (wetgraph-oiio.so) is loaded by fuzz_image from the build folder
if ! ninja -C "$dir" "${targets[@]/#/tests/fuzz/}" wetgraph-oiio.so >/dev/null; then
    ninja -C "$dir" "${targets[@]/#/tests/fuzz/}" wetgraph-oiio.so | tail -30
    echo "fuzz: 0 passed, ${#targets[@]} failed"
    exit 1
fi

export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
passed=0
failed=0
for t in "${targets[@]}"; do
    seeds=tests/fuzz/corpus/${t#fuzz_}
    found=$dir/corpus/${t#fuzz_}
    mkdir -p "$found" "$dir/crashes"
    dict=()
    [[ -f tests/fuzz/${t#fuzz_}.dict ]] && dict=(-dict="tests/fuzz/${t#fuzz_}.dict")
    # OpenImageIO keeps a little memory per file it opens (suppressed in tests/lsan.supp), so
    # every input of fuzz_image would trigger a full leak scan: leaks are for the suites there
    if [[ $t == fuzz_image ]]; then
        export ASAN_OPTIONS=abort_on_error=1:detect_leaks=0
    else
        export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1:fast_unwind_on_malloc=0
    fi
    log=$dir/$t.log
    echo "fuzz: $t for ${seconds}s (log: $log)" >&2
    if "$dir/tests/fuzz/$t" "$found" "$seeds" "${dict[@]}" -max_total_time="$seconds" \
        -timeout=30 -rss_limit_mb=4096 -max_len=65536 -print_final_stats=1 \
        -artifact_prefix="$dir/crashes/$t-" </dev/null >"$log" 2>&1; then
        passed=$((passed + 1))
        grep -E "^stat::number_of_executed_units|^#[0-9]+.*DONE" "$log" | tail -2 >&2
    else
        failed=$((failed + 1))
        echo "fuzz: $t FAILED; the end of its log:" >&2
        tail -60 "$log" >&2
    fi
done
echo "fuzz: $passed passed, $failed failed"
[[ $failed -eq 0 ]]
