#!/usr/bin/env bash
# The README's test command: installs what the tests need that cargo does not bring (Debian's
# chromium and chromium-driver, for the pendant's browser test in tests/pendant.rs) when it is
# missing, then runs `cargo test` with any arguments given (`bash scripts/test.sh --test api`),
# the LASA handwriting test (scripts/lasa.sh exports the set), and the API tests again on
# PostgreSQL (scripts/with-postgres.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v chromium > /dev/null || ! command -v chromedriver > /dev/null; then
  echo "test: installing Debian's chromium and chromium-driver (the pendant's browser test)" >&2
  sudo=""
  if [ "$(id -u)" != 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq chromium chromium-driver > /dev/null
fi

cargo test --locked "$@"

# Lead-through teaching on real demonstrations: the LASA handwriting set, exported from the
# Python package that ships it (a throw-away venv), then the test that reads it (ignored by
# plain `cargo test`). The filter names that one test exactly: `--ignored` alone would also run
# the tests ignored because the shared corpus is missing.
LASA_ONLY_EXPORT=1 bash scripts/lasa.sh
cargo test --locked --test engine -- --ignored --exact \
  lead_through::lasa_handwriting_is_segmented_and_reproduced

# The API tests once more on PostgreSQL (a throwaway cluster, its server installed when missing),
# the storage unit tests that take a cluster (the append writer's PostgreSQL pass, skipped with a
# notice by plain `cargo test`), then the tests of several instances on one database and the
# pg_dump/pg_restore round trip (ignored by plain `cargo test`: they need the cluster), named
# exactly. The instances test that
# teaches a corpus program also needs ../shared.
instances="instances::concurrent_appends_on_two_instances_are_serialised"
instances+=" backup::pg_dump_and_pg_restore_give_the_same_models_and_predictions"
instances+=" instances::a_program_changed_on_two_instances_keeps_one_history"
if [ -d ../shared/corpus/json ]; then
  instances+=" instances::two_instances_alternating_with_a_kill_match_one_instance"
else
  echo "test: no ../shared/corpus/json: skipping instances::two_instances_alternating_with_a_kill_match_one_instance (it teaches a corpus program)" >&2
fi
INSTANCES="$instances" NEXTPOSE_TEST_DB=postgres bash scripts/with-postgres.sh bash -c \
  'cargo test --locked --test api "$@" && cargo test --locked --lib storage:: &&
   cargo test --locked --test api -- --ignored --exact $INSTANCES' \
  test "$@"
