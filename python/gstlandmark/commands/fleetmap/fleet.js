// The live fleet map: the server pushes {"type": "map"} once and
// {"type": "fleet"} when the fleet changed; each robot's path comes as
// the points added since the last push, kept here up to path-length.
"use strict";

const canvas = document.getElementById("map");
const g = canvas.getContext("2d");
const robots = {};          // name -> latest fields
const paths = {};           // name -> [[x, y, heading, wall-time], ...]
let landmarks = [];
let fleetTime = null;
// what the page drew last, for tests and scripts: {robots: [names]}
window.fleetDrawn = {robots: []};

// Each robot's hue: the golden angle (137.5 degrees) times its rank in
// the order the page first saw the robots, so any few robots (r1, r2, r3)
// are far apart on the colour wheel and a robot keeps its colour while
// the page is open. (A hash of the name put r1, r2, r3 one degree apart.)
const hueRank = new Map();
function colour(name) {
  if (!hueRank.has(name)) hueRank.set(name, hueRank.size);
  const h = (hueRank.get(name) * 137.50776405) % 360;
  return `hsl(${h.toFixed(1)}, 70%, 42%)`;
}

function take(msg) {
  if (msg.type === "map") {
    landmarks = msg.landmarks;
    return;
  }
  fleetTime = msg["wall-time"];
  for (const [name, r] of Object.entries(msg.robots)) {
    robots[name] = r;
    const p = paths[name] || (paths[name] = []);
    p.push(...r["path-new"]);
    if (p.length > msg["path-length"]) p.splice(0, p.length - msg["path-length"]);
  }
  document.getElementById("summary").textContent =
    (n => `${n} robot${n === 1 ? "" : "s"}, delay p95 `)(
      Object.keys(robots).length) +
    (msg.delay.p95 === null ? "-" : `${(msg.delay.p95 * 1000).toFixed(1)} ms`);
}

// the 2x2 (x, y) block of the row-major 3x3 covariance as an ellipse:
// half axes at 2 sigma along the eigenvectors
function ellipse(cov) {
  const a = cov[0], b = cov[1], d = cov[4];
  const mean = (a + d) / 2, diff = Math.sqrt(((a - d) / 2) ** 2 + b * b);
  const l1 = Math.max(mean + diff, 0), l2 = Math.max(mean - diff, 0);
  return {rx: 2 * Math.sqrt(l1), ry: 2 * Math.sqrt(l2),
          angle: 0.5 * Math.atan2(2 * b, a - d)};
}

function bounds() {
  const xs = [], ys = [];
  for (const m of landmarks) { xs.push(m.x); ys.push(m.y); }
  for (const name in paths) {
    for (const p of paths[name]) { xs.push(p[0]); ys.push(p[1]); }
    const pose = robots[name].pose;
    if (pose) { xs.push(pose.x); ys.push(pose.y); }
  }
  if (!xs.length) return {x0: 0, y0: 0, x1: 10, y1: 10};
  const m = 0.5;
  return {x0: Math.min(...xs) - m, y0: Math.min(...ys) - m,
          x1: Math.max(...xs) + m, y1: Math.max(...ys) + m};
}

function draw() {
  const w = canvas.width, h = canvas.height, b = bounds();
  const s = Math.min(w / (b.x1 - b.x0), h / (b.y1 - b.y0));
  // metres to pixels, y up
  const u = x => (x - b.x0) * s, v = y => h - (y - b.y0) * s;
  g.clearRect(0, 0, w, h);
  g.strokeStyle = "#eee"; g.lineWidth = 1;
  for (let x = Math.ceil(b.x0); x <= b.x1; x++) {
    g.beginPath(); g.moveTo(u(x), 0); g.lineTo(u(x), h); g.stroke();
  }
  for (let y = Math.ceil(b.y0); y <= b.y1; y++) {
    g.beginPath(); g.moveTo(0, v(y)); g.lineTo(w, v(y)); g.stroke();
  }
  g.font = "12px sans-serif";
  for (const m of landmarks) {
    g.fillStyle = "#666";
    g.beginPath();
    g.arc(u(m.x), v(m.y), Math.max(m.diameter / 2 * s, 3), 0, 2 * Math.PI);
    g.fill();
    g.fillText(m.id, u(m.x) + 6, v(m.y) - 6);
  }
  const drawn = [];
  for (const name of Object.keys(robots).sort()) {
    const r = robots[name], p = paths[name], c = colour(name);
    const gone = r.status === "offline";
    g.strokeStyle = c; g.globalAlpha = gone ? 0.35 : 1; g.lineWidth = 1.5;
    if (p.length > 1) {
      g.beginPath();
      g.moveTo(u(p[0][0]), v(p[0][1]));
      for (const q of p) g.lineTo(u(q[0]), v(q[1]));
      g.stroke();
    }
    const pose = r.pose;
    if (pose && typeof pose.x === "number") {
      const x = u(pose.x), y = v(pose.y), hd = pose.heading || 0;
      if (Array.isArray(pose.covariance) && pose.covariance.length === 9) {
        const e = ellipse(pose.covariance);
        g.beginPath();
        g.ellipse(x, y, Math.max(e.rx * s, 1), Math.max(e.ry * s, 1),
                  -e.angle, 0, 2 * Math.PI);
        g.stroke();
      }
      g.fillStyle = c;
      g.beginPath(); g.arc(x, y, 5, 0, 2 * Math.PI); g.fill();
      g.beginPath(); g.moveTo(x, y);
      g.lineTo(x + 18 * Math.cos(hd), y - 18 * Math.sin(hd)); g.stroke();
      g.fillText(name, x + 8, y + 14);
      drawn.push(name);
    }
    g.globalAlpha = 1;
  }
  window.fleetDrawn = {robots: drawn};
}

function cell(text, cls) {
  const td = document.createElement("td");
  td.textContent = text;
  if (cls) td.className = cls;
  return td;
}

function table() {
  const body = document.querySelector("#robots tbody");
  body.replaceChildren();
  for (const name of Object.keys(robots).sort()) {
    const r = robots[name], tr = document.createElement("tr");
    const first = cell(name);
    const sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = colour(name);
    first.prepend(sw);
    tr.append(first, cell(r.status || "?", r.status || ""),
              cell(r.frames), cell(r["missed-frames"]),
              cell(r.delay === null ? "-" : `${(r.delay * 1000).toFixed(1)} ms`),
              cell(r["last-wall-time"] === null || fleetTime === null ? "-" :
                   `${(fleetTime - r["last-wall-time"]).toFixed(1)} s ago`),
              cell(r.pose && typeof r.pose.x === "number" ?
                   `${r.pose.x.toFixed(2)}, ${r.pose.y.toFixed(2)}, ` +
                   `${((r.pose.heading || 0) * 180 / Math.PI).toFixed(0)}°` : "-"));
    body.append(tr);
  }
}

function connect() {
  const link = document.getElementById("link");
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}:` +
                           `//${location.host}/ws`);
  ws.onopen = () => {
    // a new socket sends every kept point again
    for (const name in paths) delete paths[name];
    link.textContent = "live"; link.className = "online";
  };
  ws.onmessage = e => {
    take(JSON.parse(e.data));
    requestAnimationFrame(() => { draw(); table(); });
  };
  ws.onclose = () => {
    link.textContent = "disconnected, retrying"; link.className = "offline";
    setTimeout(connect, 2000);
  };
}

draw();
connect();
