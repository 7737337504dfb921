// Operator station page: one WebSocket to the station node. In: state (20 Hz), history (on connect),
// decisions, replies, camera frames (binary JPEG). Out: commands, condition changes, teleop keys and
// pad states (Gamepad API standard layout; the node maps them to thesis Tables 3.1/3.2).
"use strict";

const $ = (id) => document.getElementById(id);
const TITLES = { start: "Start", flight_management: "Flight Management", landing: "Landing Mode",
                 manual: "Manual Control", emergency: "Emergency Mode", quit: "Quit" };
const TELEOP_KEYS = new Set(["u", "i", "o", "j", "l", "m", ",", ".", "t", "b", "a", "d", " ", "k", "q", "z",
                             "T", "L", "E"]);
const MOTION_KEYS = new Set(["u", "i", "o", "j", "l", "m", ",", ".", "t", "b", "a", "d"]);
const KEY_REPEAT_MS = 100;   // a held key is re-sent this often (the teleop stops 0.5 s after the last one)
const PAD_PERIOD_MS = 50;    // pad and on-screen sticks are sent at 20 Hz while in use

// Counters the browser tests and the benchmark read (window.stationStats).
const stats = { states: 0, frames: 0, since: performance.now(), stateRate: 0, frameRate: 0, lastState: null,
                replies: [] };
window.stationStats = stats;

let socket = null;
let requestId = 0;
let conditionSpecs = {};
let screen = "start";
const history = { plot: [], pad: [], drone: [], seconds: 60 };
const decisionsShown = new Set();
let lastState = null;

// ----- connection ----------------------------------------------------------------------------------------
function connect(delay) {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  socket = new WebSocket(scheme + "://" + location.host + "/ws");
  socket.binaryType = "blob";
  socket.onopen = () => { $("link").textContent = "live"; $("link").className = "link up"; delay = 500; };
  socket.onclose = () => {
    $("link").textContent = "disconnected, retrying";
    $("link").className = "link down";
    setTimeout(() => connect(Math.min(delay * 2, 5000)), delay);
  };
  socket.onmessage = (event) => {
    if (typeof event.data === "string") {
      onMessage(JSON.parse(event.data));
    } else {
      showFrame(event.data);
    }
  };
}

function send(message) {
  if (!socket || socket.readyState !== WebSocket.OPEN) {
    showReply({ ok: false, message: "not connected to the station" });
    return null;
  }
  message.id = ++requestId;
  socket.send(JSON.stringify(message));
  return message.id;
}

function onMessage(message) {
  if (message.type === "state") { onState(message); }
  else if (message.type === "history") { onHistory(message); }
  else if (message.type === "decisions") { addDecisions(message.items); }
  else if (message.type === "reply") { showReply(message); }
}

function showReply(reply) {
  stats.replies.push(reply);
  if (stats.replies.length > 20) { stats.replies.shift(); }
  if (!reply.message) { return; }
  $("reply").textContent = reply.message;
  $("reply").className = reply.ok ? "reply" : "reply error";
}

// ----- camera -----------------------------------------------------------------------------------------------
let frameUrl = null;
function showFrame(blob) {
  const url = URL.createObjectURL(blob);
  const image = $("camera");
  image.onload = () => { if (frameUrl && frameUrl !== url) { URL.revokeObjectURL(frameUrl); } frameUrl = url; };
  image.src = url;
  stats.frames += 1;
}

// ----- state ---------------------------------------------------------------------------------------------------
function fmt(value, digits, unit) {
  return value === null || value === undefined ? "-" : value.toFixed(digits) + (unit ? " " + unit : "");
}

function onState(state) {
  stats.states += 1;
  stats.lastState = state;
  lastState = state;
  $("sim-time").textContent = state.t.toFixed(1);
  $("mode").textContent = state.mode;
  $("tracker").textContent = state.tracker || "-";
  setScreen(state.screen);
  $("countdown").textContent = state.countdown === null ? "" :
    "Auto take-off in " + Math.ceil(state.countdown) + " s without a choice";
  renderRows(state.rows);
  renderWarning(state.warning);
  renderLanding(state);
  renderEmergency(state.emergency, state.t);
  if (state.sample) { appendSample(state); }
  drawMap(state);
  drawPlots(state.t);
}

function setScreen(name) {
  if (name === screen && document.querySelector(".screen.active")) { return; }
  screen = name;
  for (const element of document.querySelectorAll(".screen")) {
    element.classList.toggle("active", element.id === "screen-" + name);
  }
  $("title").textContent = TITLES[name] || name;
  document.body.dataset.screen = name;
}

function renderRows(rows) {
  const body = $("conditions").tBodies[0];
  while (body.rows.length < rows.length) {
    const row = body.insertRow();
    for (const kind of ["label", "value", "note"]) { row.insertCell().className = kind; }
  }
  rows.forEach((row, index) => {
    const tr = body.rows[index];
    tr.className = row.flag ? "flag" + row.flag : row.alarm ? "alarm" : "";
    tr.dataset.key = row.key;
    tr.cells[0].textContent = row.label;
    tr.cells[1].textContent = row.text;
    tr.cells[2].textContent = row.note || "";
  });
}

function renderWarning(warning) {
  const box = $("warning");
  box.hidden = !warning;
  if (!warning) { return; }
  $("warning-message").textContent = warning.message;
  $("warning-time").textContent = warning.time_left === null ? "(the flight goes on)" :
    "- answer within " + Math.ceil(warning.time_left) + " s, else emergency landing";
  const options = $("warning-options");
  const wanted = warning.options.join(",");
  if (options.dataset.options !== wanted) {
    options.dataset.options = wanted;
    options.replaceChildren(...warning.options.map((option) => {
      const button = document.createElement("button");
      button.textContent = option;
      button.dataset.command = option;
      button.className = option === "emergency" ? "danger" : option === "continue" ? "go" : "";
      return button;
    }));
  }
}

function renderLanding(state) {
  $("landing-state").textContent = state.tracker || "-";
  $("landing-error").textContent = fmt(state.landing.error, 2, "m");
  $("landing-height").textContent = fmt(state.landing.height, 2, "m");
  $("landing-camera-latency").textContent = fmt(state.landing.camera_latency, 2, "s");
  const result = state.landing.result || "";
  $("landing-result").textContent = result;
  $("landing-result").className = "result " + (result.startsWith("Landing performed successfully") ? "success" :
                                               result ? "other" : "");
  $("landing-again").hidden = state.mode !== "landed";
}

function renderEmergency(emergency, t) {
  if (!emergency) { return; }
  if (stats.emergencyShownAt === undefined) { stats.emergencyShownAt = t; }   // sim time of the first report shown
  $("emergency-coordinates").textContent = "x = " + emergency.x.toFixed(2) + " m   y = " + emergency.y.toFixed(2) + " m";
  $("emergency-ack").textContent = emergency.acknowledged ? "acknowledged" : "reported every second until acknowledged";
}

// ----- history: plots and trails -------------------------------------------------------------------------------
function onHistory(message) {
  history.seconds = message.history_s;
  history.plot = message.plot;
  history.pad = message.pad_trail.map((p) => [p[0], p[1], p[2]]);
  history.drone = message.drone_trail.map((p) => [p[0], p[1], p[2]]);
  conditionSpecs = message.conditions;
  const select = $("condition-name");
  if (!select.options.length) {
    for (const [name, spec] of Object.entries(conditionSpecs)) {
      select.add(new Option(spec.label + " [" + spec.unit + "]", name));
    }
    select.onchange = describeCondition;
    describeCondition();
  }
  $("decisions").replaceChildren();
  decisionsShown.clear();
  addDecisions(message.decisions);
}

function appendSample(state) {
  const t = state.sample[0];
  const last = history.plot[history.plot.length - 1];
  if (!last || last[0] < t) { history.plot.push(state.sample); }
  if (last && t + 1 < last[0]) { history.plot = [state.sample]; history.pad = []; history.drone = []; }
  const trail = (list, xy, period) => {
    const end = list[list.length - 1];
    if (xy && (!end || state.t - end[0] >= period)) { list.push([state.t, xy[0], xy[1]]); }
  };
  trail(history.pad, state.pad, 0.2);
  trail(history.drone, state.drone ? [state.drone.x, state.drone.y] : null, 0.2);
  const oldest = state.t - history.seconds;
  for (const key of ["plot", "pad", "drone"]) {
    let drop = 0;
    while (drop < history[key].length && history[key][drop][0] < oldest) { drop += 1; }
    if (drop) { history[key].splice(0, drop); }
  }
}

function addDecisions(items) {
  const list = $("decisions");
  for (const d of items) {
    if (decisionsShown.has(d.seq)) { continue; }
    decisionsShown.add(d.seq);
    const li = document.createElement("li");
    li.value = d.seq;
    li.textContent = "t=" + Number(d.t).toFixed(1) + "  " + d.condition + (d.flag ? " [flag #" + d.flag + "]" : "") +
      ": " + d.action + " - " + d.reason;
    li.className = d.flag ? "flag" + d.flag : String(d.reason).startsWith("Landing performed successfully") ? "success" : "";
    list.prepend(li);
  }
  while (list.children.length > 200) { list.lastChild.remove(); }
}

// ----- map -----------------------------------------------------------------------------------------------------------
function drawMap(state) {
  const canvas = $("map");
  const ctx = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height;
  ctx.clearRect(0, 0, w, h);
  const points = [];
  for (const p of history.pad) { points.push([p[1], p[2]]); }
  for (const p of history.drone) { points.push([p[1], p[2]]); }
  for (const p of state.prediction) { points.push(p); }
  if (state.drone) { points.push([state.drone.x, state.drone.y]); }
  if (state.vehicle) { points.push([state.vehicle.x, state.vehicle.y]); }
  if (state.emergency) { points.push([state.emergency.x, state.emergency.y]); }
  if (!points.length) { points.push([0, 0]); }
  let minX = Math.min(...points.map((p) => p[0])), maxX = Math.max(...points.map((p) => p[0]));
  let minY = Math.min(...points.map((p) => p[1])), maxY = Math.max(...points.map((p) => p[1]));
  const span = Math.max(maxX - minX, maxY - minY, 10) * 1.15;
  const cx = (minX + maxX) / 2, cy = (minY + maxY) / 2;
  const scale = Math.min(w, h) / span;
  const X = (x) => w / 2 + (x - cx) * scale;
  const Y = (y) => h / 2 - (y - cy) * scale;   // world y up
  // grid every 5 m
  ctx.strokeStyle = "#222b35"; ctx.lineWidth = 1;
  const step = span > 60 ? 20 : 5;
  for (let gx = Math.floor((cx - span) / step) * step; gx < cx + span; gx += step) {
    ctx.beginPath(); ctx.moveTo(X(gx), 0); ctx.lineTo(X(gx), h); ctx.stroke();
  }
  for (let gy = Math.floor((cy - span) / step) * step; gy < cy + span; gy += step) {
    ctx.beginPath(); ctx.moveTo(0, Y(gy)); ctx.lineTo(w, Y(gy)); ctx.stroke();
  }
  ctx.fillStyle = "#8d99a6"; ctx.font = "11px sans-serif";
  ctx.fillText(step + " m grid", 6, h - 6);
  const line = (list, colour, dash) => {
    if (list.length < 2) { return; }
    ctx.strokeStyle = colour; ctx.lineWidth = 2; ctx.setLineDash(dash || []);
    ctx.beginPath(); ctx.moveTo(X(list[0][0]), Y(list[0][1]));
    for (const p of list.slice(1)) { ctx.lineTo(X(p[0]), Y(p[1])); }
    ctx.stroke(); ctx.setLineDash([]);
  };
  line(history.pad.map((p) => [p[1], p[2]]), "#e53935");
  line(history.drone.map((p) => [p[1], p[2]]), "#4a90d9");
  line(state.prediction, "#ffa726", [6, 4]);
  if (state.vehicle) {  // the vehicle's reported position and heading (about 1 m x 0.6 m: drawn to scale, at least 8 px)
    ctx.save(); ctx.translate(X(state.vehicle.x), Y(state.vehicle.y)); ctx.rotate(-state.vehicle.yaw);
    const l = Math.max(1.0 * scale, 10), b = Math.max(0.6 * scale, 6);
    ctx.fillStyle = "#9e9e9e"; ctx.fillRect(-l / 2, -b / 2, l, b);
    ctx.fillStyle = "#43a047"; ctx.fillRect(l / 2 - 3, -b / 2, 3, b);
    ctx.restore();
  }
  if (state.pad) {
    const s = Math.max(1.0 * scale, 6);
    ctx.strokeStyle = "#ff5252"; ctx.lineWidth = 2; ctx.strokeRect(X(state.pad[0]) - s / 2, Y(state.pad[1]) - s / 2, s, s);
  }
  if (state.drone) {
    ctx.save(); ctx.translate(X(state.drone.x), Y(state.drone.y)); ctx.rotate(-state.drone.yaw);
    ctx.fillStyle = "#4a90d9"; ctx.beginPath(); ctx.moveTo(10, 0); ctx.lineTo(-7, 6); ctx.lineTo(-7, -6); ctx.closePath();
    ctx.fill(); ctx.restore();
    ctx.fillStyle = "#e6e9ec"; ctx.fillText("z " + fmt(state.drone.z, 1, "m"), X(state.drone.x) + 10, Y(state.drone.y) - 8);
  }
  if (state.emergency) {
    const ex = X(state.emergency.x), ey = Y(state.emergency.y);
    ctx.strokeStyle = "#ff1744"; ctx.lineWidth = 4;
    ctx.beginPath(); ctx.moveTo(ex - 10, ey - 10); ctx.lineTo(ex + 10, ey + 10); ctx.moveTo(ex + 10, ey - 10);
    ctx.lineTo(ex - 10, ey + 10); ctx.stroke();
    ctx.fillStyle = "#ff8a80"; ctx.font = "bold 13px sans-serif";
    ctx.fillText("emergency " + state.emergency.x.toFixed(1) + ", " + state.emergency.y.toFixed(1), ex + 12, ey + 4);
  }
}

// ----- plots -----------------------------------------------------------------------------------------------------------
function plot(canvas, now, series, label, minimum) {
  const ctx = canvas.getContext("2d");
  const w = canvas.width, h = canvas.height, left = 34, bottom = 16;
  ctx.clearRect(0, 0, w, h);
  let top = minimum;
  for (const s of series) { for (const p of history.plot) { if (p[s.index] !== null) { top = Math.max(top, p[s.index]); } } }
  top = Math.ceil(top * 1.1 * 2) / 2;
  const X = (t) => left + (t - (now - history.seconds)) / history.seconds * (w - left);
  const Y = (v) => (h - bottom) - v / top * (h - bottom - 6);
  ctx.fillStyle = "#8d99a6"; ctx.font = "11px sans-serif";
  ctx.fillText(top.toFixed(1), 2, 12); ctx.fillText("0", 2, h - bottom);
  ctx.fillText("-60 s", left, h - 3); ctx.fillText("now", w - 24, h - 3);
  ctx.strokeStyle = "#2a333d"; ctx.strokeRect(left, 4, w - left - 1, h - bottom - 4);
  series.forEach((s, k) => {
    ctx.strokeStyle = s.colour; ctx.lineWidth = 2; ctx.beginPath();
    let drawing = false;
    for (const p of history.plot) {
      const v = p[s.index];
      if (v === null) { drawing = false; continue; }
      if (drawing) { ctx.lineTo(X(p[0]), Y(v)); } else { ctx.moveTo(X(p[0]), Y(v)); drawing = true; }
    }
    ctx.stroke();
    ctx.fillStyle = s.colour; ctx.fillText(s.name, left + 8 + k * 150, 16);
  });
  ctx.fillStyle = "#8d99a6"; ctx.fillText(label, w - 80, 16);
}

function drawPlots(now) {
  plot($("plot-altitude"), now, [{ index: 1, name: "altitude (baro) [m]", colour: "#4a90d9" },
                                 { index: 2, name: "height above surface (sonar) [m]", colour: "#66bb6a" }], "", 1);
  plot($("plot-error"), now, [{ index: 3, name: "tracking error [m]", colour: "#ffa726" }], "", 0.5);
}

// ----- conditions form -------------------------------------------------------------------------------------------------
function describeCondition() {
  const spec = conditionSpecs[$("condition-name").value];
  if (!spec) { return; }
  const input = $("condition-value");
  input.min = spec.low; input.max = spec.high;
  $("condition-unit").textContent = spec.unit + " (" + spec.low + " to " + spec.high + ")";
  const current = lastState && lastState.conditions[$("condition-name").value];
  if (current !== null && current !== undefined) { input.value = current; }
}

// ----- commands and Manual Control ----------------------------------------------------------------------------------------
document.addEventListener("click", (event) => {
  const button = event.target.closest("button");
  if (!button) { return; }
  if (button.dataset.command) { send({ type: "command", name: button.dataset.command }); }
  if (button.dataset.key) { send({ type: "key", key: button.dataset.key }); }
});

function setupForm() {
  $("set-condition").addEventListener("submit", (event) => {
    event.preventDefault();
    send({ type: "set", name: $("condition-name").value, value: $("condition-value").value });
  });
}

// Keys: as the teleop, only in Manual Control and not while typing in the form.
const heldKeys = new Map();   // key -> interval id
function manualKeysActive(event) {
  return screen === "manual" && !(event.target instanceof HTMLInputElement || event.target instanceof HTMLSelectElement);
}
document.addEventListener("keydown", (event) => {
  if (!manualKeysActive(event) || !TELEOP_KEYS.has(event.key) || event.ctrlKey || event.altKey || event.metaKey) { return; }
  event.preventDefault();
  if (event.repeat || heldKeys.has(event.key)) { return; }
  send({ type: "key", key: event.key });
  if (MOTION_KEYS.has(event.key)) {
    heldKeys.set(event.key, setInterval(() => send({ type: "key", key: event.key }), KEY_REPEAT_MS));
  }
});
document.addEventListener("keyup", (event) => {
  const timer = heldKeys.get(event.key);
  if (timer === undefined) { return; }
  clearInterval(timer);
  heldKeys.delete(event.key);
  if (!heldKeys.size) { send({ type: "key", key: "k" }); }
});
window.addEventListener("blur", () => {
  for (const timer of heldKeys.values()) { clearInterval(timer); }
  if (heldKeys.size) { heldKeys.clear(); send({ type: "key", key: "k" }); }
});

// On-screen sticks (Mode 2): touching a stick holds the dead-man; sent as a standard-layout pad.
const sticks = { left: { x: 0, y: 0, active: false }, right: { x: 0, y: 0, active: false } };
function setupStick(name) {
  const canvas = $("stick-" + name);
  const stick = sticks[name];
  const update = (event) => {
    const rect = canvas.getBoundingClientRect();
    const r = rect.width / 2;
    let x = (event.clientX - rect.left - r) / (r * 0.8), y = (event.clientY - rect.top - r) / (r * 0.8);
    const length = Math.hypot(x, y);
    if (length > 1) { x /= length; y /= length; }
    stick.x = x; stick.y = y;
    drawStick(canvas, stick);
  };
  canvas.addEventListener("pointerdown", (event) => { canvas.setPointerCapture(event.pointerId); stick.active = true; update(event); });
  canvas.addEventListener("pointermove", (event) => { if (stick.active) { update(event); } });
  const release = () => { stick.active = false; stick.x = 0; stick.y = 0; drawStick(canvas, stick); };
  canvas.addEventListener("pointerup", release);
  canvas.addEventListener("pointercancel", release);
  drawStick(canvas, stick);
}
function drawStick(canvas, stick) {
  const ctx = canvas.getContext("2d"), r = canvas.width / 2;
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  ctx.fillStyle = "#26303a"; ctx.beginPath(); ctx.arc(r, r, r - 2, 0, 2 * Math.PI); ctx.fill();
  ctx.strokeStyle = "#4b5a69"; ctx.beginPath(); ctx.moveTo(r, 8); ctx.lineTo(r, 2 * r - 8); ctx.moveTo(8, r);
  ctx.lineTo(2 * r - 8, r); ctx.stroke();
  ctx.fillStyle = stick.active ? "#4a90d9" : "#5c6b7a";
  ctx.beginPath(); ctx.arc(r + stick.x * r * 0.8, r + stick.y * r * 0.8, 22, 0, 2 * Math.PI); ctx.fill();
}

// The pad: Gamepad API standard layout as it comes (the node maps it). Sent while a pad is connected or a
// stick is touched, and once more after the last touch so the dead-man release stops the drone.
let padWasActive = false;
function pollPad() {
  const pads = navigator.getGamepads ? Array.from(navigator.getGamepads()).filter((p) => p && p.connected) : [];
  const pad = pads.find((p) => p.mapping === "standard");
  $("gamepad").textContent = pad ? "gamepad: " + pad.id + " (standard mapping)" :
    pads.length ? "gamepad " + pads[0].id + " has no standard mapping: not used" : "no gamepad: press a button on the pad to connect it";
  const screenActive = sticks.left.active || sticks.right.active;
  let message = null;
  if (screenActive || padWasActive && !pad) {
    const buttons = new Array(17).fill(0);
    buttons[4] = screenActive ? 1 : 0;   // L1, the dead-man
    message = { type: "joy", axes: [sticks.left.x, sticks.left.y, sticks.right.x, sticks.right.y], buttons: buttons };
  } else if (pad) {
    message = { type: "joy", axes: pad.axes.slice(0, 4).map(Number), buttons: pad.buttons.slice(0, 18).map((b) => b.value) };
  }
  padWasActive = screenActive;
  if (message && socket && socket.readyState === WebSocket.OPEN) { socket.send(JSON.stringify(message)); }
}

// ----- rates shown in the header (and read by the tests) --------------------------------------------------------------------
setInterval(() => {
  const now = performance.now(), seconds = (now - stats.since) / 1000;
  stats.stateRate = stats.states / seconds;
  stats.frameRate = stats.frames / seconds;
  $("rates").textContent = stats.stateRate.toFixed(0) + " updates/s, camera " + stats.frameRate.toFixed(0) + " fps";
  stats.states = 0; stats.frames = 0; stats.since = now;
  stats.lastRates = { state: stats.stateRate, frames: stats.frameRate };
}, 2000);

window.addEventListener("DOMContentLoaded", () => {
  setupForm();
  setupStick("left");
  setupStick("right");
  setInterval(pollPad, PAD_PERIOD_MS);
  connect(500);
});
