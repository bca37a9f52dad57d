#!/usr/bin/env bash
# Prints the Debian packages that own the shared libraries a binary links (ldd + dpkg -S), one per line: the
# runtime stage of docker/Dockerfile installs exactly these. Debian 12 merges /lib into /usr/lib, but dpkg records
# some libraries under /lib, so both spellings are tried.
set -euo pipefail
binary="$1"
ldd "$binary" | awk '/=> \// { print $3 } /^\t\/lib/ { print $1 }' | sort -u | while read -r lib; do
  real="$(readlink -f "$lib")"
  for path in "$lib" "$real" "${lib#/usr}" "${real#/usr}" "/usr$lib" "/usr$real"; do
    if owner="$(dpkg -S "$path" 2>/dev/null)"; then
      echo "${owner%%:*}"
      break
    fi
  done
done | sed 's/,.*//' | sort -u
