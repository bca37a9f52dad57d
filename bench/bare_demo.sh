#!/usr/bin/env bash
# The README's first command (scripts/demo.sh) on a bare Debian 12: debootstrap makes a minimal bookworm root in DIR
# from this machine's own apt sources, the committed tree is cloned into it, and the demo runs there under chroot
# until its view service answers /healthz. Prints a table of the phases. Run as root; needs debootstrap.
#   bench/bare_demo.sh /var/tmp/bare            # DIR must not exist, or be a root this script made before (-k)
#   RGBDCAST_PORT=8097 bench/bare_demo.sh DIR
# The chroot shares this machine's network and kernel, so the time is the demo's own: packages, npm, build, sample,
# reduce and start. DIR is removed at the end unless KEEP=1. On a shared machine the wall time depends on the other
# work; the CPU seconds printed at the end do not.
set -euo pipefail
root="${1:?usage: bench/bare_demo.sh DIR}"
port="${RGBDCAST_PORT:-8097}"
repo=$(cd "$(dirname "$0")/.." && pwd)
command -v debootstrap >/dev/null || { echo "bare_demo.sh: debootstrap missing (apt-get install debootstrap)" >&2; exit 2; }
[ "$(id -u)" = 0 ] || { echo "bare_demo.sh: run as root (debootstrap and chroot)" >&2; exit 2; }
[ ! -e "$root" ] || { echo "bare_demo.sh: $root exists; give a new directory" >&2; exit 2; }

# The archive this machine installs from: the first deb URI of its apt sources (deb822 or one-line format).
mirror=$(grep -hE '^URIs:' /etc/apt/sources.list.d/*.sources 2>/dev/null | awk '{print $2; exit}')
[ -n "$mirror" ] || mirror=$(grep -hE '^deb ' /etc/apt/sources.list 2>/dev/null | awk '{print $2; exit}')
[ -n "$mirror" ] || { echo "bare_demo.sh: no deb source in /etc/apt" >&2; exit 2; }

mounted=()
demo_pid=""
cleanup() {
  [ -n "$demo_pid" ] && kill "$demo_pid" 2>/dev/null && wait "$demo_pid" 2>/dev/null || true
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do umount "${mounted[i]}" 2>/dev/null || umount -l "${mounted[i]}" || true; done
  [ "${KEEP:-0}" = 1 ] || rm -rf --one-file-system "$root"
}
trap cleanup EXIT

t0=$(date +%s.%N)
debootstrap --variant=minbase bookworm "$root" "$mirror" >"/tmp/bare_demo.debootstrap.log" 2>&1 ||
  { echo "bare_demo.sh: debootstrap failed (/tmp/bare_demo.debootstrap.log)" >&2; exit 1; }
t1=$(date +%s.%N)
# This machine's own configuration, not software: its apt sources, its resolver, and the certificate authorities
# it trusts (a network that inspects TLS needs its own CA for npm's downloads).
if ls /etc/apt/sources.list.d/*.sources >/dev/null 2>&1; then
  cp /etc/apt/sources.list.d/*.sources "$root/etc/apt/sources.list.d/"
  rm -f "$root/etc/apt/sources.list"
elif [ -f /etc/apt/sources.list ]; then
  cp /etc/apt/sources.list "$root/etc/apt/sources.list"
fi
cp /etc/resolv.conf "$root/etc/resolv.conf"
mkdir -p "$root/etc/ssl/certs"
cp /etc/ssl/certs/ca-certificates.crt "$root/etc/ssl/certs/machine-ca.crt"
for m in proc sys dev dev/pts; do
  mount --bind "/$m" "$root/$m"
  mounted+=("$root/$m")
done
# The committed tree only, as a clean clone has it.
git clone -q "$repo" "$root/root/rgbdcast"
packages_before=$(chroot "$root" dpkg-query -W | wc -l)

log=/tmp/bare_demo.log
t2=$(date +%s.%N)
chroot "$root" /usr/bin/env -i HOME=/root PATH=/usr/sbin:/usr/bin:/sbin:/bin RGBDCAST_PORT="$port" \
  NODE_EXTRA_CA_CERTS=/etc/ssl/certs/machine-ca.crt bash -c 'cd /root/rgbdcast && exec bash scripts/demo.sh' \
  >"$log" 2>&1 &
demo_pid=$!
# The demo ends in `exec rgbdcast serve`; it is ready when the service answers. Bounded: one hour.
mark() { grep -q "$1" "$log" 2>/dev/null; }
t_setup="" t_build="" t_reduce=""
while :; do
  now=$(date +%s.%N)
  [ -z "$t_setup" ] && mark '^\[ *[0-9]*%\]' && t_setup=$now
  [ -z "$t_build" ] && mark 'Built target rgbdcast' && mark 'Built target make_sample' && t_build=$now
  [ -z "$t_reduce" ] && mark '^demo: wrote' && t_reduce=$now
  if curl -fs "http://127.0.0.1:$port/healthz" >/dev/null 2>&1; then break; fi
  kill -0 "$demo_pid" 2>/dev/null || { echo "bare_demo.sh: the demo stopped; its log:" >&2; tail -20 "$log" >&2; exit 1; }
  awk -v a="$t2" -v b="$now" 'BEGIN { exit !(b - a > 3600) }' && { echo "bare_demo.sh: no answer in an hour" >&2; exit 1; }
  sleep 0.5
done
t3=$(date +%s.%N)
# The demo's CPU seconds: it ends as the server process (demo.sh execs it), whose reaped children (apt, the
# compilers, the sample, the reduction) are in its cutime and cstime. Unlike the wall time, it holds on a shared machine.
cpu_s=$(awk -v hz="$(getconf CLK_TCK)" '{ printf "%.0f", ($14 + $15 + $16 + $17) / hz }' "/proc/$demo_pid/stat")
packages_after=$(chroot "$root" dpkg-query -W | wc -l)
glb=$(stat -c %s "$root/root/rgbdcast/out/sample/room.glb")

s() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.0f", b - a }'; }
echo "bare Debian 12 (debootstrap --variant=minbase bookworm), $(nproc) cores, load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| phase | seconds |"
echo "|---|---|"
echo "| debootstrap (the bare machine, not part of the demo) | $(s "$t0" "$t1") |"
echo "| demo: packages ($((packages_after - packages_before)) Debian packages added), npm and configure | $(s "$t2" "${t_setup:-$t3}") |"
echo "| demo: configure and build rgbdcast and make_sample | $(s "${t_setup:-$t2}" "${t_build:-$t3}") |"
echo "| demo: make the sample and reduce it (${glb} B GLB) | $(s "${t_build:-$t2}" "${t_reduce:-$t3}") |"
echo "| demo: start serving until /healthz answers | $(s "${t_reduce:-$t2}" "$t3") |"
echo "| **demo in all, the README's first command** | **$(s "$t2" "$t3")** |"
echo
echo "the demo's processes used ${cpu_s} CPU seconds (user + system); load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
grep -q 'serve: no three.js modules' "$log" && echo "the page has no three.js modules: npm ci failed (see $log)"
