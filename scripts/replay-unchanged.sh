#!/usr/bin/env bash
# Checks that a change leaves the replay of the shared corpus as it was: the JSON reports of
# `nextpose replay` (default profile; seed profile with the MAP comparison) of this checkout
# against those of another revision, equal but for the timings (`us_per_waypoint`, `seconds`), which are
# measured and never the same twice.
#
#   bash scripts/replay-unchanged.sh REV        # builds REV in a temporary worktree (release)
#   bash scripts/replay-unchanged.sh DIR        # compares with reports saved earlier in DIR
#   REPLAY_SAVE=DIR bash scripts/replay-unchanged.sh REV   # and keeps REV's reports in DIR
#
# Needs ../shared/corpus/json beside the checkout; ../shared/corpus2/json too when present (its
# reports are named corpus2-default.json, …). Exits 1 and shows the first differences when a
# report differs.
set -euo pipefail
cd "$(dirname "$0")/.."

corpus=../shared/corpus/json
if [ ! -d "$corpus" ]; then
  echo "replay-unchanged: $corpus is missing (the shared corpus beside the checkout)" >&2
  exit 2
fi
if [ $# -ne 1 ]; then
  echo "usage: bash scripts/replay-unchanged.sh REV|DIR" >&2
  exit 2
fi

work="$(mktemp -d)"
cleanup() {
  if [ -d "$work/tree" ]; then git worktree remove --force "$work/tree" > /dev/null 2>&1 || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

# The second corpus, when it is there: (directory, prefix of its reports' names).
sets=("$corpus:")
if [ -d ../shared/corpus2/json ]; then
  sets+=("../shared/corpus2/json:corpus2-")
fi

# The reports of one binary into a directory, for every corpus.
reports() {
  local bin="$1" out="$2" set dir prefix
  mkdir -p "$out"
  for set in "${sets[@]}"; do
    dir="${set%%:*}" prefix="${set#*:}"
    "$bin" replay "$dir" --quiet --json "$out/${prefix}default.json" > /dev/null
    "$bin" replay "$dir" --quiet --profile seed --map --json "$out/${prefix}seed.json" \
      --map-json "$out/${prefix}seed-map.json" > /dev/null
  done
}

if [ -d "$1" ]; then
  base="$1"
else
  rev="$(git rev-parse --verify "$1^{commit}")"
  git worktree add --detach "$work/tree" "$rev" > /dev/null
  echo "replay-unchanged: building $rev" >&2
  (cd "$work/tree" && CARGO_TARGET_DIR="$work/target" cargo build --release --locked --quiet)
  base="${REPLAY_SAVE:-$work/base}"
  reports "$work/target/release/nextpose" "$base"
fi

echo "replay-unchanged: building this checkout" >&2
cargo build --release --locked --quiet
reports "${CARGO_TARGET_DIR:-target}/release/nextpose" "$work/new"

status=0
files=()
for set in "${sets[@]}"; do
  for f in default.json seed.json seed-map.json; do
    files+=("${set#*:}$f")
  done
done
for f in "${files[@]}"; do
  if [ ! -f "$base/$f" ]; then
    echo "replay-unchanged: $f not in $base (saved before that corpus was compared): skipped" >&2
    continue
  fi
  if python3 - "$base/$f" "$work/new/$f" << 'EOF'; then
import json, sys

def strip(o):
    if isinstance(o, dict):
        return {k: strip(v) for k, v in o.items() if k not in ("us_per_waypoint", "seconds")}
    if isinstance(o, list):
        return [strip(v) for v in o]
    return o

# Keys in the order written: a reordered report is a changed report.
a, b = (json.dumps(strip(json.load(open(p))), indent=1).splitlines() for p in sys.argv[1:])
if a == b:
    sys.exit(0)
import difflib
sys.stdout.writelines(l + "\n" for l in list(difflib.unified_diff(a, b, "before", "after", lineterm=""))[:60])
sys.exit(1)
EOF
    echo "replay-unchanged: $f equal (timings aside)"
  else
    echo "replay-unchanged: $f DIFFERS" >&2
    status=1
  fi
done
exit $status
