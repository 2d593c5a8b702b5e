"""deploy/container against the rest of deploy/: compose.yaml runs the same
processes with the same flags as the systemd units (cluster.env's settings
filled in as the image places its files), from the image of the
Containerfile, whose files all exist. Prints OK.

usage: check_container.py <repository root> <directory of the built binaries>
"""

import os
import re
import shlex
import sys

import yaml

root, bins = sys.argv[1], sys.argv[2]
deploy = os.path.join(root, "deploy")
here = os.path.join(deploy, "container")

with open(os.path.join(here, "compose.yaml")) as f:
    compose = yaml.safe_load(f)


def env_file(path):
    out = {}
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#"):
                key, value = line.split("=", 1)
                out[key] = value
    return out


cluster = env_file(os.path.join(deploy, "cluster.env"))
# Where the image puts what cluster.env names on a host; the admin listens on
# every interface inside its container (the host publishes it on loopback).
placed = dict(cluster)
placed.update({
    "TRAFFICMESH_MAP": "/etc/trafficmesh/map.json",
    "TRAFFICMESH_ADMIN_BIND": "0.0.0.0:8080",
})

units = {}
for name in os.listdir(os.path.join(deploy, "systemd")):
    match = re.fullmatch(r"trafficmesh-(.+)\.service", name)
    if not match:
        continue
    with open(os.path.join(deploy, "systemd", name)) as f:
        line = next(l for l in f if l.startswith("ExecStart="))
    words = shlex.split(line[len("ExecStart="):])
    words = [re.sub(r"\$\{(\w+)\}", lambda m: placed[m.group(1)], w) for w in words]
    words[0] = os.path.basename(words[0])
    units[match.group(1)] = words

services = compose["services"]
by_unit = {("router" if s == "trafficmesh-router" else s): spec for s, spec in services.items()}
assert set(by_unit) == set(units), (sorted(by_unit), sorted(units))
for name, spec in by_unit.items():
    assert spec["command"] == units[name], (name, spec["command"], units[name])
    assert os.path.exists(os.path.join(bins, spec["command"][0])), (name, "no such binary")
    assert spec["image"] == "trafficmesh", name
    env = spec["env_file"]
    assert os.path.normpath(os.path.join(here, env)) == os.path.join(deploy, "cluster.env"), env
    if name != "router":
        # A client of the router, found by its service name as on real hosts.
        assert spec["environment"]["TRAFFICMESH_ZENOH_CONFIG"] == "/etc/trafficmesh/zenoh/service.json5"
        assert spec["depends_on"] == ["trafficmesh-router"], name
with open(os.path.join(deploy, "zenoh", "service.json5")) as f:
    assert "tcp/trafficmesh-router:7447" in f.read()

build = by_unit["router"]["build"]
context = os.path.normpath(os.path.join(here, build["context"]))
assert context == os.path.normpath(root), context
containerfile = os.path.join(context, build["dockerfile"])
with open(containerfile) as f:
    text = f.read()
for line in text.splitlines():
    words = line.split()
    if words[:1] == ["COPY"] and not words[1].startswith("--from"):
        source = words[1]
        assert source == "." or os.path.exists(os.path.join(context, source)), source
    if words[:1] == ["FROM"]:
        assert ":" in words[1], ("unpinned image", words[1])
cmd = re.search(r'^CMD (\[.*\])$', text, re.M).group(1)
assert yaml.safe_load(cmd) == by_unit["router"]["command"], cmd
# The image's map and Zenoh configs are the files the commands name.
assert "COPY deploy/zenoh/ /etc/trafficmesh/zenoh/" in text
assert "/etc/trafficmesh/map.json" in text
print("OK")
