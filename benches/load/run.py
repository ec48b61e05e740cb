#!/usr/bin/env python3
"""One round of benches/load.sh: a fresh server on DB, CELLS cells taught like a site teaches
them, and oha appending waypoints.

Each cell learns one seam first and then takes appends in phases: a phase appends about ROUTINE
waypoints to each cell's open routine (oha, URLs drawn at random from the cells' routines,
bodies taken in turn from a list of seam poses), then every routine is deleted and a new one
opened. So routines stay as long as taught ones are and every cell's model stays the same size
(one learned seam and the routine being taught) whatever the number of cells: the rounds
compare the service and its storage, not models grown to thousands of routines (the engine's
cost at size is `cargo bench --bench engine`). Only the appends are timed; throughput is the
appends over the time oha ran.

    run.py --bin B --oha O --db DB --cells N --mode closed|open --seconds S [--rate R]
           [--routine 50] [--out DIR]

closed: as many connections as cells, each sending its next request when the last is answered
(saturation). open: RATE requests/s over 64 connections (oha -q --latency-correction: a request
is timed from when it was due, so a stall counts for every request held up behind it).
Prints one markdown row: appends/s, p50, p99, max, errors / requests.
"""
import argparse
import json
import os
import re
import sqlite3
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

SEAM = [(0, 0, 100), (0, 0, 0), (120, 0, 0), (120, 60, 0), (0, 60, 0), (0, 60, 100)]
# The IRB 140 (the default arm) 450 mm behind and 100 mm beside the work origin, 250 mm below.
SETTINGS = {"base": {"x": -450, "y": -100, "z": -250, "qw": 1, "qx": 0, "qy": 0, "qz": 0}}

ap = argparse.ArgumentParser()
ap.add_argument("--bin", required=True)
ap.add_argument("--oha", required=True)
ap.add_argument("--db", required=True)
ap.add_argument("--cells", type=int, required=True)
ap.add_argument("--mode", choices=["closed", "open"], required=True)
ap.add_argument("--seconds", type=float, default=20)
ap.add_argument("--rate", type=int, default=1000)
ap.add_argument("--routine", type=int, default=50)
ap.add_argument("--out", default=None)
args = ap.parse_args()


def pose(x, y, z):
    return {"pose": {"x": x, "y": y, "z": z, "qw": 0, "qx": 0, "qy": 1, "qz": 0}}


def main():
    tmp = tempfile.mkdtemp(prefix="nextpose-load-")
    server = subprocess.Popen(
        [args.bin, "serve", "--addr", "127.0.0.1:0", "--db", args.db],
        stdout=subprocess.PIPE, stderr=open(os.path.join(tmp, "server.err"), "w"),
        env={**os.environ, "RUST_LOG": "warn"}, text=True)
    try:
        line = server.stdout.readline()
        m = re.search(r"http://[0-9.:]+", line)
        if not m:
            sys.exit(f"load: the server did not start: {line!r}")
        row = run(m.group(0), tmp)
    finally:
        server.terminate()
        server.wait()
    print(row)


def post(base, path, body):
    req = urllib.request.Request(base + path, data=json.dumps(body).encode(), method="POST",
                                 headers={"content-type": "application/json"})
    try:
        with urllib.request.urlopen(req) as r:
            return json.load(r)
    except urllib.error.HTTPError as e:
        sys.exit(f"load: POST {path}: {e.code} {e.read().decode(errors='replace')}")


def delete(base, path):
    req = urllib.request.Request(base + path, method="DELETE")
    try:
        with urllib.request.urlopen(req) as r:
            r.read()
    except urllib.error.HTTPError as e:
        sys.exit(f"load: DELETE {path}: {e.code} {e.read().decode(errors='replace')}")


def run(base, tmp):
    programs = []
    for c in range(args.cells):
        cell = post(base, "/v1/cells", {"name": f"load-{c}", "settings": SETTINGS})["id"]
        program = post(base, f"/v1/cells/{cell}/programs", {"name": "bracket"})["id"]
        first = post(base, f"/v1/programs/{program}/routines", {})["id"]
        for p in SEAM:
            post(base, f"/v1/routines/{first}/waypoints", pose(*p))
        post(base, f"/v1/routines/{first}/finish", {})
        programs.append(program)

    # The seam at 16 places on a 4 x 4 grid 100 mm apart, all within the arm's reach.
    bodies = os.path.join(tmp, "bodies")
    with open(bodies, "w") as f:
        for i in range(16):
            dx, dy = 100 * (i % 4) - 200, 100 * (i // 4) - 100
            for (x, y, z) in SEAM:
                f.write(json.dumps(pose(x + dx, y + dy, z)) + "\n")

    results = os.path.join(tmp, "requests.db")
    per_phase = args.cells * args.routine
    timed = 0.0
    sent = errors = 0
    while timed < args.seconds:
        routines = [post(base, f"/v1/programs/{p}/routines", {})["id"] for p in programs]
        urls = os.path.join(tmp, "urls")
        with open(urls, "w") as f:
            f.write("".join(f"{base}/v1/routines/{r}/waypoints\n" for r in routines))
        cmd = [args.oha, "--no-tui", "--output-format", "json", "-n", str(per_phase),
               "-m", "POST", "-T", "application/json", "-Z", bodies,
               "--db-url", results, "--urls-from-file", urls]
        if args.mode == "closed":
            cmd += ["-c", str(args.cells)]
        else:
            cmd += ["-c", "64", "-q", str(args.rate), "--latency-correction"]
        report = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
        timed += report["summary"]["total"]
        codes = report.get("statusCodeDistribution", {})
        ok = sum(v for k, v in codes.items() if k.startswith("2"))
        errors += per_phase - ok
        sent += per_phase
        for r in routines:
            delete(base, f"/v1/routines/{r}")

    db = sqlite3.connect(results)
    lat = sorted(end - (corr if corr is not None else start)
                 for start, corr, end in db.execute(
                     "SELECT start, start_latency_correction, end FROM oha"))
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, f"{args.mode}-{args.cells}.json"), "w") as f:
            json.dump({"cells": args.cells, "mode": args.mode, "seconds": timed,
                       "requests": sent, "errors": errors, "latencies_s": lat}, f)

    def pct(q):
        return lat[min(len(lat) - 1, int(q * len(lat)))] * 1000

    return "| %d | %s | %s | %.2f ms | %.2f ms | %.2f ms | %d / %d |" % (
        args.cells, args.mode, format(int(round((sent - errors) / timed)), ","),
        pct(0.5), pct(0.99), lat[-1] * 1000, errors, sent)


main()
