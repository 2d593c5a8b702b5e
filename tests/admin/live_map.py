"""The live map in headless Chromium, driven over the DevTools protocol.

Usage: live_map.py CHROMIUM URL OUT_DIR [reservations]. Prints OK and exits 0 when:
- the page loads and draws vehicles from the live stream, with no console
  error and no uncaught exception;
- two screenshots a second apart (panels hidden, so only the map is compared)
  differ where vehicles are, and the page saw newer ticks in between.
- with `reservations`: the debug layer draws reserved rectangles and a queue
  label on every approach of the map's reservation intersection.
Screenshots are written to OUT_DIR for a human to look at.
"""
import base64
import io
import json
import os
import re
import subprocess
import sys
import tempfile
import time
import urllib.request

import websocket  # websocket-client from PyPI
from PIL import Image, ImageChops

CHROMIUM, URL, OUT = sys.argv[1], sys.argv[2], sys.argv[3]
RESERVATIONS = len(sys.argv) > 4 and sys.argv[4] == "reservations"


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


profile = tempfile.mkdtemp(prefix="tm-chromium-")
browser = subprocess.Popen(
    [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
     "--disable-dev-shm-usage", "--remote-debugging-port=0", f"--user-data-dir={profile}",
     "--window-size=1280,800", "about:blank"],
    stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
try:
    port = None
    deadline = time.time() + 30
    while port is None and time.time() < deadline:
        line = browser.stderr.readline()
        m = re.search(r"DevTools listening on ws://127\.0\.0\.1:(\d+)/", line)
        if m:
            port = int(m.group(1))
    if port is None:
        fail("chromium did not open its DevTools port")
    pages = json.load(urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list"))
    page = next(p for p in pages if p["type"] == "page")
    ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=30)

    next_id = [0]
    problems = []

    def handle(msg):
        method = msg.get("method")
        params = msg.get("params", {})
        if method == "Runtime.exceptionThrown":
            problems.append("exception: " + json.dumps(params["exceptionDetails"])[:500])
        elif method == "Runtime.consoleAPICalled" and params.get("type") == "error":
            problems.append("console.error: " + json.dumps(params.get("args"))[:500])
        elif method == "Log.entryAdded" and params["entry"].get("level") == "error":
            entry = params["entry"]
            problems.append(f"log: {entry.get('text', '')[:500]} ({entry.get('url', '')})")

    def call(method, **params):
        next_id[0] += 1
        ws.send(json.dumps({"id": next_id[0], "method": method, "params": params}))
        while True:
            msg = json.loads(ws.recv())
            if msg.get("id") == next_id[0]:
                if "error" in msg:
                    fail(f"{method}: {msg['error']}")
                return msg.get("result", {})
            handle(msg)

    def evaluate(expr):
        r = call("Runtime.evaluate", expression=expr, returnByValue=True)
        return r.get("result", {}).get("value")

    call("Runtime.enable")
    call("Log.enable")
    call("Page.enable")
    call("Page.navigate", url=URL)

    deadline = time.time() + 30
    while time.time() < deadline:
        state = evaluate("window.trafficmesh && JSON.stringify(window.trafficmesh)")
        if state and json.loads(state)["drawnVehicles"] > 0:
            break
        time.sleep(0.2)
    else:
        fail(f"no vehicles drawn within 30 s: {state}")

    if RESERVATIONS:
        evaluate("document.getElementById('showGizmos').click()")
        deadline = time.time() + 30
        while time.time() < deadline:
            state = json.loads(evaluate("JSON.stringify(window.trafficmesh)"))
            if state["drawnReserved"] > 0 and state["drawnQueues"] >= 8:
                break
            time.sleep(0.2)
        else:
            fail(f"no reserved ways or queues drawn within 30 s: {state}")
        data = base64.b64decode(call("Page.captureScreenshot", format="png")["data"])
        with open(os.path.join(OUT, "live_map_reservations.png"), "wb") as f:
            f.write(data)

    # Only the map: the panels show a clock that changes by itself.
    evaluate("document.querySelectorAll('.panel').forEach(p => p.style.visibility = 'hidden')")
    time.sleep(0.3)

    def shot(name):
        data = base64.b64decode(call("Page.captureScreenshot", format="png")["data"])
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(data)
        return Image.open(io.BytesIO(data)).convert("RGB")

    tick_before = json.loads(evaluate("JSON.stringify(window.trafficmesh)"))["tick"]
    first = shot("live_map_1.png")
    time.sleep(1.0)
    second = shot("live_map_2.png")
    seen = json.loads(evaluate("JSON.stringify(window.trafficmesh)"))
    if seen["tick"] is None or seen["tick"] <= tick_before:
        fail(f"no newer tick reached the page: {tick_before} -> {seen['tick']}")

    diff = ImageChops.difference(first, second).convert("L").point(lambda v: 255 if v > 40 else 0)
    changed = diff.histogram()[255]
    # Lights may change colour in that second; a few dots are far fewer pixels
    # than a dozen cars each moving ten metres.
    if changed < 300:
        fail(f"only {changed} pixels changed between the screenshots a second apart")

    # Drain pending events, then judge the console.
    ws.settimeout(0.5)
    try:
        while True:
            handle(json.loads(ws.recv()))
    except websocket.WebSocketTimeoutException:
        pass
    # How well the page keeps up: batches received and frames drawn per second.
    before = json.loads(evaluate("JSON.stringify(window.trafficmesh)"))
    time.sleep(3.0)
    after = json.loads(evaluate("JSON.stringify(window.trafficmesh)"))
    batches_per_s = (after["batches"] - before["batches"]) / 3.0
    frames_per_s = (after["frames"] - before["frames"]) / 3.0
    problems += [f"page error: {e}" for e in after["errors"]]
    if problems:
        fail("\n".join(problems))
    print(f"OK: {seen['drawnVehicles']} vehicles drawn, {seen['drawnReserved']} reserved rectangles, {changed} pixels moved in 1 s, "
          f"{batches_per_s:.1f} batches/s received, {frames_per_s:.1f} frames/s drawn")
finally:
    browser.kill()
    browser.wait()
