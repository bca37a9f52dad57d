#!/usr/bin/env bash
# The whole test suite: install what is needed (scripts/setup.sh test: the demo's packages and the test tools),
# build everything with warnings as errors, run every test under ctest, RGBDCAST_TEST_JOBS (default: the number of
# cores) at a time. Tests that need a resource alone say so in their CMakeLists (RESOURCE_LOCK).
# Then the fuzz smoke run: every libFuzzer target for RGBDCAST_FUZZ_SECONDS (20 s) from its seed corpus, and the
# tests of the untrusted-input libraries under ASan + UBSan, both built with clang-16 in build-fuzz/.
# RGBDCAST_FUZZ_SECONDS=0 skips those two.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh test
fuzz="${RGBDCAST_FUZZ_SECONDS:-20}"

# The clang build of build-fuzz/ goes on beside the main build and ctest at the lowest priority: they keep the cores
# they ask for, and it takes the time they leave idle (links, tests waiting on their servers). It has its own session,
# so that a failure stops exactly it. A new session is a new scheduling autogroup where the kernel has them
# (/proc/sys/kernel/sched_autogroup_enabled), and autogroups share the cores equally whatever their processes' nice
# values: so the group itself is set to nice 19 too, or the build would take half the cores from the tests.
clang_pid=""
if [ "$fuzz" != 0 ]; then
  mkdir -p build-fuzz
  setsid bash -c '{ echo 19 >/proc/self/autogroup; } 2>/dev/null || true
    exec nice -n 19 env RGBDCAST_BUILD_ONLY=1 bash -c "bash scripts/fuzz.sh && bash scripts/sanitized_subset.sh"' \
    >build-fuzz/clang-build.log 2>&1 &
  clang_pid=$!
fi
stop_clang() { [ -z "$clang_pid" ] || kill -- "-$clang_pid" 2>/dev/null || true; }
trap stop_clang EXIT

RGBDCAST_WERROR=ON bash scripts/build.sh
run_ctest() { (cd build && ctest --output-on-failure --timeout 900 -j"${RGBDCAST_TEST_JOBS:-$(nproc)}" "$@"); }
# The tests labelled whole_machine (real-time runs with an idle-class thread) need cores that nothing else wants:
# they run last, once the background build is done.
run_ctest -LE whole_machine "$@"
if [ -n "$clang_pid" ]; then
  waited=$(date +%s)
  wait "$clang_pid" || { echo "test.sh: the clang build of build-fuzz/ failed:" >&2; tail -40 build-fuzz/clang-build.log >&2; exit 1; }
  clang_pid=""
  echo "test.sh: the clang build: $(grep -h ': build' build-fuzz/clang-build.log | tr '\n' ' ')(waited for $(($(date +%s) - waited)) s after ctest)"
fi
run_ctest -L whole_machine "$@"
[ "$fuzz" != 0 ] || exit 0
bash scripts/fuzz.sh "$fuzz"
bash scripts/sanitized_subset.sh
