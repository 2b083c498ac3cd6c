// gst-landmark console: draws the per-frame results the server sends over
// the WebSocket, and sends controls, tuning and teaching as JSON POSTs.
// Plain browser JavaScript, no libraries, nothing fetched from elsewhere.
"use strict";

const token = new URLSearchParams(location.search).get("token");
const withToken = (url) =>
  token ? url + (url.includes("?") ? "&" : "?") + "token=" + encodeURIComponent(token) : url;
const $ = (id) => document.getElementById(id);

let frameSize = null;        // [width, height] of the video frames
let classColours = {};       // class name -> "#rrggbb" (from the frames)
let landmarks = [];
let path = [];
let box = null;              // teach box in frame pixels
let lastFrame = null;
let tunablesShape = "";
let paletteClasses = [];     // the palette's classes (from the state)
let frozen = null;           // {frame, pts}: the still being taught on
let freezing = null;         // the freeze request in flight

function showMessage(text, isError) {
  const m = $("message");
  m.textContent = text;
  m.className = text ? (isError ? "error" : "ok") : "";
}

// onError(text): where a refusal is shown (default: the message line)
async function post(route, body, onError) {
  const headers = { "Content-Type": "application/json" };
  if (token) headers["Authorization"] = "Bearer " + token;
  const fail = onError || ((text) => showMessage(text, true));
  let reply;
  try {
    const r = await fetch(route, { method: "POST", headers, body: JSON.stringify(body || {}) });
    reply = await r.json();
    if (!r.ok) { fail(reply.error || r.statusText); return null; }
  } catch (e) {
    fail("request failed: " + e);
    return null;
  }
  return reply;
}

// ---- the video and the teach box ------------------------------------------

let view = "overlay";
function showVideo() {     // a fresh address: the browser opens a new stream
  if (frozen) return;
  const one = view === "binary" ? `&class=${encodeURIComponent($("class-select").value)}` : "";
  $("video").src = withToken(`stream.mjpg?view=${view}${one}&n=${Date.now()}`);
}
showVideo();
$("video").addEventListener("error", () => setTimeout(showVideo, 1000));   // broke: again
for (const radio of document.querySelectorAll("input[name=view]")) {
  radio.addEventListener("change", () => { view = radio.value; goLive(); });
}

// Teaching works on a still: the newest frame, kept by the server, shown
// until Live is pressed; Teach learns from exactly that frame.
function freeze() {
  if (frozen || freezing) return freezing;
  freezing = post("api/freeze").then((r) => {
    freezing = null;
    if (!r) return null;
    frozen = r;
    $("video").src = withToken(`frozen.jpg?frame=${r.frame}`);
    $("frozen").textContent = r.pts !== null ? `frozen at ${r.pts.toFixed(2)} s` : "frozen";
    $("live").hidden = false; $("freeze").hidden = true;
    return r;
  });
  return freezing;
}
function goLive() {
  frozen = null;
  $("frozen").textContent = "";
  $("live").hidden = true; $("freeze").hidden = false;
  showVideo();
}
$("freeze").addEventListener("click", freeze);
$("live").addEventListener("click", goLive);
for (const id of ["dl-log", "dl-snapshot", "dl-palette", "dl-map"]) $(id).href = withToken($(id).getAttribute("href"));

const layer = $("box-layer");
let dragStart = null;

function framePoint(ev) {
  const r = layer.getBoundingClientRect();
  const w = frameSize ? frameSize[0] : layer.width, h = frameSize ? frameSize[1] : layer.height;
  const x = Math.min(Math.max((ev.clientX - r.left) / r.width, 0), 1) * w;
  const y = Math.min(Math.max((ev.clientY - r.top) / r.height, 0), 1) * h;
  return [x, y];
}

function drawBox() {
  const r = layer.getBoundingClientRect();
  layer.width = r.width; layer.height = r.height;
  const g = layer.getContext("2d");
  g.clearRect(0, 0, layer.width, layer.height);
  if (!box || !frameSize) return;
  const sx = layer.width / frameSize[0], sy = layer.height / frameSize[1];
  g.strokeStyle = "#00e5ff"; g.lineWidth = 2; g.setLineDash([6, 4]);
  g.strokeRect(box.x * sx, box.y * sy, box.w * sx, box.h * sy);
}

layer.addEventListener("mousedown", (ev) => { dragStart = framePoint(ev); ev.preventDefault(); freeze(); });
window.addEventListener("mousemove", (ev) => {
  if (!dragStart) return;
  const p = framePoint(ev);
  box = {
    x: Math.round(Math.min(dragStart[0], p[0])), y: Math.round(Math.min(dragStart[1], p[1])),
    w: Math.round(Math.abs(p[0] - dragStart[0])), h: Math.round(Math.abs(p[1] - dragStart[1])),
  };
  drawBox();
});
window.addEventListener("mouseup", () => {
  if (!dragStart) return;
  dragStart = null;
  if (box && (box.w < 1 || box.h < 1)) box = null;
  $("teach-box").textContent = box ? `box: ${box.x},${box.y} ${box.w}x${box.h}` : "box: none";
  if (box) showBoxStatistics(box);
});

// the box's pixels in L*a*b*: mean, spread and a histogram per channel
async function showBoxStatistics(b) {
  const still = frozen || (await freezing);
  if (!still || b !== box) return;
  const r = await post("api/statistics", { frame: still.frame, x: b.x, y: b.y, w: b.w, h: b.h });
  if (!r || b !== box) return;
  $("box-stats").textContent = `${r.pixels} px  ` + ["L*", "a*", "b*"].map(
    (c, i) => `${c} ${r.mean[i].toFixed(1)} \u00b1 ${r.std[i].toFixed(1)}`).join("  ");
  const c = $("box-histogram"), g = c.getContext("2d");
  c.hidden = false;
  g.clearRect(0, 0, c.width, c.height);
  const rows = Object.entries(r.histograms), rh = c.height / rows.length;
  rows.forEach(([channel, h], k) => {
    const top = Math.max(1, ...h.counts), bw = (c.width - 24) / h.counts.length;
    g.fillStyle = "#ccc"; g.font = "11px sans-serif"; g.fillText(channel + "*", 2, k * rh + rh / 2 + 4);
    g.fillStyle = ["#e0e0e0", "#ff8a80", "#ffd54f"][k];
    h.counts.forEach((n, i) => {
      const bar = (n / top) * (rh - 4);
      g.fillRect(24 + i * bw, (k + 1) * rh - 2 - bar, Math.max(bw - 1, 1), bar);
    });
  });
}

// zoom: the video (and the box layer over it) 1, 2 or 4 times as wide,
// scrolled in its panel; boxes stay in frame pixels
$("zoom").addEventListener("change", () => {
  $("video-box").style.width = `${100 * Number($("zoom").value)}%`;
  drawBox();
});
window.addEventListener("resize", drawBox);

function knownClass(name) { return paletteClasses.find((c) => c.name === name); }
// the marker box follows the class named: ticked for a marker or a new
// class, not for a floor or background class (untick it after naming)
$("teach-class").addEventListener("input", () => {
  const known = knownClass($("teach-class").value.trim());
  $("teach-marker").checked = !known || known.role === "marker";
});
$("teach").addEventListener("click", async () => {
  const name = $("teach-class").value.trim();
  if (!box) { showMessage("drag a box on the video first", true); return; }
  if (!name) { showMessage("name the class to teach", true); return; }
  const still = frozen || (await freezing);
  const known = knownClass(name);
  const role = $("teach-marker").checked ? "marker"
    : (known && known.role !== "marker" ? known.role : "background");
  const reply = await post("api/teach", { class: name, x: box.x, y: box.y, w: box.w, h: box.h,
                                         role, frame: still ? still.frame : undefined });
  if (reply) {
    const lab = reply.class.lab.map((v) => v.toFixed(1)).join(", ");
    const warned = reply.warnings.length ? ` (${reply.warnings.length} warning(s) below)` : "";
    showMessage(`taught ${name}: L*a*b* ${lab}${warned}`, false);
  }
});
// the selected class: binary view, tolerance, rename, delete
function selectedClass() { return knownClass($("class-select").value); }
function showSelectedClass() {
  const c = selectedClass();
  if (c && document.activeElement !== $("tolerance")) $("tolerance").value = c.shading ? c.shading[1] : 1;
}
$("class-select").addEventListener("change", () => { showSelectedClass(); if (view === "binary") goLive(); });
async function editClass(action, to) {
  const name = $("class-select").value;
  const r = await post("api/class", { class: name, action, to });
  if (r) showMessage(`${action} ${name}` + (to !== undefined ? ` -> ${to}` : ""), false);
  return r;
}
$("tolerance").addEventListener("change", () => {
  if ($("tolerance").value.trim() !== "") editClass("tolerance", Number($("tolerance").value));
});
$("rename").addEventListener("click", async () => {
  const to = $("class-new-name").value.trim();
  if (!to) { showMessage("type the class's new name", true); return; }
  if (await editClass("rename", to)) { $("class-new-name").value = ""; $("class-select").value = to; showSelectedClass(); }
});
$("delete").addEventListener("click", () => editClass("delete"));
$("new-palette").addEventListener("click", async () => {
  if (await post("api/new-palette")) showMessage("the next boxes make a new palette", false);
});
$("undo").addEventListener("click", async () => {
  if (await post("api/undo")) showMessage("palette change undone", false);
});
$("save-palette").addEventListener("click", async () => {
  const r = await post("api/save-palette");
  if (r) showMessage("saved " + r.saved + " in the output folder", false);
});
$("save-config").addEventListener("click", async () => {
  const r = await post("api/save-config");
  if (r) showMessage("saved " + r.saved + " in the output folder", false);
});
for (const b of document.querySelectorAll("button[data-action]")) {
  b.addEventListener("click", async () => {
    const r = await post("api/control", { action: b.dataset.action });
    if (r) showMessage("", false);
  });
}

// ---- the source -------------------------------------------------------------

let currentSource = "start";
async function listSources() {
  const headers = token ? { Authorization: "Bearer " + token } : {};
  const reply = await (await fetch("api/sources", { headers })).json();
  $("source").replaceChildren(...reply.sources.map((src) => {
    const o = document.createElement("option");
    o.value = src.id; o.textContent = src.label;
    return o;
  }));
  currentSource = reply.current;
  $("source").value = currentSource;
}
listSources();
$("source").addEventListener("focus", listSources);      // cameras and files come and go
$("source").addEventListener("change", async () => {
  const r = await post("api/source", { id: $("source").value });
  if (r) { path = []; showMessage("playing " + r.current, false); }
  else $("source").value = currentSource;
});

// ---- scrubbing a file ------------------------------------------------------

let duration = null;
let scrubbing = false;
$("scrub").addEventListener("input", () => { scrubbing = true; });
$("scrub").addEventListener("change", async () => {
  scrubbing = false;
  await post("api/seek", { seconds: Number($("scrub").value) });
});

function showDuration(d) {
  duration = d;
  $("scrubber").hidden = !d;
  if (d) $("scrub").max = d;
}

// ---- the results ---------------------------------------------------------

function labToHex(lab) {   // CIE L*a*b* (D65) -> sRGB hex, for swatches
  const [L, a, b] = lab;
  const fy = (L + 16) / 116, fx = fy + a / 500, fz = fy - b / 200;
  const inv = (t) => (t > 6 / 29 ? t * t * t : 3 * (6 / 29) ** 2 * (t - 4 / 29));
  const X = 0.95047 * inv(fx), Y = inv(fy), Z = 1.08883 * inv(fz);
  const lin = [3.2406 * X - 1.5372 * Y - 0.4986 * Z, -0.9689 * X + 1.8758 * Y + 0.0415 * Z,
               0.0557 * X - 0.204 * Y + 1.057 * Z];
  return "#" + lin.map((c) => {
    const s = c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055;
    return Math.round(Math.min(Math.max(s, 0), 1) * 255).toString(16).padStart(2, "0");
  }).join("");
}

function drawHistogram(f) {
  const c = $("histogram"), g = c.getContext("2d");
  g.clearRect(0, 0, c.width, c.height);
  const n = f.classes.length;
  if (!n) return;
  // log scale, as the overlay draws it: the floor's tens of thousands of
  // pixels and a far marker's few dozen on one chart
  const scale = (v) => Math.log10(1 + v);
  const top = scale(Math.max(1, f.threshold || 0, ...f.classes.map((k) => k.count)));
  const bw = (c.width - 10) / n, base = c.height - 20;
  f.classes.forEach((k, i) => {
    const h = (scale(k.count) / top) * (base - 5);
    g.fillStyle = k.rgb;
    g.globalAlpha = k.active ? 1 : 0.45;
    g.fillRect(5 + i * bw + 2, base - h, bw - 4, h);
    g.globalAlpha = 1;
    g.fillStyle = "#ccc"; g.font = "11px sans-serif"; g.textAlign = "center";
    g.fillText(k.name, 5 + (i + 0.5) * bw, c.height - 6);
  });
  if (f.threshold) {
    const y = base - (scale(f.threshold) / top) * (base - 5);
    g.strokeStyle = "#ff5252"; g.setLineDash([5, 3]); g.beginPath();
    g.moveTo(0, y); g.lineTo(c.width, y); g.stroke(); g.setLineDash([]);
    g.fillStyle = "#ff5252"; g.textAlign = "left"; g.fillText("min-class-pixels " + f.threshold, 6, y - 3);
  }
}

function drawLamps(f) {
  const el = $("lamps");
  el.replaceChildren(...Object.entries(f.lamps).map(([name, on]) => {
    const d = document.createElement("span");
    d.className = "lamp" + (on ? " on" : "");
    const i = document.createElement("i");
    i.style.background = classColours[name] || "#888";
    d.append(i, name);
    return d;
  }));
}

function drawDetections(f) {
  const rows = f.detections.filter((d) => d.kept).map((d) => {
    const tr = document.createElement("tr");
    const cells = [d.class, d.range !== undefined ? d.range + " m" : "-",
                   d.bearing_deg !== undefined ? d.bearing_deg.toFixed(2) + "\u00b0" : "-",
                   d.landmark || "-"];
    for (const t of cells) { const td = document.createElement("td"); td.textContent = t; tr.append(td); }
    return tr;
  });
  $("detections").tBodies[0].replaceChildren(...rows);
  const p = f.pose;
  $("pose").textContent = p
    ? `pose: x ${p.x.toFixed(4)} m  y ${p.y.toFixed(4)} m  heading ${p.heading_deg.toFixed(2)}\u00b0` +
      (p.sigma_x !== null ? `  \u03c3 ${p.sigma_x.toFixed(3)}, ${p.sigma_y.toFixed(3)} m` : "") +
      `  (${p.solver})`
    : "pose: -";
  $("cost").textContent = "cost: " + (Object.entries(f.cost_ms || {})
    .map(([e, ms]) => `${e} ${ms.toFixed(1)}`).join(", ") || "-") + " ms";
}

function drawMinimap(f) {
  const c = $("minimap"), g = c.getContext("2d");
  g.fillStyle = "#111"; g.fillRect(0, 0, c.width, c.height);
  const pts = landmarks.map((l) => [l.x, l.y]).concat(path);
  if (!pts.length) { g.fillStyle = "#777"; g.fillText("no map (--map)", 10, 20); return; }
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  const x0 = Math.min(...xs) - 0.5, x1 = Math.max(...xs) + 0.5;
  const y0 = Math.min(...ys) - 0.5, y1 = Math.max(...ys) + 0.5;
  const s = Math.min((c.width - 20) / (x1 - x0), (c.height - 20) / (y1 - y0));
  const px = (x, y) => [10 + (x - x0) * s, c.height - 10 - (y - y0) * s];
  g.strokeStyle = "#2c2c2c"; g.lineWidth = 1;
  for (let gx = Math.ceil(x0); gx <= x1; gx++) { g.beginPath(); g.moveTo(...px(gx, y0)); g.lineTo(...px(gx, y1)); g.stroke(); }
  for (let gy = Math.ceil(y0); gy <= y1; gy++) { g.beginPath(); g.moveTo(...px(x0, gy)); g.lineTo(...px(x1, gy)); g.stroke(); }
  const byId = {};
  for (const l of landmarks) {
    byId[l.id] = l;
    const [u, v] = px(l.x, l.y);
    g.fillStyle = classColours[l.class] || "#888";
    g.beginPath(); g.arc(u, v, Math.max(4, ((l.diameter || 0.2) / 2) * s), 0, 2 * Math.PI); g.fill();
    g.fillStyle = "#ddd"; g.font = "11px sans-serif"; g.fillText(l.id, u + 6, v - 6);
  }
  if (f) for (const d of f.detections) {     // range circles around matched landmarks
    const l = d.landmark && byId[d.landmark];
    if (!l || d.range_m === undefined) continue;
    const [u, v] = px(l.x, l.y);
    g.strokeStyle = classColours[l.class] || "#888"; g.globalAlpha = 0.6;
    g.beginPath(); g.arc(u, v, d.range_m * s, 0, 2 * Math.PI); g.stroke(); g.globalAlpha = 1;
  }
  if (path.length > 1) {
    g.strokeStyle = "#7fd4ff"; g.beginPath(); g.moveTo(...px(...path[0]));
    for (const p of path) g.lineTo(...px(...p));
    g.stroke();
  }
  if (f && f.pose) {
    const [u, v] = px(f.pose.x, f.pose.y), h = (f.pose.heading_deg * Math.PI) / 180;
    if (f.pose.sigma_x !== null && f.pose.sigma_y !== null) {   // 3-sigma position
      g.strokeStyle = "#ffeb3b"; g.beginPath();
      g.ellipse(u, v, Math.max(3 * f.pose.sigma_x * s, 1), Math.max(3 * f.pose.sigma_y * s, 1), 0, 0, 2 * Math.PI);
      g.stroke();
    }
    g.fillStyle = "#fff"; g.beginPath(); g.arc(u, v, 4, 0, 2 * Math.PI); g.fill();
    g.strokeStyle = "#fff"; g.beginPath(); g.moveTo(u, v); g.lineTo(u + 16 * Math.cos(h), v - 16 * Math.sin(h)); g.stroke();
  }
}

function onFrame(f) {
  lastFrame = f;
  // a file's length is known once it plays: every frame carries it
  if ((f.duration || null) !== duration) showDuration(f.duration || null);
  if (duration && f.pts !== null) {
    if (!scrubbing) $("scrub").value = f.pts;
    $("position").textContent = `${f.pts.toFixed(2)} / ${duration.toFixed(2)} s`;
  }
  frameSize = [f.width, f.height];
  for (const k of f.classes) classColours[k.name] = k.rgb;
  if (f.pose && f.pose.x !== null) { path.push([f.pose.x, f.pose.y]); if (path.length > 2000) path.shift(); }
  $("fps").textContent = (f.fps ? f.fps.toFixed(1) : "-") + " frames/s";
  $("latency").textContent = Math.max(0, Math.round(Date.now() - f.time * 1000)) + " ms";
  drawHistogram(f); drawLamps(f); drawDetections(f); drawMinimap(f);
}

// ---- state: controls, tuning and the palette -------------------------------

function tuneControl(element, spec) {
  const row = document.createElement("div");
  row.className = "tune-row";
  const label = document.createElement("label");
  label.textContent = spec.name; label.title = spec.blurb || "";
  let input;
  if (spec.type === "boolean") {
    input = document.createElement("input"); input.type = "checkbox";
  } else if (spec.type === "enum") {
    input = document.createElement("select");
    for (const c of spec.choices) { const o = document.createElement("option"); o.textContent = c; input.append(o); }
  } else {
    input = document.createElement("input"); input.type = "number";
    input.min = spec.minimum; input.max = spec.maximum;
    input.step = spec.type === "integer" ? 1 : "any";
  }
  input.id = `tune-${element}-${spec.name}`;
  const error = document.createElement("span");
  error.className = "tune-error"; error.setAttribute("role", "alert");
  input.addEventListener("change", async () => {
    let value = input.type === "checkbox" ? input.checked : input.value;
    if (spec.type === "integer" || spec.type === "number") {
      if (value.trim() === "") return;       // being edited (or not a number)
      value = Number(value);
    }
    error.textContent = "";
    // refused: the reason beside the field, the value in force back in it
    const r = await post("api/tune", { element, property: spec.name, value }, (text) => {
      error.textContent = text;
      showTuneValue(input, tuneValues[input.id]);
    });
    if (r) showMessage(`${element}.${spec.name} = ${JSON.stringify(r.applied[0].value)}`, false);
  });
  if (spec.from) label.textContent += ` (${spec.from})`;
  row.append(label, input);
  if (spec.minimum !== undefined) {
    const range = document.createElement("span");
    const show = (v) => (Math.abs(v) >= 1e9 ? "no limit" : String(v));
    range.className = "range"; range.textContent = `${show(spec.minimum)} .. ${show(spec.maximum)}`;
    row.append(range);
  }
  row.append(error);
  return row;
}

const tuneValues = {};       // input id -> the value in force
function showTuneValue(input, value) {
  if (input.type === "checkbox") input.checked = value; else input.value = value;
}
function setTuneValue(element, spec) {
  const input = $(`tune-${element}-${spec.name}`);
  if (!input) return;
  tuneValues[input.id] = spec.value;
  if (input !== document.activeElement) showTuneValue(input, spec.value);
}

function onState(s) {
  const badge = $("state");
  badge.textContent = s.state + (s.error ? ": " + s.error : "");
  badge.className = "badge " + s.state;
  if (s.error) showMessage(s.error, true);
  landmarks = s.landmarks || [];
  showDuration(s.duration || null);
  if (s.source && s.source !== currentSource) { currentSource = s.source; $("source").value = s.source; }
  if (s.path) path = s.path.slice();
  const shape = JSON.stringify(Object.entries(s.tunables).map(([e, l]) => [e, l.map((p) => p.name)]));
  if (shape !== tunablesShape) {
    tunablesShape = shape;
    $("tunables").replaceChildren(...Object.entries(s.tunables).map(([element, specs]) => {
      const fs = document.createElement("fieldset");
      const lg = document.createElement("legend"); lg.textContent = element; fs.append(lg);
      for (const spec of specs) fs.append(tuneControl(element, spec));
      return fs;
    }));
  }
  for (const [element, specs] of Object.entries(s.tunables)) for (const spec of specs) setTuneValue(element, spec);
  const classes = s.palette.classes;
  paletteClasses = classes;
  $("class-names").replaceChildren(...classes.map((c) => { const o = document.createElement("option"); o.value = c.name; return o; }));
  $("palette").replaceChildren(...classes.map((c) => {
    const li = document.createElement("li");
    const i = document.createElement("i"); i.style.background = labToHex(c.lab);
    li.append(i, `${c.name}${c.role === "marker" ? "" : ` (${c.role})`}  L*a*b* ${c.lab.map((v) => v.toFixed(1)).join(", ")}`);
    return li;
  }));
  $("undo").disabled = !s.can_undo;
  const chosen = $("class-select").value;
  $("class-select").replaceChildren(...classes.map((c) => {
    const o = document.createElement("option"); o.value = o.textContent = c.name; return o;
  }));
  if (knownClass(chosen)) $("class-select").value = chosen;
  showSelectedClass();
  const t = s.teaching;
  $("taught").textContent = t.boxes
    ? `${t.boxes} box(es) on ${t.frames} frame(s)` + (t.beside.length ? ", beside the palette's other classes" : "")
    : (t.beside.length ? "" : "new palette: the next box starts it");
  $("teach-warnings").replaceChildren(...t.warnings.map((w) => {
    const li = document.createElement("li"); li.textContent = "warning: " + w; return li;
  }));
  drawMinimap(lastFrame);
}

function connect() {
  const url = new URL("ws", location.href);        // beside the page
  url.protocol = url.protocol.replace("http", "ws");
  url.search = "";
  const ws = new WebSocket(withToken(url.href));
  ws.onmessage = (ev) => {
    const m = JSON.parse(ev.data);
    if (m.type === "frame") onFrame(m);
    else if (m.type === "state") onState(m);
    else if (m.type === "error") showMessage(m.error, true);
  };
  ws.onclose = () => {
    $("state").textContent = "disconnected"; $("state").className = "badge disconnected";
    setTimeout(connect, 1000);
  };
}
connect();
