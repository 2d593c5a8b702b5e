"""A client we did not write (eclipse-zenoh from PyPI) against a running cluster.

Usage: external_simulator.py ENDPOINT CLUSTER MAP_JSON. Prints OK and exits 0 when:
- vehicle batches (binary, read with `struct` from the layout in docs/cluster.md) and
  light states arrive and decode;
- every vehicle's box, drawn from the batch alone (position, yaw, size and front
  offset), lies on its lane of the map file;
- from batch to batch no vehicle moves further than its speed allows;
- an external simulator's proposal is spawned (its result names a vehicle
  that the stepper's events report as spawned on that lane);
- when two external simulators propose on the same lane at once, the one
  with the higher priority spawns first.
"""
import json
import math
import os
import struct
import sys
import threading
import time
import traceback

import zenoh

ENDPOINT, CLUSTER, MAP = sys.argv[1], sys.argv[2], sys.argv[3]
LANE = "J0_0_in_W0"
JSON = zenoh.Encoding.APPLICATION_JSON


def fail(msg):
    print("FAIL:", msg, flush=True)
    # At once: an open Zenoh session's threads would keep the process alive.
    os._exit(1)


def on_uncaught(kind, value, tb):
    traceback.print_exception(kind, value, tb)
    fail(f"uncaught {kind.__name__}: {value}")


sys.excepthook = on_uncaught


conf = zenoh.Config()
conf.insert_json5("mode", '"peer"')
conf.insert_json5("scouting/multicast/enabled", "false")
conf.insert_json5("connect/endpoints", json.dumps([ENDPOINT]))
conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
session = zenoh.open(conf)

lock = threading.Lock()
batches, lights, spawned_on, results = [], {}, {}, []


# The binary vehicle batch, read from the layout in docs/cluster.md with `struct`.
HEADER = struct.Struct("<4sHHQdQI")
RECORD = struct.Struct("<QIHBBBB11f")
FLOATS = ("s", "x", "y", "z", "yaw", "speed", "accel", "length", "width", "check_distance", "front_offset")
encodings = set()


def decode_batch(data):
    magic, version, record, tick, sim_time, sent_us, count = HEADER.unpack_from(data, 0)
    if magic != b"TMVB" or version != 2 or record < RECORD.size:
        fail(f"vehicle batch header: {magic!r} version {version} record {record}")
    if len(data) != HEADER.size + count * record:
        fail(f"vehicle batch of {count} vehicles is {len(data)} bytes")
    vehicles = []
    for i in range(count):
        fields = RECORD.unpack_from(data, HEADER.size + i * record)
        v = dict(zip(("id", "lane", "kind", "mode", "yield_phase", "signal", "flags"), fields[:7]))
        v.update(zip(FLOATS, fields[7:]))
        vehicles.append(v)
    return {"tick": tick, "time": sim_time, "vehicles": vehicles}


def on_vehicles(sample):
    batch = decode_batch(bytes(sample.payload.to_bytes()))
    with lock:
        encodings.add(str(sample.encoding))
        batches.append(batch)


def on_light(sample):
    state = json.loads(sample.payload.to_bytes())
    with lock:
        lights[state["group"]] = state["color"]


def on_events(sample):
    for e in json.loads(sample.payload.to_bytes())["events"]:
        if e["type"] == "spawned":
            with lock:
                spawned_on[e["id"]] = e["lane"]


def on_result(name):
    def callback(sample):
        r = json.loads(sample.payload.to_bytes())
        with lock:
            results.append((name, r["tag"], r["id"]))
    return callback


subs = [
    session.declare_subscriber(f"{CLUSTER}/vehicles", on_vehicles),
    session.declare_subscriber(f"{CLUSTER}/lights/state/*", on_light),
    session.declare_subscriber(f"{CLUSTER}/events", on_events),
    session.declare_subscriber(f"{CLUSTER}/simulators/py_low/results", on_result("py_low")),
    session.declare_subscriber(f"{CLUSTER}/simulators/py_high/results", on_result("py_high")),
]


def wait(what, cond, timeout=30.0):
    deadline = time.time() + timeout
    while time.time() < deadline:
        with lock:
            if cond():
                return
        time.sleep(0.05)
    fail("timed out waiting for " + what)


# Vehicle batches decode and carry the documented fields.
wait("a vehicle batch with vehicles", lambda: any(b["vehicles"] for b in batches))
with lock:
    v = next(b for b in batches if b["vehicles"])["vehicles"][0]
    encoding = set(encodings)
if encoding != {"application/octet-stream;trafficmesh.vehicles.v2"}:
    fail(f"vehicle batch encoding: {encoding}")
# Speed modes NORMAL..ABSOLUTE_STOP, kinds from the five-entry catalogue, a car-sized box.
if not (v["mode"] < 5 and v["kind"] < 5 and 2.0 < v["length"] < 12.0 and 1.0 < v["width"] < 3.0):
    fail(f"vehicle state out of range: {v}")



def project(p, points):
    """(distance from p to the polyline, arc length of the nearest point on it)."""
    best, along, start = (float("inf"), 0.0), 0.0, 0.0
    for (ax, ay, *_), (bx, by, *_) in zip(points, points[1:]):
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        t = max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / (length * length or 1.0)))
        d = math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy)
        if d < best[0]:
            best = (d, start + t * length)
        start += length
    return best


def distance_to_polyline(p, points):
    return project(p, points)[0]


# Every box, drawn from the batch alone, lies on its lane: (x, y) is the rear
# axle, the front bumper `front_offset` ahead along the yaw, the box's centre
# `front_offset - length / 2` ahead. Lane ids index the map file's lanes. The
# front bumper lies on the vehicle's lane, the centre on it or on the lane
# before it (a vehicle just past a lane's start).
with open(MAP) as f:
    lanes = json.load(f)["lanes"]
by_name = {lane["name"]: lane for lane in lanes}
before = {lane["name"]: [] for lane in lanes}
for lane in lanes:
    for n in lane["next"]:
        before[n].append(lane["name"])
wait("a vehicle batch with five vehicles", lambda: any(len(b["vehicles"]) >= 5 for b in batches), 60)
with lock:
    batch = next(b for b in reversed(batches) if len(b["vehicles"]) >= 5)
for v in batch["vehicles"]:
    lane = lanes[v["lane"]]
    if not 0.0 < v["front_offset"] <= v["length"]:
        fail(f"front offset {v['front_offset']} of a {v['length']} m box: {v}")
    c, s = math.cos(v["yaw"]), math.sin(v["yaw"])
    ahead = v["front_offset"] - v["length"] / 2
    centre = (v["x"] + c * ahead, v["y"] + s * ahead)
    front = (v["x"] + c * v["front_offset"], v["y"] + s * v["front_offset"])
    room = lane.get("width", 3.5) / 2
    off, along = project(front, lane["waypoints"])
    if off > room:
        fail(f"vehicle {v['id']}'s front bumper {front} is off its lane {lane['name']}")
    # `s` is the front bumper's arc length on the lane: the drawn bumper is there.
    if abs(along - v["s"]) > 0.3:
        fail(f"vehicle {v['id']}'s front bumper is drawn at {along:.2f} m along {lane['name']}, not at s={v['s']:.2f}")
    near = min(
        distance_to_polyline(centre, by_name[name]["waypoints"])
        for name in [lane["name"], *before[lane["name"]]]
    )
    if near > room:
        fail(f"vehicle {v['id']}'s box centre {centre} is {near:.2f} m off its lane {lane['name']}")

# Motion is continuous, judged from the batches alone: from one batch to the
# next, no vehicle's origin moves further than its speed allows over the time
# between them (+ 5 cm, as `sim --check` bounds it).
wait("a hundred vehicle batches", lambda: len(batches) >= 100, 30)
with lock:
    seen = list(batches)
steps = 0
for a, b in zip(seen, seen[1:]):
    dt = b["time"] - a["time"]
    if dt <= 0:
        continue
    was = {v["id"]: v for v in a["vehicles"]}
    for v in b["vehicles"]:
        u = was.get(v["id"])
        if u is None:
            continue
        moved = math.hypot(v["x"] - u["x"], v["y"] - u["y"])
        bound = max(u["speed"], v["speed"]) * dt + 0.05
        if moved > bound:
            fail(f"vehicle {v['id']} jumped {moved:.3f} m in {dt:.3f} s at {v['speed']:.2f} m/s (bound {bound:.3f})")
        steps += 1
if steps < 100:
    fail(f"only {steps} vehicle steps seen between batches")

# Light states: the current ones by query, changes by subscription.
for reply in session.get(f"{CLUSTER}/lights/state/*"):
    state = json.loads(reply.ok.payload.to_bytes())
    with lock:
        lights[state["group"]] = state["color"]
with lock:
    if set(lights) != {"J0_0_NS", "J0_0_EW"} or not set(lights.values()) <= {"green", "yellow", "red"}:
        fail(f"light states: {lights}")

# One spawn every 5 s on the test lane, so two proposals made inside one
# interval compete when it ends.
config = {"spawnRates": [{"lane": LANE, "spawnsPerMinute": 12}], "branchWeights": []}
for reply in session.get(f"{CLUSTER}/spawner/config/set", payload=json.dumps(config), encoding=JSON):
    if reply.err is not None:
        fail("spawn config refused: " + reply.err.payload.to_bytes().decode())


def propose(name, priority, tag):
    batch = {"priority": priority, "proposals": [{"tag": tag, "lane": LANE, "kind": "Taxi"}]}
    session.put(f"{CLUSTER}/simulators/{name}/proposals", json.dumps(batch), encoding=JSON)


propose("py_low", 0, "low-1")
wait("low-1 spawned", lambda: any(t == "low-1" for _, t, _ in results), 40)
with lock:
    low_id = next(i for _, t, i in results if t == "low-1")
wait("the spawned event of low-1", lambda: low_id in spawned_on)
if spawned_on[low_id] != LANE:
    fail(f"low-1 spawned on {spawned_on[low_id]}")
# ... and drives in the telemetry, decoded from the binary batch.
wait("low-1 in a vehicle batch", lambda: any(v["id"] == low_id for v in batches[-1]["vehicles"]))

# Both propose inside the rate-limit window; the higher priority goes first.
propose("py_high", 100, "high-1")
propose("py_low", 0, "low-2")
wait("both spawned", lambda: {t for _, t, _ in results} >= {"high-1", "low-2"}, 60)
with lock:
    order = [t for _, t, _ in results]
if order.index("high-1") > order.index("low-2"):
    fail(f"lower priority spawned first: {order}")

session.close()
print("OK")
