#!/usr/bin/env bash
# Configures and builds rgbdcast (Release) into build/. Used by demo.sh and test.sh. RGBDCAST_BUILD_TESTS=OFF leaves
# the test suite out (the demo does: GoogleTest is installed only by scripts/setup.sh test). RGBDCAST_WERROR=ON makes
# compiler warnings errors (the test command sets it).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs="${RGBDCAST_JOBS:-$(nproc)}"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DRGBDCAST_BUILD_TESTS="${RGBDCAST_BUILD_TESTS:-ON}" \
  -DRGBDCAST_WERROR="${RGBDCAST_WERROR:-OFF}" >/dev/null
cmake --build build -j"$jobs" "$@"
