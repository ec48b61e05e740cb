#!/usr/bin/env bash
# Runs a command beside a throwaway PostgreSQL cluster: Debian's `postgresql` package (installed
# when missing), `initdb` into a temporary directory, a free loopback port, trust authentication
# for the `nextpose` role; stopped and removed when the command ends. The command sees the
# cluster as NEXTPOSE_TEST_POSTGRES (a URL of its `postgres` database; tests create a database
# of their own in it).
#
#   bash scripts/with-postgres.sh cargo test --test api
set -euo pipefail

find_bin() {
  if command -v initdb > /dev/null; then
    dirname "$(command -v initdb)"
  else
    # Debian keeps the server's programs out of PATH.
    ls -d /usr/lib/postgresql/*/bin 2> /dev/null | sort -V | tail -n 1
  fi
}

bin="$(find_bin)"
if [ -z "$bin" ] || [ ! -x "$bin/initdb" ]; then
  echo "with-postgres: installing Debian's postgresql" >&2
  sudo=""
  if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq postgresql > /dev/null
  bin="$(find_bin)"
fi

dir="$(mktemp -d)"
as=()
if [ "$(id -u)" = 0 ]; then
  # The server refuses to run as root: the package's `postgres` user runs it.
  chown postgres "$dir"
  as=(runuser -u postgres --)
fi
port="$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')"

stop() {
  "${as[@]}" "$bin/pg_ctl" -D "$dir/data" -m fast -w stop > /dev/null 2>&1 || true
  rm -rf "$dir"
}
trap stop EXIT

"${as[@]}" "$bin/initdb" -D "$dir/data" -U nextpose --auth=trust -E UTF8 --no-sync > /dev/null
"${as[@]}" "$bin/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w \
  -o "-p $port -k $dir -c listen_addresses=127.0.0.1 -c max_connections=300" start > /dev/null
echo "with-postgres: PostgreSQL $("$bin/postgres" --version | awk '{print $3}') on 127.0.0.1:$port" >&2

export NEXTPOSE_TEST_POSTGRES="postgres://nextpose@127.0.0.1:$port/postgres"
"$@"
