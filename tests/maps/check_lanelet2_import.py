"""Checks trafficmesh's import of a Lanelet2 map against the file itself, read
here with Python's ElementTree (not trafficmesh's reader).

Usage: check_lanelet2_import.py MAP_OSM IMPORTED_MAP_JSON. Prints OK and exits 0
when every car lanelet is a lane named ll_<id>, and a two-way one (one_way=no)
also ll_<id>_r for the other way; bounds are oriented as Lanelet2 does (the
left bound so that the right one lies on its right, then the right bound so
that the left one lies on its left); every lane whose bounds end on the nodes
where another lane's bounds start has exactly those successors (and a lane
opening from, or closing to, one node is joined where its point lies);
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


def xy(n):
    # Metres on a local plane: a degree of longitude shrinks with cos(latitude).
    lat, lon = nodes[n]
    return (111_195.0 * lon * math.cos(math.radians(lat)), 111_195.0 * lat)


def middle(line):
    if len(line) > 2:
        return xy(line[len(line) // 2])
    (ax, ay), (bx, by) = xy(line[0]), xy(line[-1])
    return ((ax + bx) / 2, (ay + by) / 2)


def side(line, p):
    """Positive when p lies left of the polyline (by its nearest segment)."""
    best = None
    for a, b in zip(line, line[1:]):
        (ax, ay), (bx, by) = xy(a), xy(b)
        dx, dy, qx, qy = bx - ax, by - ay, p[0] - ax, p[1] - ay
        t = max(0.0, min(1.0, (qx * dx + qy * dy) / max(dx * dx + dy * dy, 1e-12)))
        d = math.hypot(qx - t * dx, qy - t * dy)
        if best is None or d < best[0]:
            best = (d, dx * qy - dy * qx)
    return best[1]


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
    if side(left, middle(right)) >= 0:
        left = left[::-1]
    if side(right, middle(left)) <= 0:
        right = right[::-1]
    lanelets[f"ll_{rid}"] = ((left[0], right[0]), (left[-1], right[-1]), members)
    if tags.get("one_way") == "no":
        lanelets[f"ll_{rid}_r"] = ((right[-1], left[-1]), (right[0], left[0]), members)

ours = json.load(open(MAP))
lanes = {l["name"]: l for l in ours["lanes"]}
if set(lanes) != set(lanelets):
    fail(f"lanes {len(lanes)} vs car lanelet ways {len(lanelets)}: "
         f"{sorted(set(lanes) ^ set(lanelets))[:5]}")

# A lane opening from a point (both bounds start at one node) follows the
# lanelets whose bounds end on that node; one closing to a point leads into
# those whose bounds start there.
led_into = {o for _, (_, end, _) in lanelets.items() for o, (s, _, _) in lanelets.items() if s == end}
openings = {o: s[0] for o, (s, _, _) in lanelets.items() if s[0] == s[1] and o not in led_into}


def base(name):
    return name.removesuffix("_r")


checked = 0
for name, (start, end, _) in lanelets.items():
    expected = {o for o, (s, _, _) in lanelets.items() if s == end and o != name}
    if not expected and end[0] == end[1]:
        expected = {o for o, (s, _, _) in lanelets.items() if end[0] in s and base(o) != base(name)}
    expected |= {o for o, tip in openings.items() if tip in end and base(o) != base(name)}
    if not expected:
        continue
    got = set(lanes[name]["next"])
    if got != expected:
        fail(f"lane {name}: successors {sorted(got)}, expected {sorted(expected)}")
    checked += 1

groups = {g["name"] for g in ours["light_groups"]}
for name, (_, _, members) in lanelets.items():
    two_way = name.endswith("_r") or f"{name}_r" in lanelets
    for reg in role(members, "regulatory_element"):
        if rels.get(reg, ({}, []))[0].get("subtype") == "traffic_light":
            if f"tl_{reg}" not in groups:
                fail(f"traffic light {reg} of lane {name} is not a light group")
            # On a two-way lanelet the light is for one of its ways.
            if not two_way and lanes[name].get("traffic_light") is None:
                fail(f"lane {name} lost its traffic light")
if not groups:
    fail("no light groups")
if {c["name"] for c in ours["crosswalks"]} != {f"cw_{c}" for c in crosswalks}:
    fail(f"crosswalks: {len(ours['crosswalks'])} vs {len(crosswalks)} crosswalk lanelets")
print(f"OK: {len(lanes)} lanes, {checked} successor sets, {len(groups)} light groups, {len(crosswalks)} crosswalks")
