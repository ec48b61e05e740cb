#!/usr/bin/env bash
# A short fuzz run of the three importers for CI (docs/testing.md, "Fuzzing the importers"):
# installs cargo-fuzz 0.13.2 when missing, builds the targets rapid, krl and fanuc (each parses
# its input and imports it into a fresh engine, as POST /v1/cells/{id}/imports does), and runs
# each for FUZZ_SECONDS (default 60) from the real programs of ../shared/corpus*/raw, inputs cut
# to 4 KB. Fails on a crash, panic, timeout or out-of-memory; the input that caused it is
# written to fuzz/artifacts/<target>/ and named in the output.
#
#   bash scripts/fuzz.sh                  # all three, 60 s each
#   FUZZ_SECONDS=600 bash scripts/fuzz.sh krl
#
# Needs the Rust toolchain (stable, with RUSTC_BOOTSTRAP=1 for the sanitizer-free build
# cargo-fuzz does). Without ../shared the targets start from an empty corpus, with a warning.
set -euo pipefail

cd "$(dirname "$0")/.."
root=$PWD
shared="${SHARED:-$root/../shared}"
seconds="${FUZZ_SECONDS:-60}"
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(rapid krl fanuc)

if ! cargo fuzz --version 2>/dev/null | grep -q '0\.13\.2'; then
  echo "fuzz: installing cargo-fuzz 0.13.2" >&2
  cargo install cargo-fuzz --version 0.13.2 --locked
fi

# Seeds: each repository's files, named repo__file (names repeat across repositories), by
# language.
seeds=$(mktemp -d)
trap 'rm -rf "$seeds"' EXIT
for t in rapid krl fanuc; do mkdir -p "$seeds/$t"; done
found=0
for f in "$shared"/corpus/raw/*/* "$shared"/corpus2/raw/*/*; do
  [ -f "$f" ] || continue
  name="$(basename "$(dirname "$f")")__$(basename "$f")"
  case "$(printf '%s' "${f##*.}" | tr '[:upper:]' '[:lower:]')" in
    mod | modx | prg | sys) cp "$f" "$seeds/rapid/$name" ;;
    src | dat) cp "$f" "$seeds/krl/$name" ;;
    ls) cp "$f" "$seeds/fanuc/$name" ;;
    *) continue ;;
  esac
  found=$((found + 1))
done
[ "$found" -gt 0 ] || echo "fuzz: no seeds ($shared/corpus*/raw is missing): starting from nothing" >&2

cd "$root/fuzz"
export RUSTC_BOOTSTRAP=1
start=$(date +%s)
for t in "${targets[@]}"; do
  cargo fuzz build -s none "$t"
done
echo "fuzz: built ${targets[*]} in $(($(date +%s) - start)) s" >&2

status=0
for t in "${targets[@]}"; do
  log="$seeds/$t.log"
  echo "fuzz: $t for $seconds s from $(ls "$seeds/$t" | wc -l) seeds" >&2
  # -max_len: inputs (and seeds) cut to 4 KB, so an execution teaches tens of waypoints, not
  # the thousands of the largest corpus file; -timeout: one input that takes 60 s fails.
  if ! cargo fuzz run -s none "$t" "$seeds/$t" -- \
      -max_total_time="$seconds" -max_len=4096 -timeout=60 -dict=import.dict \
      -print_final_stats=1 >"$log" 2>&1; then
    status=1
    tail -n 60 "$log" >&2
    echo "fuzz: $t FAILED; the input is in fuzz/artifacts/$t/" >&2
  fi
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | cut -d' ' -f2)
  echo "fuzz: $t: ${runs:-?} executions, ${cov:-?} coverage edges" >&2
done
echo "fuzz: done in $(($(date +%s) - start)) s" >&2
exit $status
