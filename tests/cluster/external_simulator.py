"""A client we did not write (eclipse-zenoh from PyPI) against a running cluster.

Usage: external_simulator.py ENDPOINT CLUSTER. Prints OK and exits 0 when:
- vehicle batches (binary, read with `struct` from the layout in docs/cluster.md) and
  light states arrive and decode;
- an external simulator's proposal is spawned (its result names a vehicle
  that the stepper's events report as spawned on that lane);
- when two external simulators propose on the same lane at once, the one
  with the higher priority spawns first.
"""
import json
import struct
import sys
import threading
import time

import zenoh

ENDPOINT, CLUSTER = sys.argv[1], sys.argv[2]
LANE = "J0_0_in_W0"
JSON = zenoh.Encoding.APPLICATION_JSON


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


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
RECORD = struct.Struct("<QIHBBBB10f")
FLOATS = ("s", "x", "y", "z", "yaw", "speed", "accel", "length", "width", "check_distance")
encodings = set()


def decode_batch(data):
    magic, version, record, tick, sim_time, sent_us, count = HEADER.unpack_from(data, 0)
    if magic != b"TMVB" or version != 1 or record < RECORD.size:
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
if encoding != {"application/octet-stream;trafficmesh.vehicles.v1"}:
    fail(f"vehicle batch encoding: {encoding}")
# Speed modes NORMAL..ABSOLUTE_STOP, kinds from the five-entry catalogue, a car-sized box.
if not (v["mode"] < 5 and v["kind"] < 5 and 2.0 < v["length"] < 12.0 and 1.0 < v["width"] < 3.0):
    fail(f"vehicle state out of range: {v}")

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
