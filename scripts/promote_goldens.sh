#!/usr/bin/env bash
# Promotes actual images written by failing renderer golden tests to goldens in tests/renderer/golden/.
# Look at each <build>/tests/renderer/golden/<name>.actual.png (and .diff.png) first: a golden is a claim that the
# image is right. Usage:
#   scripts/promote_goldens.sh                 # list the candidates, promote nothing
#   scripts/promote_goldens.sh NAME [NAME...]  # promote these (e.g. vulkan_mesh_intrinsics)
#   scripts/promote_goldens.sh --all           # promote every candidate
# BUILD_DIR (default: build) is the CMake build directory.
set -euo pipefail
cd "$(dirname "$0")/.."
src="${BUILD_DIR:-build}/tests/renderer/golden"
dst="tests/renderer/golden"
shopt -s nullglob
candidates=()
for f in "$src"/*.actual.png; do
  n="$(basename "$f" .actual.png)"
  [[ "$n" == cross_* ]] || candidates+=("$n")
done
if [ $# -eq 0 ]; then
  if [ ${#candidates[@]} -eq 0 ]; then echo "no actual images in $src"; exit 0; fi
  echo "candidates in $src (review the .actual.png and .diff.png, then pass names or --all):"
  printf '  %s\n' "${candidates[@]}"
  exit 0
fi
names=("$@")
[ "$1" = "--all" ] && names=("${candidates[@]}")
mkdir -p "$dst"
for n in "${names[@]}"; do
  f="$src/$n.actual.png"
  if [ ! -f "$f" ]; then echo "promote_goldens: no $f" >&2; exit 1; fi
  cp "$f" "$dst/$n.png.tmp" && mv "$dst/$n.png.tmp" "$dst/$n.png"
  echo "promoted $dst/$n.png"
done
echo "now: git add $dst && git commit"
