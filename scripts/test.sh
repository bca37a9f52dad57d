#!/usr/bin/env bash
# The whole test suite: install what is needed, build everything, run every test under ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
cd build
ctest --output-on-failure --timeout 900 "$@"
