#!/usr/bin/env bash
# The test suite under AddressSanitizer + UndefinedBehaviorSanitizer: builds everything with
# -DRGBDCAST_SANITIZE=ON (RelWithDebInfo) in build-asan/ and runs ctest there. Any sanitizer report fails its test:
# UBSan does not recover, ASan aborts, LeakSanitizer reports at exit. The only suppressions are third-party leaks, each
# with its reason, in tests/sanitizers/lsan.supp. Extra arguments go to ctest:
#   scripts/sanitize.sh                  # the whole suite (2 cores: see BENCHMARKS.md for the time)
#   scripts/sanitize.sh -R '^(ServiceStore|CameraJson|FuzzRegression)\.'   # a part (CI does not run this script:
#                                        # see BENCHMARKS.md, "Sanitizers", for the build and test times behind that)
#   scripts/sanitize.sh -R view_params   # one test
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
jobs="${RGBDCAST_JOBS:-2}"
if [ -n "${CCACHE_DIR:-}" ] && command -v ccache >/dev/null; then
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
else
  launcher=()
fi
start=$(date +%s)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRGBDCAST_SANITIZE=ON "${launcher[@]}" >/dev/null
cmake --build build-asan -j"$jobs"
built=$(date +%s)
source scripts/sanitizer_env.sh "$root"
cd build-asan
status=0
ctest --output-on-failure --timeout 1800 "$@" || status=$?
echo "sanitize.sh: build $((built - start)) s, tests $(($(date +%s) - built)) s"
exit $status
