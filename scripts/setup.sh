#!/usr/bin/env bash
# Installs everything rgbdcast needs on Debian 12 (run as root). Idempotent: safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

DEB_PACKAGES=(
  build-essential cmake pkg-config git ca-certificates
  libpcl-dev libopencv-dev libeigen3-dev libglm-dev
  libosmesa6-dev mesa-vulkan-drivers libvulkan-dev vulkan-tools vulkan-validationlayers
  glslang-tools glslang-dev
  libtinygltf-dev nlohmann-json3-dev libstb-dev libcpp-httplib-dev libgtest-dev libcli11-dev
  libmeshoptimizer-dev libdraco-dev libturbojpeg0-dev
  librosbag-storage-dev libsensor-msgs-dev python3-rosbag python3-sensor-msgs
  clang-16 libfuzzer-16-dev libclang-rt-16-dev
  chromium wrk curl jq
  # promtool, which checks the service's /metrics (tests/service/test_missions.cpp)
  prometheus
  # External glTF viewers for tests/gltf/test_gltf_viewers (Blender's glTF importer needs numpy). Measured on a
  # machine with the rest installed: 53 packages, 112 MB of archives, 423 MiB installed, 36 s of apt-get install
  # (with 35 of the archives already in apt's cache).
  blender python3-numpy assimp-utils
)
# Node.js with npm: the machine image ships Node 20 (with npm); a bare Debian 12 gets Debian's.
command -v npm >/dev/null 2>&1 || DEB_PACKAGES+=(nodejs npm)

missing=()
for p in "${DEB_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: Debian packages already installed"
fi

# npm packages used by tests (glTF validator, three.js for the external-viewer test), pinned in tools/package.json.
if [ -f tools/package.json ]; then
  if [ ! -d tools/node_modules ] || [ tools/package.json -nt tools/node_modules ]; then
    echo "setup: installing npm packages in tools/"
    (cd tools && npm install --no-audit --no-fund --loglevel=error)
    touch tools/node_modules
  else
    echo "setup: npm packages already installed"
  fi
fi
