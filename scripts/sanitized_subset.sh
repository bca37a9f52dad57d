#!/usr/bin/env bash
# CI's sanitized tests: the test programs of the libraries that read untrusted input (GLB, Draco, PCD,
# frames, multipart bodies, intrinsics, trajectories, view queries, the service's store and guards, keyframes) and
# the fuzz regression cases, built in build-fuzz/ with clang-16 and ASan + UBSan, whose libraries scripts/fuzz.sh has
# built already, and run under scripts/sanitizer_env.sh's options. The whole suite under ASan + UBSan is
# scripts/sanitize.sh: its build alone takes longer than CI's headroom (BENCHMARKS.md, "Sanitizers").
#   scripts/sanitized_subset.sh            # after scripts/fuzz.sh (scripts/test.sh runs both)
#   scripts/sanitized_subset.sh -R Gltf    # extra arguments go to ctest
#   scripts/sanitized_subset.sh --targets  # prints the test programs it builds, and exits
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
targets=(service_core_test camera_json_test input_tests keyframes_unit_test test_gltf_untrusted test_gltf_hostile
         fuzz_regression_test)
if [ "${1:-}" = --targets ]; then
  echo "${targets[*]}"
  exit 0
fi
[ -f build-fuzz/CMakeCache.txt ] || { echo "sanitized_subset.sh: no build-fuzz/ (run scripts/fuzz.sh first)" >&2; exit 2; }
start=$(date +%s)
cmake --build build-fuzz -j"${RGBDCAST_JOBS:-2}" --target "${targets[@]}"
built=$(date +%s)
source scripts/sanitizer_env.sh "$root"
cd build-fuzz
status=0
# The other test programs are not built here: their placeholders (*_NOT_BUILT) are left out.
ctest --output-on-failure --timeout 900 -j"${RGBDCAST_JOBS:-2}" -LE fuzz -E NOT_BUILT "$@" || status=$?
echo "sanitized_subset.sh: build $((built - start)) s, tests $(($(date +%s) - built)) s"
exit $status
