#!/usr/bin/env bash
# Install dependencies, build, and run the whole test suite twice: the optimised build, then an
# address+undefined sanitizer build (skip it with WETGRAPH_NO_SANITIZE=1); then run each libFuzzer
# target of tests/fuzz for WETGRAPH_FUZZ_SECONDS (default 20) through scripts/fuzz.sh, each one
# test that fails on a crash (skip them with WETGRAPH_NO_FUZZ=1). Ends with one line
# "tests: N passed, M failed" and a non-zero exit if anything failed.
set -uo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh || exit 1
nproc=$(nproc 2>/dev/null || echo 2)
passed=0
failed=0

run_suite() { # build-dir, extra meson args...
    local dir=$1
    shift
    if [[ ! -f $dir/build.ninja ]]; then
        meson setup "$dir" "$@" >/dev/null || { failed=$((failed + 1)); return; }
    fi
    if ! ninja -C "$dir" >/dev/null; then
        ninja -C "$dir" | tail -30
        failed=$((failed + 1))
        return
    fi
    meson test -C "$dir" --num-processes "$nproc" --print-errorlogs
    local log=$dir/meson-logs/testlog.json
    local ok bad
    ok=$(grep -c '"result": "OK"' "$log" || true)
    bad=$(grep -c '"result": "\(FAIL\|TIMEOUT\|ERROR\|UNEXPECTEDPASS\)"' "$log" || true)
    # LeakSanitizer stops the process's threads with a tracer at exit; on a loaded machine the
    # tracer itself sometimes crashes ("Tracer caught signal 11 ... LeakSanitizer has encountered
    # a fatal error") after every test passed. That is a fault of the environment, not a leak
    # (a leak is reported as one): such a suite is run once more, and counts by that run.
    local flaky
    flaky=$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    t = json.loads(line)
    text = (t.get("stdout") or "") + (t.get("stderr") or "")
    if t["result"] != "OK" and "LeakSanitizer has encountered a fatal error" in text \
            and "detected memory leaks" not in text:
        print(t["name"].split(" / ")[-1])
' "$log")
    for name in $flaky; do
        echo "test.sh: $name: LeakSanitizer's tracer crashed at exit; running it once more" >&2
        if meson test -C "$dir" --print-errorlogs "$name" >/dev/null; then
            ok=$((ok + 1))
            bad=$((bad - 1))
        fi
    done
    # a skipped test (exit 77, e.g. the GLSL tests without a GL driver) is neither: name it
    local skipped
    skipped=$(python3 -c '
import json, sys
for line in open(sys.argv[1]):
    t = json.loads(line)
    if t["result"] == "SKIP":
        print(t["name"].split(" / ")[-1])
' "$log")
    [[ -n $skipped ]] && echo "test.sh: $dir: skipped: $(echo $skipped)" >&2
    passed=$((passed + ok))
    failed=$((failed + bad))
}

run_suite build --buildtype=release
if [[ "${WETGRAPH_NO_SANITIZE:-0}" != 1 ]]; then
    # full stacks on malloc, so leaks inside OpenImageIO match the suppressions
    export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:fast_unwind_on_malloc=0
    export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp
    export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
    run_suite build-sanitize --buildtype=debugoptimized -Db_sanitize=address,undefined -Db_lundef=false
fi
if [[ "${WETGRAPH_NO_FUZZ:-0}" != 1 ]]; then
    fuzz_line=$(scripts/fuzz.sh "${WETGRAPH_FUZZ_SECONDS:-20}" | tail -1)
    echo "$fuzz_line"
    if [[ $fuzz_line =~ ^fuzz:\ ([0-9]+)\ passed,\ ([0-9]+)\ failed$ ]]; then
        passed=$((passed + BASH_REMATCH[1]))
        failed=$((failed + BASH_REMATCH[2]))
    else
        failed=$((failed + 1))
    fi
fi
echo "tests: $passed passed, $failed failed"
[[ $failed -eq 0 ]]
