"""Compares trafficmesh's import of a SUMO network with what sumolib (SUMO's
own Python reader, from PyPI) reads from the same file.

Usage: check_sumo_import.py NET_XML IMPORTED_MAP_JSON. Prints OK and exits 0 when
lane count, every lane's length and the count of connections between normal
lanes (U-turns aside, which the import leaves out) agree, and every pedestrian
crossing is a crosswalk covering the crossing's lane with stop points.
"""
import json
import math
import sys

import sumolib

NET, MAP = sys.argv[1], sys.argv[2]


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


net = sumolib.net.readNet(NET, withInternal=True)
ours = json.load(open(MAP))
lanes = {l["name"]: l for l in ours["lanes"]}

theirs = [l for e in net.getEdges(withInternal=True) for l in e.getLanes() if l.allows("passenger")]
if len(theirs) != len(lanes):
    fail(f"lane count: sumolib {len(theirs)}, trafficmesh {len(lanes)}")


def polyline_length(points):
    return sum(math.dist(a[:2], b[:2]) for a, b in zip(points, points[1:]))


for l in theirs:
    mine = lanes.get(l.getID())
    if mine is None:
        fail(f"lane {l.getID()} missing")
    length = polyline_length(mine["waypoints"])
    # SUMO's zero-length internal lanes are stretched to 0.15 m by the import.
    if abs(length - l.getLength()) > max(0.06, 0.01 * l.getLength()):
        fail(f"lane {l.getID()}: length {length:.3f} m, sumolib {l.getLength():.3f} m")

expected = 0
for e in net.getEdges(withInternal=False):
    for l in e.getLanes():
        for c in l.getOutgoing():
            if c.getDirection() != "t" and l.allows("passenger") and c.getToLane().allows("passenger"):
                expected += 1


def normal_successors(name, seen=()):
    out = set()
    for n in lanes[name]["next"]:
        if lanes[n]["intersection"] and n not in seen:
            out |= normal_successors(n, seen + (n,))
        elif not lanes[n]["intersection"]:
            out.add(n)
    return out


found = sum(len(normal_successors(n)) for n, l in lanes.items() if not l["intersection"])
if found != expected:
    fail(f"connections between normal lanes: sumolib {expected}, trafficmesh {found}")

crossings = [e for e in net.getEdges(withInternal=True) if e.getFunction() == "crossing"]
areas = {c["name"]: c for c in ours["crosswalks"]}
if len(crossings) != len(areas):
    fail(f"crossings: sumolib {len(crossings)}, trafficmesh crosswalks {len(areas)}")


def inside(polygon, p):
    c = False
    for a, b in zip(polygon, polygon[-1:] + polygon[:-1]):
        if (a[1] > p[1]) != (b[1] > p[1]) and p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]:
            c = not c
    return c


for e in crossings:
    area = areas.get(e.getID())
    if area is None:
        fail(f"crossing {e.getID()} missing")
    lane = e.getLanes()[0]
    shape = lane.getShape()
    mid = ((shape[0][0] + shape[-1][0]) / 2, (shape[0][1] + shape[-1][1]) / 2)
    if area["area"]["shape"] != "polygon" or not inside(area["area"]["points"], mid):
        fail(f"crossing {e.getID()}: area does not cover its centre {mid}")
    if not area["stop_points"]:
        fail(f"crossing {e.getID()}: no stop points")
print(f"OK: {len(lanes)} lanes, {found} connections, {len(crossings)} crossings")
