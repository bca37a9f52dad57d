#!/usr/bin/env bash
# Installs what rgbdcast needs on Debian 12 (run as root), in two layers. Idempotent: safe to run again.
#   scripts/setup.sh demo  what building and running rgbdcast needs (scripts/demo.sh runs this)
#   scripts/setup.sh test  the demo layer, then what only the tests, fuzzing, external viewers and benchmarks need
#                          (scripts/test.sh runs this)
set -euo pipefail
cd "$(dirname "$0")/.."
layer="${1:-test}"

# Build and runtime: the compiler and CMake, the libraries the build links (libpq for the PostgreSQL store), the renderers' drivers (lavapipe for
# Vulkan, OSMesa) and glslangValidator, which compiles the shaders at build time.
DEMO_PACKAGES=(
  build-essential cmake pkg-config
  libpcl-dev libopencv-dev libeigen3-dev libglm-dev
  libosmesa6-dev mesa-vulkan-drivers libvulkan-dev glslang-tools
  libtinygltf-dev nlohmann-json3-dev libstb-dev libcpp-httplib-dev libcli11-dev
  libmeshoptimizer-dev libdraco-dev libturbojpeg0-dev
  libpq-dev
)
# Tests only: GoogleTest, the Vulkan validation layers, ROS 1 bag reading and writing, clang-16 with libFuzzer and
# the sanitizers' runtime, headless Chromium (the page tests), wrk (load benchmarks), curl and jq (scripts),
# promtool (the /metrics check), git and clang-format 14 (the tests that read the tree and check its format), the
# external glTF viewers (Blender, whose glTF importer needs numpy, and Assimp), the PostgreSQL server the store tests
# start, and nginx in front of the replicas that deploy/cluster.sh starts.
TEST_PACKAGES=(
  git clang-format-14 ca-certificates libgtest-dev vulkan-tools vulkan-validationlayers glslang-dev
  librosbag-storage-dev libsensor-msgs-dev python3-rosbag python3-sensor-msgs
  clang-16 libfuzzer-16-dev libclang-rt-16-dev
  chromium wrk curl jq prometheus
  blender python3-numpy assimp-utils
  postgresql-15 nginx
)

case "$layer" in
  demo)
    packages=("${DEMO_PACKAGES[@]}")
    # npm installs three.js and 3DTilesRendererJS for the operator page's local rendering (tools/package.json).
    command -v npm >/dev/null 2>&1 || packages+=(nodejs npm)
    ;;
  test)
    packages=("${DEMO_PACKAGES[@]}" "${TEST_PACKAGES[@]}")
    # Node.js with npm runs the test tools of tools/package.json: the machine image ships Node 20 (with npm); a
    # bare Debian 12 gets Debian's.
    command -v npm >/dev/null 2>&1 || packages+=(nodejs npm)
    ;;
  *) echo "usage: scripts/setup.sh demo|test" >&2; exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup ($layer): installing ${#missing[@]} Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup ($layer): Debian packages already installed"
fi

# npm packages, pinned in tools/package.json: three.js and 3DTilesRendererJS, which rgbdcast serve hands to the
# operator page, and the glTF validator of the tests. Both layers install them; a failed install leaves the page on
# server-rendered views.
if [ -f tools/package.json ]; then
  if [ ! -d tools/node_modules ] || [ tools/package.json -nt tools/node_modules ]; then
    echo "setup: installing npm packages in tools/"
    if (cd tools && npm ci --no-audit --no-fund --loglevel=error); then
      touch tools/node_modules
    else
      echo "setup: npm ci in tools/ failed: the operator page will show server-rendered views" >&2
    fi
  else
    echo "setup: npm packages already installed"
  fi
fi
