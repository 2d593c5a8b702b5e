"""A late joiner, as a user's Python client would be: opens a Zenoh session to a
running cluster and asks for the current light states and crosswalk occupancy
(the services answer queries on the keys they publish on). Prints
`lights=N crosswalks=M seconds=T`, T counted from opening the session.

usage: late_joiner.py ENDPOINT CLUSTER
"""

import json
import sys
import time

import zenoh


def current(session, key, deadline):
    """Every state under `key`, asked for until one answers or the deadline."""
    while True:
        states = {}
        for reply in session.get(key, timeout=0.3):
            if reply.ok is not None:
                states[str(reply.ok.key_expr)] = json.loads(reply.ok.payload.to_string())
        if states or time.monotonic() >= deadline:
            return states
        time.sleep(0.05)


def main():
    endpoint, cluster = sys.argv[1], sys.argv[2]
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    start = time.monotonic()
    with zenoh.open(conf) as session:
        deadline = start + 5.0
        lights = current(session, f"{cluster}/lights/state/*", deadline)
        crosswalks = current(session, f"{cluster}/crosswalks/occupancy/*", deadline)
        elapsed = time.monotonic() - start
    colours = sorted(s["color"] for s in lights.values())
    print(f"lights={len(lights)} crosswalks={len(crosswalks)} seconds={elapsed:.2f} colours={','.join(colours)}")


if __name__ == "__main__":
    main()
