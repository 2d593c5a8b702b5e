"""Checks trafficmesh's import of a Lanelet2 map against the file itself, read
here with Python's ElementTree (not trafficmesh's reader).

Usage: check_lanelet2_import.py MAP_OSM IMPORTED_MAP_JSON. Prints OK and exits 0
when every car lanelet is a lane named ll_<id>; every lanelet whose bounds end
on the nodes where another lanelet's bounds start has exactly those successors;
every traffic-light element referred to by a car lanelet is a light group on
those lanes; and every crosswalk lanelet is a crosswalk area.
"""
import json
import math
import sys
import xml.etree.ElementTree as ET

OSM, MAP = sys.argv[1], sys.argv[2]
CARS = {"road", "highway", "play_street", "emergency_lane", "bus_lane"}


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


root = ET.parse(OSM).getroot()
ways = {w.get("id"): [nd.get("ref") for nd in w.findall("nd")] for w in root.findall("way")}
rels = {}
for r in root.findall("relation"):
    tags = {t.get("k"): t.get("v") for t in r.findall("tag")}
    members = [(m.get("type"), m.get("role"), m.get("ref")) for m in r.findall("member")]
    rels[r.get("id")] = (tags, members)
nodes = {}
for n in root.findall("node"):
    nodes[n.get("id")] = (float(n.get("lat")), float(n.get("lon")))


def role(members, name):
    return [ref for t, r, ref in members if r == name]


def close(a, b):
    # Metres on a local plane: a degree of longitude shrinks with cos(latitude).
    k = math.cos(math.radians(a[0]))
    return 111_195.0 * math.hypot(a[0] - b[0], k * (a[1] - b[1]))


lanelets = {}
crosswalks = set()
for rid, (tags, members) in rels.items():
    if tags.get("type") != "lanelet":
        continue
    sub = tags.get("subtype", "road")
    if sub == "crosswalk":
        crosswalks.add(rid)
    if sub not in CARS:
        continue
    left, right = ways[role(members, "left")[0]], ways[role(members, "right")[0]]
    # The right bound may be drawn against the driving direction.
    a = close(nodes[left[0]], nodes[right[0]]) + close(nodes[left[-1]], nodes[right[-1]])
    b = close(nodes[left[0]], nodes[right[-1]]) + close(nodes[left[-1]], nodes[right[0]])
    if a > b:
        right = right[::-1]
    lanelets[rid] = ((left[0], right[0]), (left[-1], right[-1]), members)

ours = json.load(open(MAP))
lanes = {l["name"]: l for l in ours["lanes"]}
if set(lanes) != {f"ll_{i}" for i in lanelets}:
    fail(f"lanes {len(lanes)} vs car lanelets {len(lanelets)}: "
         f"{sorted(set(lanes) ^ {f'll_{i}' for i in lanelets})[:5]}")

checked = 0
for rid, (start, end, _) in lanelets.items():
    expected = {f"ll_{o}" for o, (s, _, _) in lanelets.items() if s == end and o != rid}
    if not expected:
        continue
    got = set(lanes[f"ll_{rid}"]["next"])
    if got != expected:
        fail(f"lanelet {rid}: successors {sorted(got)}, expected {sorted(expected)}")
    checked += 1

groups = {g["name"] for g in ours["light_groups"]}
for rid, (_, _, members) in lanelets.items():
    for reg in role(members, "regulatory_element"):
        if rels.get(reg, ({}, []))[0].get("subtype") == "traffic_light":
            if f"tl_{reg}" not in groups:
                fail(f"traffic light {reg} of lanelet {rid} is not a light group")
            if lanes[f"ll_{rid}"].get("traffic_light") is None:
                fail(f"lanelet {rid} lost its traffic light")
if not groups:
    fail("no light groups")
if {c["name"] for c in ours["crosswalks"]} != {f"cw_{c}" for c in crosswalks}:
    fail(f"crosswalks: {len(ours['crosswalks'])} vs {len(crosswalks)} crosswalk lanelets")
print(f"OK: {len(lanes)} lanes, {checked} successor sets, {len(groups)} light groups, {len(crosswalks)} crosswalks")
