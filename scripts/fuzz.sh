#!/usr/bin/env bash
# Builds the libFuzzer harnesses of fuzz/ (clang-16, ASan + UBSan + libFuzzer) in build-fuzz/ and runs each one for
# [seconds] (default 10) from its seed corpus, through ctest (tests fuzz_smoke_*, RGBDCAST_JOBS of them at a time).
# A crash, leak, timeout (10 s) or an input that takes over 2.5 GB fails the run; the input is kept in
# build-fuzz/fuzz/artifacts/.
#   scripts/fuzz.sh            # the CI smoke run: 10 harnesses x 10 s (rosbag only where ROS bag input is built)
#   scripts/fuzz.sh 600        # longer
#   FUZZ_ONLY=glb scripts/fuzz.sh 3600
# RGBDCAST_FUZZ_ALSO_BUILD: more targets of build-fuzz/ to build in the same build (scripts/test.sh gives the
# sanitized subset's, so that the two keep both cores busy to the end).
# Reproduce a crash: build-fuzz/fuzz/fuzz_glb build-fuzz/fuzz/artifacts/glb-crash-<sha1>
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-10}"
jobs="${RGBDCAST_JOBS:-2}"
only="${FUZZ_ONLY:-glb|draco|intrinsics|frame_decode|frame_upload|multipart|pcd|trajectory|view_query|rosbag}"
for tool in clang-16 clang++-16; do
  command -v "$tool" >/dev/null || { echo "fuzz.sh: $tool missing (scripts/setup.sh installs it)" >&2; exit 2; }
done
if [ -n "${CCACHE_DIR:-}" ] && command -v ccache >/dev/null; then
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
else
  launcher=()
fi
CC=clang-16 CXX=clang++-16 cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRGBDCAST_FUZZ=ON \
  -DRGBDCAST_FUZZ_SECONDS="$seconds" "${launcher[@]}" >/dev/null
if [ -z "${FUZZ_ONLY:-}" ] && [ ! -d build-fuzz/fuzz/CMakeFiles/fuzz_rosbag.dir ]; then
  only="${only%|rosbag}"  # built without ROS bag input (librosbag-storage-dev missing)
  echo "fuzz.sh: this build has no ROS bag input; the rosbag target is skipped" >&2
fi
targets=()
for name in ${only//|/ }; do targets+=("fuzz_$name"); done
start=$(date +%s)
read -r -a also <<<"${RGBDCAST_FUZZ_ALSO_BUILD:-}"
cmake --build build-fuzz -j"$jobs" --target "${targets[@]}" "${also[@]}"
built=$(date +%s)
cd build-fuzz
ctest -L fuzz -R "^fuzz_smoke_(${only})\$" --output-on-failure -j"$jobs"
echo "fuzz.sh: build $((built - start)) s, runs $(($(date +%s) - built)) s (${seconds} s per harness)"
