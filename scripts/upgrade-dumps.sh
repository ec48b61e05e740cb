#!/usr/bin/env bash
# Regenerates the databases of earlier releases that the upgrade tests open with today's server
# (tests/api/upgrade.rs, docs/testing.md "Upgrades"): for each release below, the commit is
# checked out in a scratch worktree, its `nextpose` binary built (debug, into this checkout's
# target directory, so only the crate is compiled again), served on a fresh database (an SQLite
# file, or a database in a throwaway PostgreSQL cluster), taught over its REST API by `session`
# below, stopped, and dumped as plain SQL into tests/upgrade/NAME.sql (`sqlite3 .dump`;
# `pg_dump --inserts --no-owner --no-privileges`, without the `\restrict` lines psql reads, so
# that the tests can run the text through sqlx).
#
#   bash scripts/upgrade-dumps.sh                  # every dump
#   bash scripts/upgrade-dumps.sh sqlite-0010      # some
#
# Needs git, cargo, curl, jq, python3, sqlite3 and, for the PostgreSQL dumps, what
# scripts/with-postgres.sh needs (it re-runs itself under it). The programs imported are the
# repository's own (tests/fixtures/import, and the generated ones below), not the shared
# corpus's, whose files carry no licence and stay out of the repository.
#
# The tokens of the releases that have them get new random secrets each run: the script
# prints them at the end, and tests/api/upgrade.rs keeps them (`TOKENS_*`); paste them there
# after regenerating.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="$repo/tests/upgrade"
target="${CARGO_TARGET_DIR:-$repo/target}"

# name, commit (the last on main before the next migration), engine
releases=(
  "sqlite-0008 43552d7 sqlite"   # migrations 0001-0008: before tokens and the audit trail
  "postgres-0002 43552d7 postgres"
  "sqlite-0010 60c8db5 sqlite"   # 0001-0010: tokens and the audit trail, before program history
  "postgres-0004 60c8db5 postgres"
)

wanted=("$@")
want() { [ ${#wanted[@]} = 0 ] || [[ " ${wanted[*]} " == *" $1 "* ]]; }

needs_postgres=0
for r in "${releases[@]}"; do
  set -- $r
  if want "$1" && [ "$3" = postgres ]; then needs_postgres=1; fi
done
if [ "$needs_postgres" = 1 ] && [ -z "${NEXTPOSE_TEST_POSTGRES:-}" ]; then
  exec bash "$repo/scripts/with-postgres.sh" bash "$0" "${wanted[@]}"
fi

work="$(mktemp -d)"
server=""
cleanup() {
  if [ -n "$server" ]; then kill "$server" 2> /dev/null || true; fi
  for wt in "$work"/old-*; do
    [ -d "$wt" ] && git -C "$repo" worktree remove --force "$wt" > /dev/null 2>&1 || true
  done
  rm -rf "$work"
}
trap cleanup EXIT

# The release's binary, built once per commit (and kept in the target directory).
binary() {
  local commit=$1 wt="$work/old-$1" bin="$target/upgrade-dumps/nextpose-$1"
  if [ ! -x "$bin" ]; then
    git -C "$repo" worktree add --detach "$wt" "$commit" > /dev/null 2>&1
    echo "upgrade-dumps: building $commit" >&2
    (cd "$wt" && CARGO_TARGET_DIR="$target" nice cargo build --locked --quiet --bin nextpose)
    mkdir -p "$target/upgrade-dumps"
    cp "$target/debug/nextpose" "$bin"
  fi
  echo "$bin"
}

port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

BOOTSTRAP="upgrade-dumps-bootstrap"
AUTH=""   # the bearer token of the next requests ("" for none)

# api METHOD PATH [BODY] [STATUS]: the request, failing unless answered STATUS (default 2xx);
# prints the body.
api() {
  local method=$1 path=$2 body=${3:-} want=${4:-2..}
  local args=(-sS -X "$method" -o "$work/body" -w '%{http_code}' "$B$path")
  if [ -n "$body" ]; then args+=(-H 'content-type: application/json' -d "$body"); fi
  if [ -n "$AUTH" ]; then args+=(-H "authorization: Bearer $AUTH"); fi
  local code
  code="$(curl "${args[@]}")"
  if ! [[ "$code" =~ ^$want$ ]]; then
    echo "upgrade-dumps: $method $path answered $code: $(cat "$work/body")" >&2
    exit 1
  fi
  cat "$work/body"
}

# A pose with the tool pointing down, turned by `yaw` degrees about z.
pose() {
  python3 -c 'import math, sys
x, y, z, yaw = map(float, sys.argv[1:5])
h = math.radians(yaw) / 2
print("{\"x\":%r,\"y\":%r,\"z\":%r,\"qw\":0,\"qx\":%r,\"qy\":%r,\"qz\":0}" % (x, y, z, -math.sin(h), math.cos(h)))' "$@"
}

# A seam of six waypoints at (ox, oy, oz), as the README's session teaches it.
seam() {
  local ox=$1 oy=$2 oz=$3
  for p in "0 0 100" "0 0 0" "120 0 0" "120 60 0" "0 60 0" "0 60 100"; do
    set -- $p
    pose "$((ox + $1))" "$((oy + $2))" "$((oz + $3))" 0
  done
}

# append ROUTINE POSE: the answer's prediction id (empty when withheld).
append() {
  api POST "/v1/routines/$1/waypoints" "{\"pose\":$2}" | jq -r '.prediction.id // empty'
}

# Generated programs, one per language, numbered k (the fixtures are the repository's too).
rapid_module() {
  local k=$1
  cat << EOF
MODULE Seam$k
    PERS tooldata tTorch:=[TRUE,[[0,0,200],[1,0,0,0]],[2,[0,0,100],[1,0,0,0],0,0,0]];
    CONST robtarget pStart:=[[$((300 + 10 * k)),-40,$((400 + k))],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pEnd:=[[$((420 + 10 * k)),-40,$((400 + k))],[0,0.258819,0.965926,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

    PROC weld_side()
        MoveJ Offs(pStart,0,0,80), v500, z50, tTorch;
        MoveL pStart, v100, fine, tTorch;
        MoveL Offs(pStart,60,0,0), v20, z1, tTorch;
        MoveL pEnd, v20, fine, tTorch;
        MoveL Offs(pEnd,0,0,80), v200, z10, tTorch;
    ENDPROC

    PROC weld_back()
        MoveL Offs(pEnd,0,50,80), v200, z10, tTorch;
        MoveL Offs(pEnd,0,50,0), v100, fine, tTorch;
        MoveL Offs(pStart,0,50,0), v20, fine, tTorch;
        MoveL Offs(pStart,0,50,80), v200, z10, tTorch;
    ENDPROC
ENDMODULE
EOF
}

krl_src() {
  cat << EOF
DEF weld$1( )
  PTP xHome
  LIN xP1
  LIN xP2 C_DIS
  LIN xP3
  CIRC xP4, xP5
  LIN xP6
END
EOF
}

krl_dat() {
  local k=$1
  cat << EOF
DEFDAT WELD$k
DECL E6POS xHome={X 600.0,Y 0.0,Z 700.0,A 0.0,B 90.0,C 0.0,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL E6POS xP1={X $((500 + 5 * k)).0,Y -100.0,Z 450.0,A 0.0,B 90.0,C 0.0,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL E6POS xP2={X $((500 + 5 * k)).0,Y -100.0,Z 400.0,A 0.0,B 90.0,C 0.0,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL E6POS xP3={X $((620 + 5 * k)).0,Y -100.0,Z 400.0,A 15.0,B 90.0,C 0.0,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL E6POS xP4={X $((660 + 5 * k)).0,Y -60.0,Z 400.0,A 30.0,B 90.0,C 0.0,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL E6POS xP5={X $((620 + 5 * k)).0,Y -20.0,Z 400.0,A 45.0,B 90.0,C 0.0,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
DECL E6POS xP6={X $((620 + 5 * k)).0,Y -20.0,Z 480.0,A 45.0,B 90.0,C 0.0,S 2,T 2,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}
ENDDAT
EOF
}

fanuc_listing() {
  local k=$1 name=$2 dy=$3
  cat << EOF
/PROG  $name
/ATTR
OWNER		= MNEDITOR;
/MN
   1:J P[1] 100% FINE    ;
   2:L P[2:approach] 500mm/sec CNT50    ;
   3:L P[3] 100mm/sec FINE    ;
   4:L P[4] 100mm/sec FINE    ;
   5:J P[1] 100% FINE    ;
/POS
P[1]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   $((400 + 10 * k)).000  mm,	Y =  $((dy)).000  mm,	Z =   500.000  mm,
	W =  180.000 deg,	P =     0.000 deg,	R =    0.000 deg
};
P[2:"approach"]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   $((400 + 10 * k)).000  mm,	Y =  $((dy)).000  mm,	Z =   420.000  mm,
	W =  180.000 deg,	P =     0.000 deg,	R =   30.000 deg
};
P[3]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   $((480 + 10 * k)).000  mm,	Y =  $((dy + 40)).500  mm,	Z =   400.000  mm,
	W =  180.000 deg,	P =    10.000 deg,	R =   30.000 deg
};
P[4]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   $((480 + 10 * k)).000  mm,	Y =  $((dy + 120)).250  mm,	Z =   400.000  mm,
	W =  180.000 deg,	P =    10.000 deg,	R =   60.000 deg
};
/END
EOF
}

# files NAME TEXT...: a JSON array of upload files from (name, text) pairs.
files() {
  local json="[]"
  while [ $# -gt 0 ]; do
    json="$(jq -c --arg n "$1" --arg t "$2" '. + [{name: $n, content: $t}]' <<< "$json")"
    shift 2
  done
  echo "$json"
}

# The teaching session every dump holds. $1: whether the release has tokens.
session() {
  local tokens=$1
  [ "$tokens" = 1 ] && AUTH=$BOOTSTRAP
  # Cell 1: an IRB 140 behind and below the work frame, flagging what it cannot reach; cell 2:
  # the seed's engine on a KR 16 with its own export settings; cell 3: an M-10iA; cell 4 is
  # deleted (ids are never reused).
  api POST /v1/cells '{"name":"weld-1","settings":{"robot":"abb_irb140","base":{"x":-450,"y":-100,"z":-250,"qw":1,"qx":0,"qy":0,"qz":0},"reach_policy":"flag"}}' > /dev/null
  api POST /v1/cells '{"name":"mill-2","settings":{"profile":"seed","robot":"kuka_kr16_2","reach_policy":"flag","export":{"speed_mm_s":250,"zone_mm":5,"work_object":"wobj3","tool":"tool2"}}}' > /dev/null
  api POST /v1/cells '{"name":"paint-3","settings":{"robot":"fanuc_m10ia","horizon":4,"offer_threshold":0.6,"reach_policy":"flag"}}' > /dev/null
  api POST /v1/cells '{"name":"scrap-4","settings":{}}' > /dev/null
  if [ "$tokens" = 1 ]; then
    # An operator of cell 1, an engineer and an admin of every cell, and a token revoked.
    OTTO="$(api POST /v1/tokens '{"name":"otto","role":"operator","cells":[1]}' | jq -r .secret)"
    ERIN="$(api POST /v1/tokens '{"name":"erin","role":"engineer"}' | jq -r .secret)"
    ADA="$(api POST /v1/tokens '{"name":"ada","role":"admin"}' | jq -r .secret)"
    GONE="$(api POST /v1/tokens '{"name":"gone","role":"operator","cells":[2]}' | jq -r .secret)"
    api DELETE /v1/tokens/gone > /dev/null
    AUTH=$ADA
  fi
  api DELETE /v1/cells/4 > /dev/null
  [ "$tokens" = 1 ] && AUTH=$ERIN

  # Imports: 15 programs, five per language (cell 1 learns its RAPID ones, cell 2 keeps its KRL
  # ones unlearned, cell 3 learns its FANUC folders).
  local up
  up="$(files Calibration.mod "$(cat "$repo/tests/fixtures/import/rapid/Calibration.mod")" \
    Seam1.mod "$(rapid_module 1)" Seam2.mod "$(rapid_module 2)" \
    Seam3.mod "$(rapid_module 3)" Seam4.mod "$(rapid_module 4)")"
  api POST /v1/cells/1/imports "{\"files\":$up,\"learn\":true}" > /dev/null
  up="$(files mill_pocket.src "$(cat "$repo/tests/fixtures/import/krl/mill_pocket.src")" \
    mill_pocket.dat "$(cat "$repo/tests/fixtures/import/krl/mill_pocket.dat")" \
    weld1.src "$(krl_src 1)" weld1.dat "$(krl_dat 1)" weld2.src "$(krl_src 2)" weld2.dat "$(krl_dat 2)" \
    weld3.src "$(krl_src 3)" weld3.dat "$(krl_dat 3)" weld4.src "$(krl_src 4)" weld4.dat "$(krl_dat 4)")"
  api POST /v1/cells/2/imports "{\"files\":$up,\"learn\":false}" > /dev/null
  local k args=()
  for k in 1 2 3 4 5; do
    args+=("job$k/main.ls" "$(fanuc_listing "$k" MAIN $((k * 20)))")
    args+=("job$k/side.ls" "$(fanuc_listing "$k" SIDE $((k * 20 - 200)))")
  done
  api POST /v1/cells/3/imports "{\"files\":$(files "${args[@]}"),\"learn\":true}" > /dev/null

  # Cell 1 taught by its operator: program "bracket" (id 16), two seams finished, with feedback
  # on the second's suggestions (accepted, adjusted, rejected) and an undo; then an engineer's
  # edits; then a third seam being taught, its suggestion for the fourth waypoint offered.
  api POST /v1/cells/1/programs '{"name":"bracket"}' > /dev/null
  [ "$tokens" = 1 ] && AUTH=$OTTO
  local r p w
  r="$(api POST /v1/programs/16/routines '{}' | jq -r .id)"
  while read -r w; do append "$r" "$w" > /dev/null; done < <(seam 0 0 0)
  api POST "/v1/routines/$r/finish" > /dev/null
  r="$(api POST /v1/programs/16/routines '{}' | jq -r .id)"
  mapfile -t w < <(seam 30 200 0)
  append "$r" "${w[0]}" > /dev/null
  append "$r" "${w[1]}" > /dev/null
  p="$(append "$r" "${w[2]}")"
  [ -n "$p" ] || { echo "upgrade-dumps: no suggestion after three waypoints" >&2; exit 1; }
  api POST "/v1/predictions/$p/feedback" '{"verdict":"accepted"}' > /dev/null
  p="$(append "$r" "${w[3]}")"
  [ -n "$p" ] || { echo "upgrade-dumps: no suggestion after four waypoints" >&2; exit 1; }
  api POST "/v1/predictions/$p/feedback" "{\"verdict\":\"adjusted\",\"pose\":$(pose 32 262 0 0)}" > /dev/null
  append "$r" "$(pose 32 262 0 0)" > /dev/null
  api DELETE "/v1/routines/$r/waypoints/last" > /dev/null
  p="$(append "$r" "${w[4]}")"
  [ -n "$p" ] && api POST "/v1/predictions/$p/feedback" '{"verdict":"rejected"}' > /dev/null
  append "$r" "${w[5]}" > /dev/null
  api POST "/v1/routines/$r/finish" > /dev/null
  # An engineer's edits: a waypoint of the first seam moved, the routine named, cell 1's
  # settings changed (the model is learned again).
  [ "$tokens" = 1 ] && AUTH=$ERIN
  local first
  first="$(api GET /v1/programs/16/routines | jq -r '.[0].id')"
  w="$(api GET "/v1/routines/$first" | jq -r '.waypoints[2].id')"
  api PATCH "/v1/waypoints/$w" "{\"pose\":$(pose 121 1 0 5)}" > /dev/null
  api PATCH "/v1/routines/$first" '{"name":"seam_a"}' > /dev/null
  api PATCH /v1/cells/1 '{"settings":{"tolerance":{"mm":2.5,"rad":0.05}}}' > /dev/null
  [ "$tokens" = 1 ] && AUTH=$OTTO
  r="$(api POST /v1/programs/16/routines '{}' | jq -r .id)"
  mapfile -t w < <(seam -40 -180 20)
  append "$r" "${w[0]}" > /dev/null
  append "$r" "${w[1]}" > /dev/null
  p="$(append "$r" "${w[2]}")"
  [ -n "$p" ] || { echo "upgrade-dumps: the routine being taught has no suggestion" >&2; exit 1; }

  # Cell 2 taught by the engineer: program "pocket" with one routine finished and one left
  # unfinished, and a routine started and deleted.
  [ "$tokens" = 1 ] && AUTH=$ERIN
  api POST /v1/cells/2/programs '{"name":"pocket"}' > /dev/null
  local pocket
  pocket="$(api GET /v1/cells/2/programs | jq -r '.[] | select(.name == "pocket") | .id')"
  r="$(api POST "/v1/programs/$pocket/routines" '{}' | jq -r .id)"
  while read -r w; do append "$r" "$w" > /dev/null; done < <(seam 400 0 300)
  api POST "/v1/routines/$r/finish" > /dev/null
  r="$(api POST "/v1/programs/$pocket/routines" '{}' | jq -r .id)"
  append "$r" "$(pose 500 300 400 0)" > /dev/null
  api DELETE "/v1/routines/$r" > /dev/null
  r="$(api POST "/v1/programs/$pocket/routines" '{"name":"unfinished"}' | jq -r .id)"
  mapfile -t w < <(seam 400 200 300)
  for k in 0 1 2 3; do append "$r" "${w[$k]}" > /dev/null; done
  AUTH=""
}

for r in "${releases[@]}"; do
  set -- $r
  name=$1 commit=$2 engine=$3
  want "$name" || continue
  mkdir -p "$out"
  bin="$(binary "$commit")"
  tokens=0
  if git -C "$repo" cat-file -e "$commit:migrations/sqlite/0009_tokens.sql" 2> /dev/null; then tokens=1; fi
  if [ "$engine" = sqlite ]; then
    db="$work/$name.db"
  else
    dbname="upgrade_${name//-/_}_$$"
    psql -q "$NEXTPOSE_TEST_POSTGRES" -c "CREATE DATABASE $dbname"
    db="${NEXTPOSE_TEST_POSTGRES%/*}/$dbname"
  fi
  p="$(port)"
  B="http://127.0.0.1:$p"
  # The release's own arm models (its binary looks for them in the worktree it was built in).
  mkdir -p "$work/robots-$commit"
  git -C "$repo" archive "$commit" robots | tar -x -C "$work/robots-$commit"
  flags=(serve --db "$db" --addr "127.0.0.1:$p" --robots "$work/robots-$commit/robots")
  if [ "$tokens" = 1 ]; then flags+=(--token "$BOOTSTRAP"); fi
  RUST_LOG=warn "$bin" "${flags[@]}" > "$work/$name.log" 2>&1 &
  server=$!
  for _ in $(seq 300); do
    curl -sf "$B/healthz" > /dev/null 2>&1 && break
    if ! kill -0 "$server" 2> /dev/null; then cat "$work/$name.log" >&2; exit 1; fi
    sleep 0.1
  done
  echo "upgrade-dumps: $name: teaching $commit's server" >&2
  session "$tokens"
  kill -TERM "$server"
  wait "$server" || true
  server=""
  if [ "$engine" = sqlite ]; then
    sqlite3 "$db" .dump > "$out/$name.sql"
  else
    pg_dump --inserts --no-owner --no-privileges "$db" | grep -v '^\\\(un\)\?restrict ' > "$out/$name.sql"
  fi
  echo "upgrade-dumps: wrote tests/upgrade/$name.sql ($(wc -c < "$out/$name.sql") bytes)" >&2
  if [ "$tokens" = 1 ]; then
    echo "// $name (tests/api/upgrade.rs)"
    for t in "otto:$OTTO" "erin:$ERIN" "ada:$ADA" "gone:$GONE"; do
      echo "(\"${t%%:*}\", \"${t#*:}\"),"
    done
  fi
done
