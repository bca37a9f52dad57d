#!/usr/bin/env bash
# The whole test suite: install what is needed (scripts/setup.sh test: the demo's packages and the test tools),
# build everything with warnings as errors, run every test under ctest, RGBDCAST_TEST_JOBS (default: two per core,
# since the tests spend much of their time waiting on their servers, browsers and disks; BENCHMARKS.md, "Time of
# the test command") at a time. Tests that need a resource alone say so in their CMakeLists (RESOURCE_LOCK).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh test
RGBDCAST_WERROR=ON bash scripts/build.sh
cd build
ctest --output-on-failure --timeout 900 -j"${RGBDCAST_TEST_JOBS:-$((2 * $(nproc)))}" "$@"
# The fuzz smoke run: every libFuzzer target for RGBDCAST_FUZZ_SECONDS (10 s) from its seed corpus, built
# with clang-16 in build-fuzz/. RGBDCAST_FUZZ_SECONDS=0 skips it. A smoke run, not a campaign: from the seeds, the
# GLB target reached about 95 % of its 20 s edges by half its executions (BENCHMARKS.md, "Fuzzing").
cd ..
if [ "${RGBDCAST_FUZZ_SECONDS:-10}" != 0 ]; then
  # The tests of the untrusted-input libraries under ASan + UBSan are built with the harnesses, in one build.
  RGBDCAST_FUZZ_ALSO_BUILD="$(bash scripts/sanitized_subset.sh --targets)" bash scripts/fuzz.sh "${RGBDCAST_FUZZ_SECONDS:-10}"
  bash scripts/sanitized_subset.sh
fi
