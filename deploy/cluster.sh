#!/usr/bin/env bash
# A cluster on one machine, for users, tests and benchmarks:
#   deploy/cluster.sh up DIR [--replicas N] [--port P] [-- SERVE_OPTIONS...]
#   deploy/cluster.sh down DIR
# `up` starts, all on loopback and all kept in DIR:
# - PostgreSQL 15 (Debian's): initdb into DIR/pg/data on first use, then a server listening only on a unix socket in
#   DIR/pg (no TCP port). PostgreSQL refuses to run as root: as root it runs as the `postgres` user, which must be
#   able to reach DIR (a folder under /tmp works; one under /root does not).
# - N replicas of `rgbdcast serve --store postgresql://...`, named 1..N, on ports P+1..P+N, each with its copy of the
#   tiles in DIR/replica-NAME/ and its output in DIR/replica-NAME.log. SERVE_OPTIONS are added to each.
# - nginx (Debian's) on port P with deploy/nginx.conf.in, written to DIR/nginx.conf.
# It writes DIR/postgres.pid, DIR/replica-NAME.pid and DIR/nginx.pid, waits until every replica's /readyz answers 200
# (at most 60 s each) and prints the front URL; a start that fails stops what is running in DIR. `down` stops exactly
# the processes of those pid files (each checked to still be the program it was: a pid may have been reused),
# replicas with SIGTERM, nginx with SIGQUIT, PostgreSQL with SIGINT (its fast shutdown), and SIGKILL for any still
# running 20 s later.
# The rgbdcast binary: $RGBDCAST_BIN, else build/app/rgbdcast of this checkout, else `rgbdcast` on PATH.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
pg_bin=/usr/lib/postgresql/15/bin

die() { echo "cluster.sh: $*" >&2; exit 1; }

usage() {
  echo "usage: deploy/cluster.sh up DIR [--replicas N] [--port P] [-- SERVE_OPTIONS...] | down DIR" >&2
  exit 2
}

# Runs "$@" as the postgres user when root (PostgreSQL refuses root), as this user otherwise. exec keeps the pid.
as_pg() {
  if [ "$(id -u)" = 0 ]; then
    exec setpriv --reuid=postgres --regid=postgres --init-groups -- "$@"
  else
    exec "$@"
  fi
}

rgbdcast_bin() {
  if [ -n "${RGBDCAST_BIN:-}" ]; then echo "$RGBDCAST_BIN"; return; fi
  if [ -x "$here/../build/app/rgbdcast" ]; then echo "$here/../build/app/rgbdcast"; return; fi
  command -v rgbdcast || die "no rgbdcast binary: build it, or set RGBDCAST_BIN"
}

# Whether pid file $1 names a live process whose command line contains $2.
alive() {
  local pid
  [ -f "$1" ] || return 1
  pid="$(cat "$1")"
  [[ "$pid" =~ ^[0-9]+$ ]] || return 1
  [ -r "/proc/$pid/cmdline" ] && tr '\0' ' ' < "/proc/$pid/cmdline" | grep -q -- "$2"
}

# Whether the process of pid file $1 still runs (neither gone nor a zombie), whatever its command line: for a process
# this script has just started in the background, which may not have reached its exec yet (its command line is then
# still this script's, and alive() would say it is not the program).
running() {
  local pid stat
  [ -f "$1" ] || return 1
  pid="$(cat "$1")"
  [[ "$pid" =~ ^[0-9]+$ ]] || return 1
  stat="$(cat "/proc/$pid/stat" 2>/dev/null)" || return 1
  stat="${stat##*) }"
  [ "${stat%% *}" != Z ]
}

# Stops the process of pid file $1 (command line containing $2) with signal $3, SIGKILL after 20 s; removes the file.
stop_one() {
  local file="$1" what="$2" sig="$3" pid i
  if alive "$file" "$what"; then
    pid="$(cat "$file")"
    kill "-$sig" "$pid" 2>/dev/null || true
    for i in $(seq 200); do
      alive "$file" "$what" || break
      sleep 0.1
    done
    if alive "$file" "$what"; then
      echo "cluster.sh: $file ($pid) still running after 20 s: SIGKILL" >&2
      kill -KILL "$pid" 2>/dev/null || true
    fi
  fi
  rm -f "$file"
}

down() {
  local dir="$1" f
  [ -d "$dir" ] || die "no folder $dir"
  stop_one "$dir/nginx.pid" nginx QUIT
  for f in "$dir"/replica-*.pid; do
    [ -e "$f" ] && stop_one "$f" serve TERM
  done
  stop_one "$dir/postgres.pid" postgres INT
  echo "cluster.sh: stopped the cluster in $dir"
}

# Polls `curl URL` until it answers 200, at most $2 seconds, while pid file $3 (when given) names a process that
# runs (running()); false otherwise.
wait_200() {
  local url="$1" seconds="$2" file="${3:-}" i
  for i in $(seq $((seconds * 10))); do
    [ "$(curl -s -o /dev/null -w '%{http_code}' --max-time 2 "$url" || true)" = 200 ] && return 0
    if [ -n "$file" ] && ! running "$file"; then return 1; fi
    sleep 0.1
  done
  return 1
}

start_postgres() {
  local dir="$1" i
  [ -x "$pg_bin/postgres" ] || die "PostgreSQL 15 is not installed (scripts/setup.sh test)"
  mkdir -p "$dir/pg"
  if [ "$(id -u)" = 0 ]; then
    chown postgres:postgres "$dir/pg"
    setpriv --reuid=postgres --regid=postgres --init-groups -- test -w "$dir/pg" ||
      die "the postgres user cannot reach $dir/pg (a folder on the way is closed to it): use a folder under /tmp"
  fi
  if [ ! -f "$dir/pg/data/PG_VERSION" ]; then
    (as_pg "$pg_bin/initdb" -D "$dir/pg/data" -A trust -U postgres -E UTF8 --no-instructions) \
      > "$dir/pg/initdb.log" 2>&1 || die "initdb failed: see $dir/pg/initdb.log"
  fi
  if alive "$dir/postgres.pid" postgres; then return; fi
  (as_pg "$pg_bin/postgres" -D "$dir/pg/data" -k "$dir/pg" -c listen_addresses= -c max_connections=200) \
    >> "$dir/pg/postgres.log" 2>&1 &
  echo $! > "$dir/postgres.pid"
  for i in $(seq 300); do
    "$pg_bin/pg_isready" -q -h "$dir/pg" -U postgres && break
    running "$dir/postgres.pid" || die "postgres exited at start: see $dir/pg/postgres.log"
    sleep 0.1
  done
  "$pg_bin/pg_isready" -q -h "$dir/pg" -U postgres || die "postgres did not answer within 30 s"
  if [ "$("$pg_bin/psql" -h "$dir/pg" -U postgres -tAc "SELECT 1 FROM pg_database WHERE datname = 'rgbdcast'")" != 1 ]; then
    "$pg_bin/createdb" -h "$dir/pg" -U postgres rgbdcast
  fi
}

up() {
  local dir="$1" replicas="$2" port="$3"
  shift 3
  local bin servers="" i rport uri
  bin="$(rgbdcast_bin)"
  command -v nginx >/dev/null || [ -x /usr/sbin/nginx ] || die "nginx is not installed (scripts/setup.sh test)"
  mkdir -p "$dir"
  dir="$(cd "$dir" && pwd)"
  # A start that fails half-way (a port taken, a replica that does not get ready) stops the cluster in DIR again,
  # rather than leaving some of its processes running.
  trap 'echo "cluster.sh: the start failed; stopping the cluster in $dir" >&2
        down "$dir" > /dev/null 2>&1 || true' EXIT
  start_postgres "$dir"
  uri="postgresql:///rgbdcast?host=$dir/pg&user=postgres"
  for i in $(seq "$replicas"); do
    rport=$((port + i))
    servers+="    server 127.0.0.1:$rport max_fails=1 fail_timeout=5s;"$'\n'
    alive "$dir/replica-$i.pid" serve && continue
    "$bin" serve --store "$uri" --replica "$i" --data-dir "$dir/replica-$i" --port "$rport" \
      --allow-origin "http://127.0.0.1:$port" --allow-origin "http://localhost:$port" "$@" \
      > "$dir/replica-$i.log" 2>&1 &
    echo $! > "$dir/replica-$i.pid"
  done
  for i in $(seq "$replicas"); do
    wait_200 "http://127.0.0.1:$((port + i))/readyz" 60 "$dir/replica-$i.pid" ||
      die "replica $i is not ready: $(tail -n 1 "$dir/replica-$i.log")"
  done
  mkdir -p "$dir/nginx/body" "$dir/nginx/proxy" "$dir/nginx/fastcgi" "$dir/nginx/uwsgi" "$dir/nginx/scgi"
  # As root nginx's workers run as nobody: they write request bodies under DIR/nginx.
  if [ "$(id -u)" = 0 ]; then chmod -R 0777 "$dir/nginx"; fi
  local max_body=64 prev=""
  for a in "$@"; do
    [ "$prev" = --max-body-mib ] && max_body="${a%.*}"
    prev="$a"
  done
  awk -v dir="$dir" -v port="$port" -v servers="${servers%$'\n'}" -v body="$max_body" '
    /@SERVERS@/ { print servers; next }
    { gsub(/@DIR@/, dir); gsub(/@PORT@/, port); gsub(/@MAX_BODY_MIB@/, body); print }
  ' "$here/nginx.conf.in" > "$dir/nginx.conf"
  if ! alive "$dir/nginx.pid" nginx; then
    nginx -t -q -c "$dir/nginx.conf" -e "$dir/nginx-error.log" 2> "$dir/nginx-check.log" ||
      die "nginx refused its configuration: see $dir/nginx-check.log"
    nginx -c "$dir/nginx.conf" -e "$dir/nginx-error.log" >> "$dir/nginx-error.log" 2>&1 &
    echo $! > "$dir/nginx.pid"  # nginx writes the same pid there itself (the pid directive)
  fi
  wait_200 "http://127.0.0.1:$port/readyz" 30 "$dir/nginx.pid" ||
    die "nginx does not answer on port $port: $(tail -n 1 "$dir/nginx-error.log")"
  trap - EXIT
  echo "http://127.0.0.1:$port"
}

[ $# -ge 2 ] || usage
cmd="$1"
dir="$2"
shift 2
case "$cmd" in
  up)
    replicas=2
    port=8080
    while [ $# -gt 0 ]; do
      case "$1" in
        --replicas) replicas="${2:?}"; shift 2 ;;
        --port) port="${2:?}"; shift 2 ;;
        --) shift; break ;;
        *) usage ;;
      esac
    done
    [[ "$replicas" =~ ^[1-9][0-9]?$ ]] || die "--replicas must be 1..99"
    [[ "$port" =~ ^[0-9]+$ ]] && [ "$port" -ge 1024 ] && [ $((port + replicas)) -le 65535 ] ||
      die "--port must leave room for the replicas' ports above it (1024..65535)"
    up "$dir" "$replicas" "$port" "$@"
    ;;
  down)
    [ $# -eq 0 ] || usage
    down "$dir"
    ;;
  *) usage ;;
esac
