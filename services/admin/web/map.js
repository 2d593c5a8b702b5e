// trafficmesh live map: lanes, vehicles, lights and crosswalks from the admin,
// live over a WebSocket. No libraries, no network beyond the admin itself.
"use strict";

const MODES = ["NORMAL", "SLOW", "STOP", "SUDDEN_STOP", "ABSOLUTE_STOP"];
const MODE_COLORS = ["#3fb950", "#d29922", "#f0883e", "#f85149", "#db61a2"];
const PHASES = ["NONE", "ENTERING_INTERSECTION", "AT_INTERSECTION", "INTERSECTION_BLOCKED",
  "LEFT_HAND_RULE_ENTERING_INTERSECTION", "LEFT_HAND_RULE_AT_INTERSECTION",
  "LANES_RULES_ENTERING_INTERSECTION", "LANES_RULES_AT_INTERSECTION", "FORCING_PRIORITY"];
const PHASE_COLORS = [null, "#58a6ff", "#58a6ff", "#f85149", "#d29922", "#d29922", "#a371f7", "#a371f7", "#ff00ff"];
const SIGNALS = ["off", "left", "right"];
const LIGHT_COLORS = { green: "#3fb950", yellow: "#e3b341", red: "#f85149" };
const HEADER_BYTES = 36;

const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
const statusBox = document.getElementById("status");
const vehicleBox = document.getElementById("vehicle");

// Exposed for tests and for the curious: what the page has seen and drawn.
const live = { frames: 0, batches: 0, drawnVehicles: 0, drawnActors: 0, drawnReserved: 0, drawnQueues: 0, tick: null, errors: [] };
window.trafficmesh = live;

let map = null;
let lanesPath = null, junctionPath = null;
let batch = null; // { tick, time, count, view: DataView, record }
let states = { lights: {}, crosswalks: {} };
// The traffic service's sessions: each one's actors as box centres (docs/traffic-service.md).
let sessions = [];
const DRIVER_COLORS = { log: "#8b949e", model: "#d29922", client: "#58a6ff", static: "#6e7681" };
// The reservation intersections' view: rectangles reserved ahead, each approach's head (docs/cluster.md).
let intersections = null;
// How far ahead the reserved rectangles are drawn, seconds (they fade out to it).
const RESERVED_AHEAD = 5;
const view = { scale: 1, x: 0, y: 0 }; // screen = (world - (x, y)) * scale, y flipped
let dirty = true;
// The lanes, drawn once per view (pan, zoom, resize) instead of every frame.
const lanesLayer = document.createElement("canvas");
let lanesView = "";
let selected = null;

function layer(id) {
  return document.getElementById(id).checked;
}
for (const id of ["showGizmos", "showYieldingPhase", "showObstacleChecking", "showSpawnPoints", "showReservations"]) {
  document.getElementById(id).addEventListener("change", () => { dirty = true; });
}
document.getElementById("legend").innerHTML =
  MODES.map((m, i) => `<span style="background:${MODE_COLORS[i]}"></span>${m}`).join("<br>");

function resize() {
  canvas.width = canvas.clientWidth * devicePixelRatio;
  canvas.height = canvas.clientHeight * devicePixelRatio;
  dirty = true;
}
window.addEventListener("resize", resize);

function fit() {
  const [x0, y0, x1, y1] = map.bounds;
  const w = canvas.width, h = canvas.height;
  view.scale = 0.95 * Math.min(w / Math.max(x1 - x0, 1), h / Math.max(y1 - y0, 1));
  view.x = (x0 + x1) / 2 - w / 2 / view.scale;
  view.y = (y0 + y1) / 2 + h / 2 / view.scale;
}

function toWorld(px, py) {
  return [px / view.scale + view.x, view.y - py / view.scale];
}

// Pan with the mouse, zoom with the wheel around the cursor.
let drag = null;
canvas.addEventListener("mousedown", (e) => {
  drag = { x: e.clientX, y: e.clientY, moved: false };
  canvas.classList.add("dragging");
});
window.addEventListener("mouseup", (e) => {
  canvas.classList.remove("dragging");
  if (drag && !drag.moved) pick(e.clientX * devicePixelRatio, e.clientY * devicePixelRatio);
  drag = null;
});
window.addEventListener("mousemove", (e) => {
  if (!drag) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  if (Math.abs(dx) + Math.abs(dy) > 2) drag.moved = true;
  view.x -= dx * devicePixelRatio / view.scale;
  view.y += dy * devicePixelRatio / view.scale;
  drag.x = e.clientX; drag.y = e.clientY;
  dirty = true;
});
canvas.addEventListener("wheel", (e) => {
  e.preventDefault();
  const px = e.offsetX * devicePixelRatio, py = e.offsetY * devicePixelRatio;
  const [wx, wy] = toWorld(px, py);
  view.scale *= Math.exp(-e.deltaY * 0.0015);
  view.x = wx - px / view.scale;
  view.y = wy + py / view.scale;
  dirty = true;
}, { passive: false });

function buildPaths() {
  lanesPath = new Path2D();
  junctionPath = new Path2D();
  for (const lane of map.lanes) {
    const path = lane.intersection ? junctionPath : lanesPath;
    lane.points.forEach(([x, y], i) => (i ? path.lineTo(x, y) : path.moveTo(x, y)));
  }
}

// One vehicle record of the binary batch (layout in docs/cluster.md).
function vehicle(i) {
  const d = batch.view, o = HEADER_BYTES + i * batch.record;
  return {
    id: Number(d.getBigUint64(o, true)), lane: d.getUint32(o + 8, true), kind: d.getUint16(o + 12, true),
    mode: d.getUint8(o + 14), phase: d.getUint8(o + 15), signal: d.getUint8(o + 16),
    zebra: (d.getUint8(o + 17) & 1) === 1,
    s: d.getFloat32(o + 18, true), x: d.getFloat32(o + 22, true), y: d.getFloat32(o + 26, true),
    z: d.getFloat32(o + 30, true), yaw: d.getFloat32(o + 34, true), speed: d.getFloat32(o + 38, true),
    accel: d.getFloat32(o + 42, true), length: d.getFloat32(o + 46, true), width: d.getFloat32(o + 50, true),
    check: d.getFloat32(o + 54, true),
    // From version 2: the front bumper's distance ahead of (x, y).
    front: batch.version >= 2 ? d.getFloat32(o + 58, true) : (map.kinds[d.getUint16(o + 12, true)] || { front: 0 }).front,
  };
}

function readBatch(buffer) {
  const d = new DataView(buffer);
  const magic = String.fromCharCode(d.getUint8(0), d.getUint8(1), d.getUint8(2), d.getUint8(3));
  const version = d.getUint16(4, true);
  if (magic !== "TMVB" || (version !== 1 && version !== 2)) throw new Error("not a version-1 or 2 vehicle batch");
  const record = d.getUint16(6, true), count = d.getUint32(32, true);
  if (record < (version >= 2 ? 62 : 58)) throw new Error("vehicle batch records too short");
  if (buffer.byteLength !== HEADER_BYTES + count * record) throw new Error("vehicle batch length mismatch");
  return { tick: Number(d.getBigUint64(8, true)), time: d.getFloat64(16, true), count, record, version, view: d };
}

// The box's centre: the pose is the rear axle, `front` metres behind the front bumper.
function boxCorners(v) {
  const c = Math.cos(v.yaw), s = Math.sin(v.yaw);
  const mid = v.front - v.length / 2;
  const cx = v.x + c * mid, cy = v.y + s * mid, hl = v.length / 2, hw = v.width / 2;
  return [[cx + c * hl - s * hw, cy + s * hl + c * hw], [cx + c * hl + s * hw, cy + s * hl - c * hw],
    [cx - c * hl + s * hw, cy - s * hl - c * hw], [cx - c * hl - s * hw, cy - s * hl + c * hw]];
}

function worldTransform(c) {
  c.setTransform(view.scale, 0, 0, -view.scale, -view.x * view.scale, view.y * view.scale);
}

function drawLanes() {
  const key = `${canvas.width}x${canvas.height}:${view.scale}:${view.x}:${view.y}`;
  if (key === lanesView) return;
  lanesView = key;
  lanesLayer.width = canvas.width;
  lanesLayer.height = canvas.height;
  const c = lanesLayer.getContext("2d");
  c.fillStyle = "#1b1e23";
  c.fillRect(0, 0, lanesLayer.width, lanesLayer.height);
  worldTransform(c);
  c.lineCap = "round";
  c.lineJoin = "round";
  c.lineWidth = Math.max(3.2, 1.5 / view.scale);
  c.strokeStyle = "#4b525c";
  c.stroke(lanesPath);
  c.strokeStyle = "#3a4049";
  c.stroke(junctionPath);
}

function draw() {
  drawLanes();
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.drawImage(lanesLayer, 0, 0);
  worldTransform(ctx);
  const px = 1 / view.scale;

  // Crosswalks: green when clear, red when occupied (the AWSIM reference's gizmo colours).
  for (const cw of map.crosswalks) {
    const occupied = states.crosswalks[cw.name] === true;
    ctx.beginPath();
    cw.polygon.forEach(([x, y], i) => (i ? ctx.lineTo(x, y) : ctx.moveTo(x, y)));
    ctx.closePath();
    ctx.fillStyle = occupied ? "rgba(248,81,73,0.35)" : "rgba(63,185,80,0.15)";
    ctx.fill();
    ctx.strokeStyle = occupied ? "#f85149" : "#3fb950";
    ctx.lineWidth = 2 * px;
    ctx.stroke();
    ctx.fillStyle = "#39c5cf";
    for (const [x, y] of cw.stop_points) {
      ctx.beginPath();
      ctx.arc(x, y, Math.max(0.6, 3 * px), 0, 2 * Math.PI);
      ctx.fill();
    }
  }

  // Lights at their stop lines.
  for (const [group, points] of Object.entries(map.lights)) {
    ctx.fillStyle = LIGHT_COLORS[states.lights[group]] || "#6e7681";
    for (const [x, y] of points) {
      ctx.beginPath();
      ctx.arc(x, y, Math.max(0.9, 3.5 * px), 0, 2 * Math.PI);
      ctx.fill();
    }
  }

  const gizmos = layer("showGizmos");
  if (gizmos && layer("showSpawnPoints")) {
    ctx.fillStyle = "#39c5cf";
    const half = Math.max(1, 4 * px);
    for (const p of map.spawn_points) ctx.fillRect(p.x - half, p.y - half, 2 * half, 2 * half);
  }

  let drawn = 0;
  if (batch) {
    const byMode = MODES.map(() => new Path2D());
    const rays = new Path2D();
    const phases = [];
    // Zoomed far out a car is under a pixel: draw a marker of fixed screen size instead.
    const marker = view.scale < 1.2 ? 2.5 * px : 0;
    for (let i = 0; i < batch.count; i++) {
      const v = vehicle(i);
      const path = byMode[v.mode] || byMode[0];
      if (marker) {
        path.rect(v.x - marker / 2, v.y - marker / 2, marker, marker);
      } else {
        const corners = boxCorners(v);
        path.moveTo(corners[0][0], corners[0][1]);
        for (let k = 1; k < 4; k++) path.lineTo(corners[k][0], corners[k][1]);
        path.closePath();
      }
      drawn++;
      if (gizmos && layer("showObstacleChecking") && v.check > 0) {
        const c = Math.cos(v.yaw), s = Math.sin(v.yaw);
        const fx = v.x + c * v.front, fy = v.y + s * v.front;
        rays.moveTo(fx, fy);
        rays.lineTo(fx + c * v.check, fy + s * v.check);
      }
      if (gizmos && layer("showYieldingPhase") && v.phase > 0) phases.push(v);
    }
    if (gizmos && layer("showObstacleChecking")) {
      ctx.strokeStyle = "rgba(255,255,255,0.35)";
      ctx.lineWidth = px;
      ctx.stroke(rays);
    }
    byMode.forEach((p, i) => { ctx.fillStyle = MODE_COLORS[i]; ctx.fill(p); });
    for (const v of phases) {
      ctx.strokeStyle = PHASE_COLORS[v.phase] || "#ffffff";
      ctx.lineWidth = 2 * px;
      ctx.beginPath();
      ctx.arc(v.x, v.y, Math.max(v.length * 0.7, 5 * px), 0, 2 * Math.PI);
      ctx.stroke();
    }
    if (gizmos && layer("showYieldingPhase") && view.scale > 6) {
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.fillStyle = "#ffffff";
      ctx.font = `${11 * devicePixelRatio}px system-ui`;
      for (const v of phases) {
        const sx = (v.x - view.x) * view.scale, sy = (view.y - v.y) * view.scale;
        ctx.fillText(PHASES[v.phase] || String(v.phase), sx + 6, sy - 6);
      }
    }
  }
  live.drawnVehicles = drawn;
  if (gizmos && layer("showReservations")) drawReservations();
  let actors = 0;
  worldTransform(ctx);
  for (const s of sessions) {
    for (const o of s.objects) {
      ctx.fillStyle = DRIVER_COLORS[o.driver] || "#ffffff";
      centredBox(o);
      ctx.fill();
      actors++;
    }
  }
  live.drawnActors = actors;
  live.frames++;
}

// A path around a box given by its centre, heading and size (the traffic
// service's actors, reserved rectangles).
function centredBox(b) {
  const c = Math.cos(b.yaw), sn = Math.sin(b.yaw), hl = b.length / 2, hw = b.width / 2;
  ctx.beginPath();
  ctx.moveTo(b.x + c * hl - sn * hw, b.y + sn * hl + c * hw);
  ctx.lineTo(b.x + c * hl + sn * hw, b.y + sn * hl - c * hw);
  ctx.lineTo(b.x - c * hl + sn * hw, b.y - sn * hl - c * hw);
  ctx.lineTo(b.x - c * hl - sn * hw, b.y - sn * hl + c * hw);
  ctx.closePath();
}

// Each vehicle's granted way: its rectangles ahead in time, fading out with
// time; at each approach lane's end, the vehicles standing on it and how long
// its head has waited for a way.
function drawReservations() {
  let reserved = 0, queues = 0;
  if (!intersections) { live.drawnReserved = 0; live.drawnQueues = 0; return; }
  worldTransform(ctx);
  const px = 1 / view.scale;
  for (const r of intersections.reserved) {
    const fade = Math.max(0.08, 0.55 * (1 - r.ahead_s / RESERVED_AHEAD));
    const hue = (r.vehicle * 137) % 360;
    centredBox(r);
    ctx.fillStyle = `hsla(${hue}, 80%, 60%, ${fade * 0.5})`;
    ctx.fill();
    ctx.strokeStyle = `hsla(${hue}, 80%, 65%, ${fade})`;
    ctx.lineWidth = px;
    ctx.stroke();
    reserved++;
  }
  const standing = new Map();
  if (batch) {
    for (let i = 0; i < batch.count; i++) {
      const v = vehicle(i);
      if (v.speed < 0.5) standing.set(v.lane, (standing.get(v.lane) || 0) + 1);
    }
  }
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.font = `${11 * devicePixelRatio}px system-ui`;
  for (const a of intersections.approaches) {
    const lane = map.lanes[a.lane];
    if (!lane || lane.points.length === 0) continue;
    const [x, y] = lane.points[lane.points.length - 1];
    const sx = (x - view.x) * view.scale, sy = (view.y - y) * view.scale;
    const n = standing.get(a.lane) || 0;
    ctx.fillStyle = a.head_waiting_s > 0 ? "#e3b341" : "#8b949e";
    ctx.fillText(a.head_waiting_s > 0 ? `${n} · ${a.head_waiting_s.toFixed(0)} s` : `${n}`, sx + 4, sy - 4);
    queues++;
  }
  live.drawnReserved = reserved;
  live.drawnQueues = queues;
}

function pick(px, py) {
  if (!batch) return;
  const [wx, wy] = toWorld(px, py);
  let best = null, bestD = Infinity;
  for (let i = 0; i < batch.count; i++) {
    const v = vehicle(i);
    const d = Math.hypot(v.x - wx, v.y - wy);
    if (d < bestD) { bestD = d; best = v; }
  }
  const reach = Math.max(4, 10 / view.scale);
  selected = best && bestD < reach + best.length ? best.id : null;
  showSelected();
}

function showSelected() {
  if (selected === null || !batch) { vehicleBox.style.display = "none"; return; }
  for (let i = 0; i < batch.count; i++) {
    const v = vehicle(i);
    if (v.id !== selected) continue;
    vehicleBox.style.display = "block";
    vehicleBox.textContent = [
      `vehicle ${v.id} (${(map.kinds[v.kind] || { name: "?" }).name})`,
      `lane        ${(map.lanes[v.lane] || { name: "?" }).name}`,
      `s           ${v.s.toFixed(1)} m`,
      `position    ${v.x.toFixed(1)}, ${v.y.toFixed(1)}`,
      `speed       ${v.speed.toFixed(2)} m/s (${(v.speed * 3.6).toFixed(0)} km/h)`,
      `accel       ${v.accel.toFixed(2)} m/s²`,
      `mode        ${MODES[v.mode]}`,
      `yield phase ${PHASES[v.phase]}`,
      `signal      ${SIGNALS[v.signal]}`,
      `zebra stop  ${v.zebra}`,
      `check ahead ${v.check.toFixed(1)} m`,
    ].join("\n");
    return;
  }
  vehicleBox.textContent = `vehicle ${selected}: gone`;
}

function frame() {
  if (map && dirty) {
    draw();
    dirty = false;
  }
  requestAnimationFrame(frame);
}

function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/api/v1/live?hz=10`);
  ws.binaryType = "arraybuffer";
  ws.onmessage = (e) => {
    if (typeof e.data === "string") {
      const m = JSON.parse(e.data);
      if (m.type === "states") states = m;
      if (m.type === "sessions") sessions = m.sessions;
      if (m.type === "intersections") intersections = m.view;
    } else {
      batch = readBatch(e.data);
      live.batches++;
      live.tick = batch.tick;
      if (selected !== null) showSelected();
    }
    dirty = true;
  };
  ws.onclose = () => setTimeout(connect, 1000);
}

async function pollStatus() {
  try {
    const s = await (await fetch("/api/v1/status")).json();
    const alive = Object.entries(s.services).filter(([, v]) => v.alive).map(([k]) => k);
    statusBox.innerHTML =
      `<b>${s.cluster}</b> ${s.degraded ? `<span class="error">degraded: ${s.reasons.join("; ")}</span>` : '<span class="ok">ok</span>'}<br>` +
      `t=${(s.time ?? 0).toFixed(1)} s · ${s.vehicles ?? 0} vehicles · ${(s.tick_rate ?? 0).toFixed(1)} ticks/s<br>` +
      `alive: ${alive.join(", ")}`;
  } catch (err) {
    statusBox.textContent = `status: ${err}`;
  }
}

// The spawn-rate panel uses the same REST API as any client.
const tokenInput = document.getElementById("token");
tokenInput.value = localStorage.getItem("trafficmesh-token") || "";
tokenInput.addEventListener("change", () => localStorage.setItem("trafficmesh-token", tokenInput.value));
let spawnConfig = { spawnRates: [], branchWeights: [] };

function message(text, ok) {
  const box = document.getElementById("spawn-message");
  box.textContent = text;
  box.className = ok ? "ok" : "error";
}

function renderRates() {
  const body = document.querySelector("#spawn-rates tbody");
  body.innerHTML = "";
  spawnConfig.spawnRates.forEach((rate, i) => {
    const row = document.createElement("tr");
    row.innerHTML = `<td><input type="text" value=""></td><td><input type="number" step="0.5" min="0"></td><td>/min</td>`;
    const [lane, perMinute] = row.querySelectorAll("input");
    lane.value = rate.lane;
    perMinute.value = rate.spawnsPerMinute;
    lane.addEventListener("change", () => { spawnConfig.spawnRates[i].lane = lane.value; });
    perMinute.addEventListener("change", () => { spawnConfig.spawnRates[i].spawnsPerMinute = Number(perMinute.value); });
    body.appendChild(row);
  });
}

async function call(method, path, body) {
  const headers = { Authorization: `Bearer ${tokenInput.value}` };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  const r = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  const data = await r.json().catch(() => null);
  if (!r.ok) {
    const problems = data && data.problems ? "\n" + data.problems.join("\n") : "";
    throw new Error(`${r.status}: ${data ? data.detail : r.statusText}${problems}`);
  }
  return data;
}

async function reloadConfig() {
  try {
    spawnConfig = await (await fetch("/api/v1/spawn-config")).json();
    renderRates();
  } catch (err) {
    message(`spawn config: ${err}`, false);
  }
}

document.getElementById("spawn-reload").onclick = reloadConfig;
document.getElementById("spawn-add").onclick = () => {
  spawnConfig.spawnRates.push({ lane: "", spawnsPerMinute: 6 });
  renderRates();
};
document.getElementById("spawn-apply").onclick = async () => {
  try {
    spawnConfig = await call("PUT", "/api/v1/spawn-config", spawnConfig);
    renderRates();
    message("applied", true);
  } catch (err) { message(String(err.message), false); }
};
document.getElementById("spawn-save").onclick = async () => {
  try { message(`saved to ${(await call("POST", "/api/v1/spawn-config/save")).saved}`, true); } catch (err) { message(String(err.message), false); }
};
document.getElementById("spawn-load").onclick = async () => {
  try {
    spawnConfig = await call("POST", "/api/v1/spawn-config/load");
    renderRates();
    message("loaded", true);
  } catch (err) { message(String(err.message), false); }
};

window.addEventListener("error", (e) => live.errors.push(String(e.message)));

(async () => {
  map = await (await fetch("/api/v1/map")).json();
  buildPaths();
  resize();
  fit();
  connect();
  reloadConfig();
  pollStatus();
  setInterval(pollStatus, 1000);
  requestAnimationFrame(frame);
})();
