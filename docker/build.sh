#!/usr/bin/env bash
# Builds docker/Dockerfile for real and checks the container: it answers /healthz and serves a view of an uploaded
# scene. Run as root on Debian 12 with docker.io (or podman with DOCKER=podman) and debootstrap installed.
#
# There is no registry for base images here, so the base image debian:bookworm is made from Debian's archive:
# debootstrap bookworm into a folder, then `docker import` (skipped when the image already exists).
#
# Environment: DOCKER (default: docker), DOCKER_HOST (to use a daemon on another socket), MIRROR and
# SECURITY_MIRROR (default: the archives this machine's own apt sources name for bookworm and bookworm-security),
# IMAGE (default rgbdcast:verify), PORT (default 18080), SCENE (a GLB to upload; default: reduce TUM fr1/xyz frame 0
# from ../shared/data with the image's own binary).
# Prints one line per step with its time; exits non-zero at the first failing step, saying which.
set -euo pipefail
cd "$(dirname "$0")/.."
DOCKER="${DOCKER:-docker}"

# The URI that this machine's apt sources give for a suite: one-line entries ("deb [options] URI suite components"
# in sources.list and *.list) and deb822 stanzas (Types/URIs/Suites in *.sources). Prints nothing when none does.
apt_source_uri() {
  local suite="$1" f
  for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [ -f "$f" ] || continue
    awk -v s="$suite" '$1 == "deb" {
      i = 2; if ($i ~ /^\[/) { while (i < NF && $i !~ /\]$/) i++; i++ }
      if ($(i + 1) == s) { print $i; exit } }' "$f"
  done
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -f "$f" ] || continue
    awk -v s="$suite" 'BEGIN { RS = "" } {
      types = uris = suites = ""
      n = split($0, lines, "\n")
      for (j = 1; j <= n; j++) {
        if (lines[j] ~ /^Types:/) types = " " substr(lines[j], 7) " "
        else if (lines[j] ~ /^URIs:/) uris = substr(lines[j], 6)
        else if (lines[j] ~ /^Suites:/) suites = " " substr(lines[j], 8) " "
      }
      split(uris, u, " ")
      if (types ~ / deb / && suites ~ (" " s " ") && u[1] != "") { print u[1]; exit } }' "$f"
  done
}
MIRROR="${MIRROR:-$(apt_source_uri bookworm | head -1)}"
SECURITY_MIRROR="${SECURITY_MIRROR:-$(apt_source_uri bookworm-security | head -1)}"
IMAGE="${IMAGE:-rgbdcast:verify}"
PORT="${PORT:-18080}"
work="$(mktemp -d /tmp/rgbdcast-docker.XXXXXX)"
container=""
cleanup() {
  [ -n "$container" ] && "$DOCKER" rm -f "$container" >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT

step_start=0
step() { step_start=$(date +%s); echo "docker/build.sh: $*"; }
done_step() { echo "docker/build.sh:   ok ($(( $(date +%s) - step_start )) s)"; }
die() { echo "docker/build.sh: FAILED: $*" >&2; exit 1; }

[ -n "$MIRROR" ] || die "no apt source of this machine names bookworm (/etc/apt/sources.list*): set MIRROR"
"$DOCKER" version >/dev/null 2>&1 || die "no container engine answers: $("$DOCKER" version 2>&1 | tail -1)"

if ! "$DOCKER" image inspect debian:bookworm >/dev/null 2>&1; then
  step "base image: debootstrap bookworm from $MIRROR, then $DOCKER import"
  command -v debootstrap >/dev/null || die "debootstrap is not installed (apt-get install debootstrap)"
  debootstrap --variant=minbase bookworm "$work/rootfs" "$MIRROR" > "$work/debootstrap.log" 2>&1 ||
    die "debootstrap: $(tail -3 "$work/debootstrap.log")"
  # The same suites as a stock Debian image: updates and security too (when this machine has a security source).
  {
    echo "deb $MIRROR bookworm main"
    echo "deb $MIRROR bookworm-updates main"
    [ -z "$SECURITY_MIRROR" ] || echo "deb $SECURITY_MIRROR bookworm-security main"
  } > "$work/rootfs/etc/apt/sources.list"
  rm -rf "$work/rootfs/var/cache/apt/archives/"*.deb "$work/rootfs/var/lib/apt/lists/"*
  tar -C "$work/rootfs" -c . | "$DOCKER" import - debian:bookworm >/dev/null
  done_step
  echo "docker/build.sh:   debian:bookworm $("$DOCKER" image inspect -f '{{.Size}}' debian:bookworm) bytes"
fi

step "build $IMAGE from docker/Dockerfile"
"$DOCKER" build -f docker/Dockerfile -t "$IMAGE" . > "$work/build.log" 2>&1 || {
  tail -20 "$work/build.log" >&2
  die "$DOCKER build (last lines above)"
}
done_step
echo "docker/build.sh:   $IMAGE $("$DOCKER" image inspect -f '{{.Size}}' "$IMAGE") bytes"

step "run $IMAGE, wait for /healthz"
# The server refuses a non-loopback bind without a token: one for this check, and the address curl uses allowed.
head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$work/token"
chmod 644 "$work/token"
container="$("$DOCKER" run -d -p "127.0.0.1:$PORT:8080" -v "$work/token:/run/secrets/rgbdcast-token:ro" "$IMAGE" \
  rgbdcast serve --bind 0.0.0.0 --port 8080 --data-dir /var/lib/rgbdcast --token-file /run/secrets/rgbdcast-token \
  --allow-origin "http://127.0.0.1:$PORT")"
for _ in $(seq 1 60); do
  curl -fsS "http://127.0.0.1:$PORT/healthz" > "$work/healthz.json" 2>/dev/null && break
  sleep 0.5
done
[ -s "$work/healthz.json" ] || die "/healthz did not answer within 30 s; container log: $("$DOCKER" logs "$container" 2>&1 | tail -5)"
echo "docker/build.sh:   /healthz: $(cat "$work/healthz.json")"
done_step

scene="${SCENE:-}"
if [ -z "$scene" ]; then
  step "reduce TUM fr1/xyz frame 0 with the image's binary"
  data="$(cd .. && pwd)/shared/data/tum/rgbd_dataset_freiburg1_xyz"
  [ -d "$data" ] || die "no scene: set SCENE=file.glb or provide $data"
  "$DOCKER" run --rm -v "$data:/data:ro" -v "$work:/out" --user "$(id -u):$(id -g)" "$IMAGE" \
    rgbdcast reduce --input /data --frame 0 --out /out/scene.glb > "$work/reduce.log" 2>&1 ||
    die "reduce in the container: $(tail -2 "$work/reduce.log")"
  scene="$work/scene.glb"
  done_step
fi

step "upload $(basename "$scene") ($(stat -c %s "$scene") bytes) and fetch a view"
code="$(curl -sS -o "$work/upload.json" -w '%{http_code}' -H 'Content-Type: model/gltf-binary' \
  -H "Authorization: Bearer $(cat "$work/token")" \
  --data-binary "@$scene" "http://127.0.0.1:$PORT/v1/scenes")"
[ "$code" = 201 ] || die "POST /v1/scenes answered $code: $(cat "$work/upload.json")"
id="$(sed -n 's/.*"id": *"\([^"]*\)".*/\1/p' "$work/upload.json" | head -1)"
[ -n "$id" ] || die "no scene id in $(cat "$work/upload.json")"
code="$(curl -sS -D "$work/view.headers" -o "$work/view.png" -w '%{http_code}' \
  "http://127.0.0.1:$PORT/v1/scenes/$id/view?pose=capture&format=png")"
[ "$code" = 200 ] || die "GET view answered $code: $(cat "$work/view.png")"
head -c 8 "$work/view.png" | od -An -tx1 | grep -q '89 50 4e 47' || die "the view is not a PNG"
backend="$(grep -i '^X-Backend:' "$work/view.headers" | tr -d '\r' | cut -d' ' -f2)"
render_ms="$(grep -i '^X-Render-Ms:' "$work/view.headers" | tr -d '\r' | cut -d' ' -f2)"
echo "docker/build.sh:   scene $id: view $(stat -c %s "$work/view.png") bytes PNG, backend $backend, render $render_ms ms"
done_step
echo "docker/build.sh: container verified"
