"""An independent red-light judge, as a user's Python client would be: reads
the map file, subscribes to a running cluster's vehicle batches and light
states, and flags every front bumper that goes 0.5 m past a stop line more
than 0.5 s after that lane's group turned red (the yellow time plus 0.5 s).

Light states come from the bus only: a yellow state's `next_change` is when
red begins, a red state's when it ends. Vehicle batches are read with
`struct` from the layout in docs/cluster.md.

Prints `crossings=N on_red=M reds=R seconds=T restarts=K` (K: times the
simulation time went back, a stepper that died and was restarted) and the
first red crossings, after SECONDS of simulated time.

usage: red_light_judge.py ENDPOINT CLUSTER MAP_JSON SECONDS
"""

import json
import math
import struct
import sys
import threading
import time

import zenoh

PAST_LINE = 0.5
GRACE = 0.5

HEADER = struct.Struct("<4sHHQdQI")
# id, lane, kind, mode, yield_phase, signal, flags, then s (the front's arc length).
RECORD_HEAD = struct.Struct("<QIHBBBBf")


def stop_marks(path):
    """Per signalised lane index: (group, arc length of the stop line + PAST_LINE, lane length)."""
    lanes = json.load(open(path))["lanes"]
    marks = {}
    for i, lane in enumerate(lanes):
        group, line = lane.get("traffic_light"), lane.get("stop_line")
        if not group or not line:
            continue
        pts = [(p[0], p[1]) for p in lane["waypoints"]]
        mid = ((line[0][0] + line[-1][0]) / 2, (line[0][1] + line[-1][1]) / 2)
        best, along, length = None, 0.0, 0.0
        for (ax, ay), (bx, by) in zip(pts, pts[1:]):
            seg = math.hypot(bx - ax, by - ay)
            t = 0.0 if seg == 0 else max(0.0, min(1.0, ((mid[0] - ax) * (bx - ax) + (mid[1] - ay) * (by - ay)) / seg**2))
            d = math.hypot(ax + t * (bx - ax) - mid[0], ay + t * (by - ay) - mid[1])
            if best is None or d < best[0]:
                best = (d, length + t * seg)
            length += seg
        marks[i] = (group, best[1] + PAST_LINE, length)
    return marks


def main():
    endpoint, cluster, map_path, seconds = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
    marks = stop_marks(map_path)
    lock = threading.Lock()
    coming_red = {}  # group -> when red begins, from its yellow state
    red_from = {}  # group -> when its current red began (None: before we joined)
    red_until = {}  # group -> when its current red ends
    reds = set()
    last = {}  # vehicle id -> (lane, s, time)
    state = {"crossings": 0, "on_red": [], "start": None, "now": None, "restarts": 0}

    def red_for(group, t):
        """Seconds `group` had been red at time t, or None when it was not red."""
        if group not in red_from or t >= red_until[group]:
            return None
        start = red_from[group]
        if start is None:  # red when we joined: counted from our first batch
            start = state["start"]
        return None if t < start else t - start

    def on_state(s):
        with lock:
            if s["color"] == "yellow" and s["next_change"] is not None:
                coming_red[s["group"]] = s["next_change"]
            elif s["color"] == "red" and s["next_change"] is not None:
                if red_until.get(s["group"]) == s["next_change"]:
                    return  # the same red again (a query's answer)
                red_from[s["group"]] = coming_red.pop(s["group"], None)
                red_until[s["group"]] = s["next_change"]
                reds.add((s["group"], s["next_change"]))

    def on_light(sample):
        on_state(json.loads(sample.payload.to_bytes()))

    def on_vehicles(sample):
        data = bytes(sample.payload.to_bytes())
        magic, version, record, _tick, t, _sent, count = HEADER.unpack_from(data, 0)
        if magic != b"TMVB":
            return
        with lock:
            if state["start"] is None:
                state["start"] = t
            elif t < state["now"]:
                # The stepper began again (it died and was restarted): a new run.
                state["restarts"] += 1
                last.clear()
            state["now"] = t
            for k in range(count):
                vid, lane, *_flags, s = RECORD_HEAD.unpack_from(data, HEADER.size + k * record)
                before = last.get(vid)
                last[vid] = (lane, s, t)
                if before is None or before[0] not in marks:
                    continue
                prev_lane, prev_s, prev_t = before
                group, mark, length = marks[prev_lane]
                if prev_s >= mark:
                    continue
                crossed = (lane == prev_lane and s >= mark) or (lane != prev_lane and length >= mark)
                if not crossed:
                    continue
                state["crossings"] += 1
                # It was still short of the mark at prev_t: it crossed after that.
                into_red = red_for(group, prev_t)
                if into_red is not None and into_red > GRACE:
                    state["on_red"].append(
                        f"vehicle {vid} lane {prev_lane} ({group}) between t={prev_t:.2f} and {t:.2f}, "
                        f"{into_red:.2f} s into red"
                    )

    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    with zenoh.open(conf) as session:
        subs = [
            session.declare_subscriber(f"{cluster}/lights/state/*", on_light),
            session.declare_subscriber(f"{cluster}/vehicles", on_vehicles),
        ]
        # The states in force when we joined (the lights service answers queries).
        for reply in session.get(f"{cluster}/lights/state/*", timeout=2.0):
            if reply.ok is not None:
                on_state(json.loads(reply.ok.payload.to_string()))
        deadline = time.monotonic() + seconds * 2 + 120
        while time.monotonic() < deadline:
            with lock:
                if state["start"] is not None and state["now"] - state["start"] >= seconds:
                    break
            time.sleep(0.2)
        for sub in subs:
            sub.undeclare()
    with lock:
        span = 0.0 if state["start"] is None else state["now"] - state["start"]
        print(
            f"crossings={state['crossings']} on_red={len(state['on_red'])} reds={len(reds)} "
            f"seconds={span:.1f} restarts={state['restarts']}"
        )
        for line in state["on_red"][:10]:
            print(line)


if __name__ == "__main__":
    main()
