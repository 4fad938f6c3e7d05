#!/usr/bin/env python3
"""REST scenario against the compose demo (docker/compose.yaml), run from the host by run.sh.

  scenario.py HTTP_PORT DATA_DIR

For every family: wait until its drive is online, enable, home where the family needs it, move
absolute, wait for the command to be DONE at the target. Then the audit rows of those moves must be
in the SQLite file of the gateway's mounted /data, and the hash chain must verify. Exit 0 only if
all of it holds; every failure names the drive and what was seen.
"""
import json
import sqlite3
import sys
import time
import urllib.error
import urllib.request

PORT = int(sys.argv[1])
DATA_DIR = sys.argv[2]
BASE = f"http://127.0.0.1:{PORT}"

# drive, needs home first, target mm, velocity mm/s, acceleration mm/s², position tolerance mm
MOVES = [
    ("x1", False, 50.0, 500.0, 5000.0, 0.01),        # LinMot LinUDP (0.1 µm units)
    ("d1", True, 40.0, 500.0, 5000.0, 0.05),         # LinMot DeviceNet over the CAN bus
    ("s1", False, 25.0, 100.0, 1000.0, 0.001),       # STOBER CANopen (0.001 u)
    ("feeder-x", False, 10.0, 20.0, 100.0, 1 / 640),  # Trinamic over CAN, one microstep
]


def call(method, path, body=None, timeout=10):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(BASE + path, data=data, method=method,
                                 headers={"Content-Type": "application/json"})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, json.loads(r.read() or b"{}")
    except urllib.error.HTTPError as e:
        return e.code, e.read().decode(errors="replace")


def wait_for(drive, what, pred, seconds=30):
    deadline = time.monotonic() + seconds
    last = None
    while time.monotonic() < deadline:
        code, body = call("GET", f"/v1/drives/{drive}")
        if code == 200:
            last = body
            if pred(body.get("status", {})):
                return body
        else:
            last = (code, body)
        time.sleep(0.1)
    sys.exit(f"scenario: {drive}: not {what} within {seconds} s; last seen {last}")


def expect_ok(drive, verb, code, body):
    if code != 200:
        sys.exit(f"scenario: {drive}:{verb} answered {code}: {body}")


def main():
    code, body = call("GET", "/v1/drives")
    if code != 200:
        sys.exit(f"scenario: GET /v1/drives answered {code}: {body}")
    names = sorted(d["name"] for d in body.get("drives", []))
    print(f"scenario: drives {names}")
    for drive, home, target, vel, acc, tol in MOVES:
        t0 = time.monotonic()
        wait_for(drive, "online", lambda s: s.get("state") not in (None, "OFFLINE", "DRIVE_STATE_UNSPECIFIED"))
        expect_ok(drive, "enable", *call("POST", f"/v1/drives/{drive}:enable", {}))
        if home:
            expect_ok(drive, "home", *call("POST", f"/v1/drives/{drive}:home", {}))
            wait_for(drive, "homed", lambda s: s.get("homed") is True)
        code, body = call("POST", f"/v1/drives/{drive}:moveAbsolute",
                          {"position_mm": target, "velocity_mm_s": vel, "acceleration_mm_s2": acc})
        expect_ok(drive, "moveAbsolute", code, body)
        done = wait_for(drive, "DONE at the target", lambda s: s.get("last_command", {}).get("kind") == "MoveAbsolute"
                        and s.get("last_command", {}).get("state") == "DONE")
        pos = done["status"].get("position_mm", 0.0)
        if abs(pos - target) > tol:
            sys.exit(f"scenario: {drive}: DONE at {pos} mm, target {target} ± {tol} mm")
        print(f"scenario: {drive}: moved to {pos:.4f} mm in {time.monotonic() - t0:.1f} s")

    code, body = call("POST", "/v1/auditLog:verify", {})
    if code != 200 or body.get("ok") is not True:
        sys.exit(f"scenario: audit chain does not verify: {code} {body}")

    # The gateway's database in the mounted directory; read-only, while the gateway runs (WAL).
    db = sqlite3.connect(f"file:{DATA_DIR}/drivegw.db?mode=ro", uri=True)
    rows = db.execute("SELECT drive, result_code FROM audit_log WHERE action = 'MoveAbsolute'").fetchall()
    db.close()
    moved = {d for d, _ in rows}
    for drive, *_ in MOVES:
        if drive not in moved:
            sys.exit(f"scenario: no MoveAbsolute audit row for {drive} in {DATA_DIR}/drivegw.db (rows: {rows})")
    print(f"scenario: {len(rows)} MoveAbsolute audit rows in the mounted database, chain verified")


if __name__ == "__main__":
    main()
