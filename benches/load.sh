#!/usr/bin/env bash
# Load test of the append path (waypoint → prediction, stored and answered) with an external
# load generator, oha (installed from the crate registry into the target dir when missing).
# Each round starts the release server on a fresh database and drives it with
# benches/load/run.py (how cells are taught and timed is described there):
#   closed loop for each of CELLS cells (one connection per cell: saturation);
#   open loop, RATE appends/s across OPEN_CELLS cells.
#
#   bash benches/load.sh [sqlite|postgres]      # default sqlite; postgres starts a throwaway
#                                               # cluster (scripts/with-postgres.sh)
#   CELLS="1 8 64 256" SECONDS_PER_ROUND=20 RATE=1000 OPEN_CELLS=64 bash benches/load.sh
#
# Client and server share the machine. Prints a markdown table; every request's latency is kept
# in <target>/load/<database>/.
set -euo pipefail
cd "$(dirname "$0")/.."

backend="${1:-sqlite}"
cells_list="${CELLS:-1 8 64 256}"
seconds="${SECONDS_PER_ROUND:-20}"
rate="${RATE:-1000}"
open_cells="${OPEN_CELLS:-64}"
target="${CARGO_TARGET_DIR:-target}"

if [ "$backend" = postgres ] && [ -z "${NEXTPOSE_TEST_POSTGRES:-}" ]; then
  exec bash scripts/with-postgres.sh bash "$0" "$@"
fi

cargo build --release --locked --quiet
bin="$target/release/nextpose"
oha="$(command -v oha || true)"
if [ -z "$oha" ]; then
  oha="$target/tools/bin/oha"
  if [ ! -x "$oha" ]; then
    echo "load: installing oha into $target/tools" >&2
    cargo install --quiet --locked --root "$target/tools" oha@1.16.0
  fi
fi

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
database() { # a new database for each round (run in a subshell: names are unique by time)
  local id
  id="$(date +%s%N)"
  if [ "$backend" = postgres ]; then
    local name="load_$id"
    psql -q "$NEXTPOSE_TEST_POSTGRES" -c "CREATE DATABASE $name"
    echo "${NEXTPOSE_TEST_POSTGRES%/*}/$name"
  else
    echo "$tmp/load-$id.db"
  fi
}

echo "$backend, $(nproc) cores, $(date -u +%Y-%m-%dT%H:%MZ):"
echo
echo "| cells | loop | appends/s | p50 | p99 | max | errors / requests |"
echo "|---|---|---|---|---|---|---|"
round_of() {
  python3 benches/load/run.py --bin "$bin" --oha "$oha" --db "$(database)" --cells "$2" \
    --mode "$1" --seconds "$seconds" --rate "$rate" --out "$target/load/$backend"
}
for cells in $cells_list; do
  round_of closed "$cells"
done
round_of open "$open_cells"
