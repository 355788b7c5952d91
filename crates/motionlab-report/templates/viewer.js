"use strict";
// motionlab viewer: plays a motion back as a 3-D stick figure above time-aligned lanes.
// Data format: see crates/motionlab-report/src/viewer.rs. No library, no network.
(function () {
const t0 = performance.now();
const meta = JSON.parse(document.getElementById("viewer-meta").textContent);
const N = meta.n_frames, P = meta.point_names.length, RATE = meta.frame_rate_hz;
const COLORS = { matched: "#2ca02c", false_positive: "#d62728", missed: "#ff7f0e", none: "#5b6b7f" };
const KIND_COLORS = { candidates: "#1f77b4", fused: "#6a3d9a", truth: "#111111", other: "#8c564b", annotation: "#0b5cad" };
const SERIES_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"];

const state = {
  frame: 0, playing: false, speed: 1, pos: 0, activeLane: -1,
  yaw: 0.65, pitch: 0.32, dist: 4000, follow: true,
  view0: 0, view1: Math.max(1, N - 1), ready: false, openMs: NaN,
};

function fail(msg) {
  const e = document.getElementById("error");
  e.textContent = msg;
  e.style.display = "block";
}

function base64Bytes(text) {
  const s = atob(text.trim());
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
  return out;
}

async function inflate(bytes) {
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

// One channel: N low bytes then N high bytes of wrapping deltas of 16-bit codes.
function decodeChannel(raw, off, q, out, base, stride) {
  let code = 0;
  for (let f = 0; f < N; f++) {
    code = (code + (raw[off + f] | (raw[off + N + f] << 8))) & 0xffff;
    out[base + f * stride] = code === 0 ? NaN : q.offset + (code - 1) * q.step;
  }
  return off + 2 * N;
}

// ---- geometry -------------------------------------------------------------------------------
const UP = meta.up_axis;
const FLOOR = [[1, 2], [0, 2], [0, 1]][UP];
// View space is y-up; keep the data's handedness (x, y, z) → (a, up, ±b).
const FLIP = ((FLOOR[0] + 1) % 3 === UP && (UP + 1) % 3 === FLOOR[1]) ? 1 : -1;
let pos = null; // Float32Array N*P*3 in view space
let floorY = 0, bodyHeight = 1800, pathBox = [0, 0, 0, 0];

function toView(raw) {
  pos = new Float32Array(N * P * 3);
  for (let i = 0; i < N * P; i++) {
    pos[3 * i] = raw[3 * i + FLOOR[0]];
    pos[3 * i + 1] = raw[3 * i + UP];
    pos[3 * i + 2] = FLIP * raw[3 * i + FLOOR[1]];
  }
  let lo = Infinity, hi = -Infinity;
  for (let i = 1; i < pos.length; i += 3) {
    const v = pos[i];
    if (v === v) { if (v < lo) lo = v; if (v > hi) hi = v; }
  }
  floorY = isFinite(lo) ? lo : 0;
  // Height of the figure: the median over frames of each frame's top − bottom.
  const hs = [];
  for (let f = 0; f < N; f += Math.max(1, Math.floor(N / 200))) {
    let a = Infinity, b = -Infinity;
    for (let k = 0; k < P; k++) { const v = pos[(f * P + k) * 3 + 1]; if (v === v) { if (v < a) a = v; if (v > b) b = v; } }
    if (b > a) hs.push(b - a);
  }
  hs.sort((x, y) => x - y);
  bodyHeight = hs.length ? Math.max(300, hs[hs.length >> 1]) : 1800;
  state.dist = bodyHeight * 2.6;
  let x0 = Infinity, x1 = -Infinity, z0 = Infinity, z1 = -Infinity;
  for (let f = 0; f < N; f++) {
    const c = centre(f);
    if (c) { x0 = Math.min(x0, c[0]); x1 = Math.max(x1, c[0]); z0 = Math.min(z0, c[2]); z1 = Math.max(z1, c[2]); }
  }
  pathBox = isFinite(x0) ? [x0, x1, z0, z1] : [-1000, 1000, -1000, 1000];
}

// The followed point at frame f: the root, else the centroid of the finite points.
function centre(f) {
  if (meta.root !== null && meta.root !== undefined) {
    const i = (f * P + meta.root) * 3;
    if (pos[i] === pos[i]) return [pos[i], pos[i + 1], pos[i + 2]];
  }
  let s = [0, 0, 0], n = 0;
  for (let k = 0; k < P; k++) {
    const i = (f * P + k) * 3;
    if (pos[i] === pos[i]) { s[0] += pos[i]; s[1] += pos[i + 1]; s[2] += pos[i + 2]; n++; }
  }
  return n ? [s[0] / n, s[1] / n, s[2] / n] : null;
}

// ---- 3-D scene --------------------------------------------------------------------------------
const scene = document.getElementById("scene");
const sctx = scene.getContext("2d");
let target = [0, 0, 0];

function camera(w, h) {
  const cp = Math.cos(state.pitch);
  const eye = [target[0] + state.dist * cp * Math.sin(state.yaw), target[1] + state.dist * Math.sin(state.pitch), target[2] + state.dist * cp * Math.cos(state.yaw)];
  const f = norm([target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]]);
  const r = norm([-f[2], 0, f[0]]); // f × (0,1,0)
  const u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]];
  const focal = h / (2 * Math.tan(22.5 * Math.PI / 180));
  return { eye, f, r, u, focal, cx: w / 2, cy: h / 2 };
}
function norm(v) { const l = Math.hypot(v[0], v[1], v[2]) || 1; return [v[0] / l, v[1] / l, v[2] / l]; }
function toCam(c, x, y, z) {
  const dx = x - c.eye[0], dy = y - c.eye[1], dz = z - c.eye[2];
  return [dx * c.r[0] + dy * c.r[1] + dz * c.r[2], dx * c.u[0] + dy * c.u[1] + dz * c.u[2], dx * c.f[0] + dy * c.f[1] + dz * c.f[2]];
}
const NEAR = 50;
function screen(c, p) { return [c.cx + c.focal * p[0] / p[2], c.cy - c.focal * p[1] / p[2]]; }
// A segment in camera space, clipped at the near plane; null when behind the camera.
function segment(c, a, b) {
  if (a[2] < NEAR && b[2] < NEAR) return null;
  if (a[2] < NEAR || b[2] < NEAR) {
    const t = (NEAR - a[2]) / (b[2] - a[2]);
    const m = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), NEAR];
    if (a[2] < NEAR) a = m; else b = m;
  }
  return [screen(c, a), screen(c, b)];
}
function line3(ctx, c, x0, y0, z0, x1, y1, z1) {
  const s = segment(c, toCam(c, x0, y0, z0), toCam(c, x1, y1, z1));
  if (s) { ctx.moveTo(s[0][0], s[0][1]); ctx.lineTo(s[1][0], s[1][1]); }
}

function gridStep() {
  const span = Math.max(pathBox[1] - pathBox[0], pathBox[3] - pathBox[2], bodyHeight * 2);
  return span > 20000 ? 2000 : span > 8000 ? 1000 : 500;
}

function drawScene() {
  const dpr = window.devicePixelRatio || 1;
  const w = scene.clientWidth, h = scene.clientHeight;
  if (scene.width !== Math.round(w * dpr) || scene.height !== Math.round(h * dpr)) { scene.width = Math.round(w * dpr); scene.height = Math.round(h * dpr); }
  const ctx = sctx;
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const f = state.frame;
  const c0 = centre(f);
  if (state.follow && c0) target = [c0[0], floorY + bodyHeight * 0.5, c0[2]];
  else if (!state.follow && !state.targetSet) target = [(pathBox[0] + pathBox[1]) / 2, floorY + bodyHeight * 0.5, (pathBox[2] + pathBox[3]) / 2];
  const c = camera(w, h);
  // Floor grid around the path (and around the figure).
  const step = gridStep(), m = step * 2;
  const gx0 = Math.floor((Math.min(pathBox[0], target[0] - 2 * bodyHeight) - m) / step) * step, gx1 = Math.ceil((Math.max(pathBox[1], target[0] + 2 * bodyHeight) + m) / step) * step;
  const gz0 = Math.floor((Math.min(pathBox[2], target[2] - 2 * bodyHeight) - m) / step) * step, gz1 = Math.ceil((Math.max(pathBox[3], target[2] + 2 * bodyHeight) + m) / step) * step;
  ctx.lineWidth = 1;
  ctx.strokeStyle = "#c9d0d8";
  ctx.beginPath();
  for (let x = gx0; x <= gx1; x += step) line3(ctx, c, x, floorY, gz0, x, floorY, gz1);
  for (let z = gz0; z <= gz1; z += step) line3(ctx, c, gx0, floorY, z, gx1, floorY, z);
  ctx.stroke();
  // Root path on the floor: travelled part dark, the rest light.
  const every = Math.max(1, Math.ceil(N / 3000));
  for (const [a, b, col, wid] of [[0, f, "#3b6ea8", 2], [f, N - 1, "#a9bdd4", 1.5]]) {
    ctx.strokeStyle = col; ctx.lineWidth = wid; ctx.beginPath();
    let prev = null;
    for (let k = a; k <= b; k = (k === b ? b + 1 : Math.min(b, k + every))) {
      const p = centre(k);
      if (p && prev) line3(ctx, c, prev[0], floorY, prev[2], p[0], floorY, p[2]);
      prev = p;
    }
    ctx.stroke();
  }
  // Shadow, bones, joints.
  const base = f * P * 3;
  const cam = new Array(P);
  for (let k = 0; k < P; k++) {
    const i = base + 3 * k;
    cam[k] = pos[i] === pos[i] ? toCam(c, pos[i], pos[i + 1], pos[i + 2]) : null;
  }
  ctx.strokeStyle = "rgba(60,70,90,0.18)"; ctx.lineWidth = 3; ctx.beginPath();
  for (const [a, b] of meta.bones) {
    const ia = base + 3 * a, ib = base + 3 * b;
    if (pos[ia] === pos[ia] && pos[ib] === pos[ib]) line3(ctx, c, pos[ia], floorY, pos[ia + 2], pos[ib], floorY, pos[ib + 2]);
  }
  ctx.stroke();
  ctx.strokeStyle = "#1d2733"; ctx.lineWidth = 3; ctx.lineCap = "round"; ctx.beginPath();
  for (const [a, b] of meta.bones) {
    if (!cam[a] || !cam[b]) continue;
    const s = segment(c, cam[a], cam[b]);
    if (s) { ctx.moveTo(s[0][0], s[0][1]); ctx.lineTo(s[1][0], s[1][1]); }
  }
  ctx.stroke();
  const r = meta.bones.length ? 2.6 : 3.5;
  for (let k = 0; k < P; k++) {
    if (!cam[k] || cam[k][2] < NEAR) continue;
    const s = screen(c, cam[k]);
    ctx.fillStyle = k === meta.root ? "#d62728" : "#3b6ea8";
    ctx.beginPath(); ctx.arc(s[0], s[1], k === meta.root ? r + 1.5 : r, 0, 2 * Math.PI); ctx.fill();
  }
  const marks = marksAt(f);
  document.getElementById("hud").textContent = `frame ${f} / ${N - 1} · ${(f / RATE).toFixed(2)} s` + (marks.length ? " · " + marks.join(", ") : "");
}

// "lane: status" of every mark exactly at frame f.
function marksAt(f) {
  const out = [];
  meta.lanes.forEach(l => {
    if (l.type !== "events") return;
    for (const m of l.marks) if (m.frame === f) out.push(l.name + (m.status ? " (" + m.status.replace("_", " ") + ")" : ""));
  });
  return out;
}

// ---- lanes ------------------------------------------------------------------------------------
const lanesCanvas = document.getElementById("lanes");
const lctx = lanesCanvas.getContext("2d");
const LABEL_W = 170, AXIS_H = 24;
const laneBoxes = []; // {index, y, h}
let lanesImage = null; // offscreen canvas with everything but the playhead

function laneHeight(l) { return l.type === "trace" ? 74 : l.kind === "annotation" ? 32 : 24; }
function xOf(f, w) { return LABEL_W + (f - state.view0) / (state.view1 - state.view0) * (w - LABEL_W - 10); }
function frameOf(x, w) { return state.view0 + (x - LABEL_W) / (w - LABEL_W - 10) * (state.view1 - state.view0); }

function layoutLanes() {
  laneBoxes.length = 0;
  let y = 4;
  meta.lanes.forEach((l, i) => { if (l.hidden) return; const h = laneHeight(l); laneBoxes.push({ index: i, y, h }); y += h + 4; });
  const total = y + AXIS_H;
  lanesCanvas.style.height = total + "px";
  return total;
}

function niceStep(span, target) {
  const raw = span / target, p = Math.pow(10, Math.floor(Math.log10(raw)));
  for (const m of [1, 2, 5, 10]) if (m * p >= raw) return m * p;
  return 10 * p;
}

function drawLanesImage() {
  const dpr = window.devicePixelRatio || 1;
  const w = lanesCanvas.clientWidth, h = layoutLanes();
  if (!lanesImage) lanesImage = document.createElement("canvas");
  lanesImage.width = Math.round(w * dpr); lanesImage.height = Math.round(h * dpr);
  lanesCanvas.width = lanesImage.width; lanesCanvas.height = lanesImage.height;
  const ctx = lanesImage.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, w, h);
  ctx.font = "12px " + getComputedStyle(document.body).fontFamily;
  const v0 = state.view0, v1 = state.view1;
  for (const box of laneBoxes) {
    const l = meta.lanes[box.index];
    const active = box.index === state.activeLane;
    ctx.fillStyle = active ? "#e8f0fb" : (box.index % 2 ? "#fafbfc" : "#f3f5f8");
    ctx.fillRect(0, box.y, w, box.h);
    ctx.fillStyle = active ? "#0b5cad" : "#222";
    ctx.font = (active ? "bold " : "") + "12px " + getComputedStyle(document.body).fontFamily;
    ctx.textBaseline = "middle";
    const label = l.type === "trace" && l.unit ? `${l.name} (${l.unit})`.replace(`(${l.unit}) (${l.unit})`, `(${l.unit})`) : l.name;
    if (l.type === "trace" && !active) ctx.fillStyle = "#555";
    ctx.fillText(label.length > 24 ? label.slice(0, 23) + "…" : label, l.type === "trace" ? 16 : 6, box.y + Math.min(12, box.h / 2));
    ctx.save();
    ctx.beginPath(); ctx.rect(LABEL_W, box.y, w - LABEL_W, box.h); ctx.clip();
    if (l.type === "events") drawEventLane(ctx, l, box, w);
    else if (l.type === "trace") drawTraceLane(ctx, l, box, w);
    else drawIntervalLane(ctx, l, box, w);
    ctx.restore();
  }
  // Time axis in seconds.
  const yA = h - AXIS_H + 2;
  ctx.strokeStyle = "#888"; ctx.fillStyle = "#444"; ctx.lineWidth = 1; ctx.textBaseline = "top";
  ctx.beginPath(); ctx.moveTo(LABEL_W, yA); ctx.lineTo(w - 10, yA); ctx.stroke();
  const s0 = v0 / RATE, s1 = v1 / RATE, st = niceStep(s1 - s0, Math.max(2, (w - LABEL_W) / 90));
  for (let s = Math.ceil(s0 / st) * st; s <= s1 + 1e-9; s += st) {
    const x = xOf(s * RATE, w);
    ctx.beginPath(); ctx.moveTo(x, yA); ctx.lineTo(x, yA + 4); ctx.stroke();
    ctx.fillText((st < 1 ? s.toFixed(st < 0.1 ? 2 : 1) : s.toFixed(0)) + " s", x - 10, yA + 6);
  }
  ctx.fillText("time", 6, yA + 6);
}

function statusColor(m, l) { return m.status ? COLORS[m.status] : (KIND_COLORS[l.kind] || COLORS.none); }

function drawEventLane(ctx, l, box, w) {
  const unit = (w - LABEL_W - 10) / (state.view1 - state.view0);
  ctx.fillStyle = "rgba(0,0,0,0.10)";
  for (const [a, b] of l.windows) ctx.fillRect(xOf(a, w), box.y + 2, Math.max(1, (b - a) * unit), box.h - 4);
  if (l.tolerance_frames) {
    ctx.fillStyle = "rgba(70,110,170,0.16)";
    for (const m of l.marks) ctx.fillRect(xOf(m.frame - l.tolerance_frames, w), box.y + 2, 2 * l.tolerance_frames * unit, box.h - 4);
  }
  for (const m of l.marks) {
    const x = Math.round(xOf(m.frame, w)) + 0.5;
    ctx.strokeStyle = statusColor(m, l);
    ctx.lineWidth = m.status === "missed" ? 2 : 2;
    ctx.setLineDash(m.status === "missed" ? [3, 2] : []);
    ctx.beginPath(); ctx.moveTo(x, box.y + 3); ctx.lineTo(x, box.y + box.h - 3); ctx.stroke();
  }
  ctx.setLineDash([]);
  // Other annotators' marks (loaded from a file), thin and grey under yours.
  if (l.others && l.others.length) {
    ctx.strokeStyle = "#9aa5b1"; ctx.lineWidth = 1;
    ctx.beginPath();
    for (const m of l.others) { const x = Math.round(xOf(m.frame, w)) + 0.5; ctx.moveTo(x, box.y + box.h / 2); ctx.lineTo(x, box.y + box.h - 2); }
    ctx.stroke();
  }
}

function traceRange(l, data) {
  if (l._range) return l._range;
  let lo = Infinity, hi = -Infinity;
  for (const s of data) for (let f = 0; f < N; f++) { const v = s[f]; if (v === v) { if (v < lo) lo = v; if (v > hi) hi = v; } }
  for (const [, v] of l.thresholds) if (isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
  if (!isFinite(lo)) { lo = 0; hi = 1; }
  if (hi - lo < 1e-12) { hi = lo + 1; }
  return (l._range = [lo, hi]);
}

function drawTraceLane(ctx, l, box, w) {
  const data = l._data;
  const [lo, hi] = traceRange(l, data);
  const yOf = v => box.y + box.h - 4 - (v - lo) / (hi - lo) * (box.h - 8);
  ctx.fillStyle = "#777"; ctx.textBaseline = "top"; ctx.font = "10px " + getComputedStyle(document.body).fontFamily;
  ctx.fillText(fmt(hi), LABEL_W + 2, box.y + 1);
  ctx.textBaseline = "bottom"; ctx.fillText(fmt(lo), LABEL_W + 2, box.y + box.h - 1);
  const x0 = LABEL_W, x1 = w - 10;
  data.forEach((s, k) => {
    ctx.strokeStyle = SERIES_COLORS[k % SERIES_COLORS.length]; ctx.lineWidth = 1.2; ctx.beginPath();
    // Per pixel column: the min and max of its frames (every sample counts at any zoom).
    let pen = false;
    for (let x = x0; x < x1; x++) {
      const fa = Math.max(0, Math.floor(frameOf(x, w))), fb = Math.min(N - 1, Math.floor(frameOf(x + 1, w)));
      let a = Infinity, b = -Infinity;
      for (let f = fa; f <= Math.max(fa, fb); f++) { const v = s[f]; if (v === v) { if (v < a) a = v; if (v > b) b = v; } }
      if (!isFinite(a)) { pen = false; continue; }
      if (!pen) { ctx.moveTo(x, yOf(a)); pen = true; } else ctx.lineTo(x, yOf(a));
      if (b !== a) ctx.lineTo(x, yOf(b));
    }
    ctx.stroke();
  });
  ctx.setLineDash([6, 4]); ctx.strokeStyle = "#555"; ctx.lineWidth = 1;
  ctx.textBaseline = "bottom";
  l.thresholds.forEach(([name, v], k) => {
    const y = Math.round(yOf(v)) + 0.5;
    ctx.beginPath(); ctx.moveTo(x0, y); ctx.lineTo(x1, y); ctx.stroke();
    const text = `${name} = ${fmt(v)}`, tw = ctx.measureText(text).width;
    const tx = x1 - 8 - tw - k * 150;
    ctx.fillStyle = "rgba(255,255,255,0.8)"; ctx.fillRect(tx - 2, y - 12, tw + 4, 11);
    ctx.fillStyle = "#333"; ctx.fillText(text, tx, y - 1);
  });
  ctx.setLineDash([]);
  // Legend of the series.
  ctx.textBaseline = "top";
  let lx = LABEL_W + 60;
  data.forEach((s, k) => {
    const name = l.series[k][0];
    ctx.fillStyle = SERIES_COLORS[k % SERIES_COLORS.length]; ctx.fillRect(lx, box.y + 5, 10, 3);
    ctx.fillStyle = "#333"; ctx.fillText(name, lx + 13, box.y + 1); lx += 22 + ctx.measureText(name).width;
  });
}

function drawIntervalLane(ctx, l, box, w) {
  l.intervals.forEach(([a, b, label], k) => {
    const x = xOf(a, w), x2 = xOf(b + 1, w);
    ctx.fillStyle = l.kind === "matched" ? "rgba(44,160,44,0.45)" : (k % 2 ? "rgba(31,119,180,0.35)" : "rgba(31,119,180,0.55)");
    ctx.fillRect(x, box.y + 4, Math.max(1, x2 - x), box.h - 8);
    // Clipped to its stretch (long labels — a repetition's H, R and rank — show whole on hover).
    if (label && x2 - x > 40) {
      ctx.save(); ctx.beginPath(); ctx.rect(x, box.y, x2 - x - 2, box.h); ctx.clip();
      ctx.fillStyle = "#123"; ctx.textBaseline = "middle"; ctx.fillText(label, x + 3, box.y + box.h / 2);
      ctx.restore();
    }
  });
}

function fmt(v) {
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e7)) return v.toExponential(2);
  return a >= 1000 ? v.toFixed(0) : a >= 100 ? v.toFixed(1) : a >= 10 ? v.toFixed(2) : v.toFixed(3);
}

function drawLanes() {
  if (!lanesImage) drawLanesImage();
  const dpr = window.devicePixelRatio || 1;
  const w = lanesCanvas.clientWidth, h = lanesImage.height / dpr;
  lctx.setTransform(1, 0, 0, 1, 0, 0);
  lctx.drawImage(lanesImage, 0, 0);
  lctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  const x = Math.round(xOf(state.frame, w)) + 0.5;
  if (x >= LABEL_W && x <= w - 10) {
    // Dark and thin, with a handle on the axis: it must not hide a mark's status colour.
    lctx.strokeStyle = "rgba(20,20,20,0.8)"; lctx.lineWidth = 1;
    lctx.beginPath(); lctx.moveTo(x, 0); lctx.lineTo(x, h - AXIS_H + 2); lctx.stroke();
    lctx.fillStyle = "#222";
    lctx.beginPath(); lctx.moveTo(x - 5, h - AXIS_H + 2); lctx.lineTo(x + 5, h - AXIS_H + 2); lctx.lineTo(x, h - AXIS_H - 5); lctx.fill();
  }
  annoDrawNearest(lctx, w);
}

// ---- marks list -------------------------------------------------------------------------------
// (Re)built whenever marks change; lanes keep their open or closed state.
function buildList() {
  const list = document.getElementById("list");
  const open = new Map([...list.querySelectorAll("details")].map(d => [d.dataset.name, d.open]));
  list.textContent = "";
  meta.lanes.forEach((l, i) => {
    if (l.type !== "events" || l.hidden) return;
    const counts = {};
    for (const m of l.marks) counts[m.status || "none"] = (counts[m.status || "none"] || 0) + 1;
    const d = document.createElement("details");
    d.dataset.name = l.kind === "annotation" ? "\u0000annotation" : l.name;
    d.open = open.has(d.dataset.name) ? open.get(d.dataset.name) : l.kind === "fused" || l.kind === "truth" || l.kind === "annotation" || l.marks.length <= 12;
    const s = document.createElement("summary");
    s.dataset.lane = i;
    const parts = Object.entries(counts).filter(([k]) => k !== "none").map(([k, n]) => `${n} ${k.replace("_", " ")}`);
    s.textContent = `${l.name} — ${l.marks.length}` + (parts.length ? ` (${parts.join(", ")})` : "") + (l.judged_against ? ` · judged against ${l.judged_against}` : "");
    s.addEventListener("click", () => setActiveLane(i));
    d.appendChild(s);
    const t = document.createElement("table");
    l.marks.forEach(m => {
      const tr = document.createElement("tr");
      tr.dataset.frame = m.frame; tr.dataset.lane = i;
      const st = m.status ? `<span class="st-${m.status}">${m.status.replace("_", " ")}</span>` : "";
      tr.innerHTML = `<td>${m.frame}</td><td>${(m.frame / RATE).toFixed(2)} s</td><td>${st}</td><td></td>`;
      tr.lastChild.textContent = m.label;
      tr.addEventListener("click", () => { setActiveLane(i); seek(m.frame); });
      t.appendChild(tr);
    });
    d.appendChild(t);
    list.appendChild(d);
  });
}

function highlightList() {
  for (const tr of document.querySelectorAll("#list tr.current")) tr.classList.remove("current");
  for (const tr of document.querySelectorAll(`#list tr[data-frame="${state.frame}"]`)) tr.classList.add("current");
}

function setActiveLane(i) {
  state.activeLane = i;
  document.getElementById("active-lane").textContent = i >= 0 ? meta.lanes[i].name : "—";
  for (const s of document.querySelectorAll("#list summary")) s.classList.toggle("active", Number(s.dataset.lane) === i);
  // Choosing a lane of candidates also judges your marks against it.
  const l = meta.lanes[i];
  if (ANNO && anno.lane && l && (l.kind === "candidates" || l.kind === "fused") && anno.judge !== i) { anno.judge = i; annoRefresh(false); buildList(); }
  lanesImage = null;
  redraw();
}

// ---- playback ---------------------------------------------------------------------------------
const scrub = document.getElementById("scrub");
function seek(f) {
  state.frame = Math.max(0, Math.min(N - 1, Math.round(f)));
  state.pos = state.frame;
  // Keep the playhead in the visible time range.
  if (state.frame < state.view0 || state.frame > state.view1) {
    const span = state.view1 - state.view0;
    state.view0 = Math.max(0, Math.min(N - 1 - span, state.frame - span / 2));
    state.view1 = state.view0 + span;
    lanesImage = null;
  }
  redraw();
}
function redraw() {
  scrub.value = state.frame;
  document.getElementById("readout").textContent = `frame ${state.frame} · ${(state.frame / RATE).toFixed(3)} s of ${(N / RATE).toFixed(1)} s`;
  document.getElementById("readout").dataset.frame = state.frame;
  drawScene();
  drawLanes();
  highlightList();
}
function setPlaying(on) {
  state.playing = on && N > 1;
  document.getElementById("play").textContent = state.playing ? "❚❚ pause" : "▶ play";
  if (state.playing) { if (state.frame >= N - 1) seek(0); last = performance.now(); requestAnimationFrame(tick); }
}
let last = 0;
function tick(now) {
  if (!state.playing) return;
  state.pos += (now - last) / 1000 * RATE * state.speed;
  last = now;
  if (state.pos >= N - 1) { state.pos = N - 1; setPlaying(false); }
  const f = Math.floor(state.pos);
  if (f !== state.frame) { state.frame = f; const p = state.pos; seek(f); state.pos = p; }
  requestAnimationFrame(tick);
}
// Next / previous mark of the active lane, strictly after / before the current frame.
function stepMark(dir) {
  const l = meta.lanes[state.activeLane];
  if (!l) return;
  const frames = l.marks.map(m => m.frame);
  const next = dir > 0 ? frames.find(f => f > state.frame) : frames.slice().reverse().find(f => f < state.frame);
  if (next !== undefined) seek(next);
}
const SPEEDS = [0.1, 0.25, 0.5, 1, 2, 4];
function setSpeed(v) { state.speed = v; document.getElementById("speed").value = String(v); }

// ---- input ------------------------------------------------------------------------------------
function wireInput() {
  document.getElementById("play").addEventListener("click", () => setPlaying(!state.playing));
  document.getElementById("speed").addEventListener("change", e => setSpeed(Number(e.target.value)));
  document.getElementById("follow").addEventListener("change", e => { state.follow = e.target.checked; state.targetSet = false; redraw(); });
  scrub.max = N - 1;
  scrub.addEventListener("input", () => seek(Number(scrub.value)));
  document.addEventListener("keydown", e => {
    if (e.target && (e.target.tagName === "INPUT" && e.target.type !== "range" || e.target.tagName === "SELECT")) return;
    if (annoKey(e)) { e.preventDefault(); return; }
    const k = e.key;
    if (k === " ") { setPlaying(!state.playing); }
    else if (k === "ArrowRight") { setPlaying(false); seek(state.frame + (e.shiftKey ? 10 : 1)); }
    else if (k === "ArrowLeft") { setPlaying(false); seek(state.frame - (e.shiftKey ? 10 : 1)); }
    else if (k === "n") { setPlaying(false); stepMark(1); }
    else if (k === "p") { setPlaying(false); stepMark(-1); }
    else if (k === "]") setSpeed(SPEEDS[Math.min(SPEEDS.length - 1, SPEEDS.indexOf(state.speed) + 1)]);
    else if (k === "[") setSpeed(SPEEDS[Math.max(0, SPEEDS.indexOf(state.speed) - 1)]);
    else if (k === "Home") seek(0);
    else if (k === "End") seek(N - 1);
    else if (k === "0") { state.view0 = 0; state.view1 = Math.max(1, N - 1); lanesImage = null; redraw(); }
    else return;
    e.preventDefault();
  });
  // Orbit and zoom.
  let drag = null;
  scene.addEventListener("pointerdown", e => { drag = [e.clientX, e.clientY]; scene.setPointerCapture(e.pointerId); scene.style.cursor = "grabbing"; });
  scene.addEventListener("pointermove", e => {
    if (!drag) return;
    state.yaw -= (e.clientX - drag[0]) * 0.008;
    state.pitch = Math.max(-0.2, Math.min(1.5, state.pitch + (e.clientY - drag[1]) * 0.006));
    drag = [e.clientX, e.clientY];
    drawScene();
  });
  scene.addEventListener("pointerup", () => { drag = null; scene.style.cursor = "grab"; });
  scene.addEventListener("wheel", e => { e.preventDefault(); state.dist = Math.max(300, Math.min(200000, state.dist * Math.exp(e.deltaY * 0.001))); drawScene(); }, { passive: false });
  // Lanes: click jumps (to a mark within 5 px, else to the frame), wheel zooms time, drag pans.
  let pan = null;
  lanesCanvas.addEventListener("pointerdown", e => { pan = { x: e.offsetX, v0: state.view0, v1: state.view1, moved: false }; lanesCanvas.setPointerCapture(e.pointerId); });
  lanesCanvas.addEventListener("pointermove", e => {
    const w = lanesCanvas.clientWidth;
    if (pan && Math.abs(e.offsetX - pan.x) > 3) {
      pan.moved = true;
      const df = (e.offsetX - pan.x) / (w - LABEL_W - 10) * (pan.v1 - pan.v0);
      const span = pan.v1 - pan.v0;
      state.view0 = Math.max(0, Math.min(N - 1 - span, pan.v0 - df)); state.view1 = state.view0 + span;
      lanesImage = null; drawLanes();
      return;
    }
    const hit = hitMark(e.offsetX, e.offsetY);
    const stretch = hit ? null : hitInterval(e.offsetX, e.offsetY);
    document.getElementById("hover").textContent = hit
      ? `${hit.lane.name}: frame ${hit.mark.frame} (${(hit.mark.frame / RATE).toFixed(2)} s)` + (hit.mark.status ? ` — ${hit.mark.status.replace("_", " ")}` : "") + (hit.mark.label ? ` — ${hit.mark.label}` : "")
      : stretch ? `${stretch.lane}: frames ${stretch.a}–${stretch.b} (${(stretch.a / RATE).toFixed(2)}–${(stretch.b / RATE).toFixed(2)} s)` + (stretch.label ? ` — ${stretch.label}` : "")
      : (e.offsetX > LABEL_W ? `frame ${Math.round(frameOf(e.offsetX, w))}` : "");
  });
  lanesCanvas.addEventListener("pointerup", e => {
    const p = pan; pan = null;
    if (!p || p.moved) return;
    const box = laneBoxes.find(b => e.offsetY >= b.y && e.offsetY < b.y + b.h);
    if (e.offsetX < LABEL_W) { if (box && meta.lanes[box.index].type === "events") setActiveLane(box.index); return; }
    const hit = hitMark(e.offsetX, e.offsetY);
    if (hit) { setActiveLane(hit.index); seek(hit.mark.frame); }
    else seek(frameOf(e.offsetX, lanesCanvas.clientWidth));
  });
  lanesCanvas.addEventListener("wheel", e => {
    e.preventDefault();
    const w = lanesCanvas.clientWidth, at = frameOf(Math.max(LABEL_W, e.offsetX), w);
    const k = Math.exp(e.deltaY * 0.0015), span = Math.max(20, Math.min(N - 1, (state.view1 - state.view0) * k));
    const r = (at - state.view0) / (state.view1 - state.view0);
    state.view0 = Math.max(0, Math.min(N - 1 - span, at - r * span)); state.view1 = state.view0 + span;
    lanesImage = null; drawLanes();
  }, { passive: false });
  window.addEventListener("resize", () => { lanesImage = null; redraw(); });
}

function hitMark(x, y) {
  const w = lanesCanvas.clientWidth;
  const box = laneBoxes.find(b => y >= b.y && y < b.y + b.h);
  if (!box) return null;
  const l = meta.lanes[box.index];
  if (l.type !== "events") return null;
  let best = null, bd = 6;
  for (const m of l.marks) { const d = Math.abs(xOf(m.frame, w) - x); if (d < bd) { bd = d; best = m; } }
  return best ? { lane: l, mark: best, index: box.index } : null;
}

// The interval under (x, y) on an interval lane, or null.
function hitInterval(x, y) {
  const box = laneBoxes.find(b => y >= b.y && y < b.y + b.h);
  const l = box && meta.lanes[box.index];
  if (!l || l.type !== "intervals" || x <= LABEL_W) return null;
  const f = frameOf(x, lanesCanvas.clientWidth);
  const hit = l.intervals.find(([a, b]) => f >= a && f < b + 1);
  return hit ? { lane: l.name, a: hit[0], b: hit[1], label: hit[2] } : null;
}

/*{{ANNOTATE}}*/

// ---- start ------------------------------------------------------------------------------------
async function start() {
  const raw = await inflate(base64Bytes(document.getElementById("viewer-data").textContent));
  const xyz = new Float32Array(N * P * 3);
  let off = 0;
  for (let k = 0; k < P; k++) for (let a = 0; a < 3; a++) off = decodeChannel(raw, off, meta.positions[k][a], xyz, 3 * k + a, 3 * P);
  meta.lanes.forEach((l, i) => {
    if (l.type !== "trace") return;
    l._data = l.series.map(([, q]) => { const s = new Float32Array(N); off = decodeChannel(raw, off, q, s, 0, 1); return s; });
  });
  if (off !== raw.length) throw new Error(`viewer data: ${raw.length} bytes, expected ${off}`);
  const tDecoded = performance.now();
  toView(xyz);
  const tView = performance.now();
  document.getElementById("subtitle").textContent = `${N} frames at ${RATE} Hz (${(N / RATE).toFixed(1)} s) · ${P} ${meta.bones.length ? "joints/markers with bones" : "markers"}`;
  if (meta.back_link) {
    const a = document.createElement("a"); a.href = meta.back_link; a.textContent = "← run page";
    document.getElementById("back").appendChild(a);
  }
  annoInit();
  buildList();
  const tList = performance.now();
  wireInput();
  const fused = meta.lanes.findIndex(l => l.type === "events" && l.kind === "fused");
  const cand = meta.lanes.findIndex(l => l.type === "events" && l.kind !== "truth" && l.kind !== "annotation");
  setActiveLane(fused >= 0 ? fused : cand >= 0 ? cand : meta.lanes.findIndex(l => l.type === "events"));
  seek(0);
  state.ready = true;
  state.openMs = performance.now();
  state.phases = { script_start_ms: t0, decoded_ms: tDecoded, view_ms: tView, list_ms: tList, first_frame_ms: state.openMs };
  state.decodeMs = state.openMs - t0;
}

// For tests and the console: the current state and a few actions.
window.viewer = {
  get frame() { return state.frame; },
  get activeLane() { return state.activeLane; },
  get ready() { return state.ready; },
  get openMs() { return state.openMs; },
  get decodeMs() { return state.decodeMs; },
  get phases() { return state.phases; },
  meta, seek, setActiveLane, stepMark,
  setPlaying,
  // Annotation mode (null on pages without it): its marks, the judgement and the files.
  annotation: ANNO && {
    get on() { return anno.on; },
    get name() { return anno.name; },
    get marks() { return anno.marks.map(m => ({ ...m })); },
    get pending() { return anno.pending; },
    get results() { return anno.results.map(r => ({ ...r })); },
    get judgedAgainst() { return anno.lane.judged_against; },
    get message() { return anno.message; },
    get storageKey() { return STORE_KEY; },
    setName: annoSetName, match: annoMatch, csv: annoCsvText, eaf: annoEafText,
  },
};
start().catch(e => { fail("The viewer could not start: " + e.message); console.error(e); });
})();
