#!/usr/bin/env bash
# Regenerates the realtime preset's goldens (tests/renderer/golden/realtime_tum_*.png, tests/renderer/
# test_golden_realtime.cpp) after the realtime reduction changed its mesh. One command:
#   scripts/regenerate_realtime_goldens.sh
# It builds renderer_fidelity_test, runs the RealtimeGolden tests (they fail where the image changed and write
# <build>/tests/renderer/golden/realtime_*.actual.png and .diff.png), promotes those actual images, then runs the
# tests again, which must now pass. Look at the promoted images (and the diffs) before committing them: a golden is
# a claim that the image is right. BUILD_DIR (default: build) is the CMake build directory; RGBDCAST_JOBS (2) the
# build's jobs.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${BUILD_DIR:-build}"
test_bin="$build/tests/renderer/renderer_fidelity_test"
filter='Backends/RealtimeGolden.*'
cmake --build "$build" --target renderer_fidelity_test -j"${RGBDCAST_JOBS:-2}"
rm -f "$build"/tests/renderer/golden/realtime_*.png
"$test_bin" --gtest_filter="$filter" > /dev/null || true  # fails where a golden changed; writes the actual images
shopt -s nullglob
actual=("$build"/tests/renderer/golden/realtime_*.actual.png)
if [ ${#actual[@]} -eq 0 ]; then
  echo "regenerate_realtime_goldens: every realtime golden already matches"
else
  names=()
  for f in "${actual[@]}"; do names+=("$(basename "$f" .actual.png)"); done
  BUILD_DIR="$build" bash scripts/promote_goldens.sh "${names[@]}"
fi
"$test_bin" --gtest_filter="$filter"
