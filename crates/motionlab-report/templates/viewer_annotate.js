// ---- annotation mode --------------------------------------------------------------------------
// Boundaries marked at the playhead, per annotator, judged live against every candidate lane,
// kept in the browser under the take's SHA-256 and downloaded as boundaries_csv / ELAN .eaf
// (the formats of crates/motionlab-io/src/labels/: what is written here reads back through the
// readers there to the same frames; `motionlab export` writes the same two formats in Rust).
const ANNO = meta.annotation || null;
const STORE_KEY = ANNO ? "motionlab-marks:" + ANNO.input_sha256 : "";
const NAME_KEY = "motionlab-annotator";
const anno = {
  on: false, name: "", marks: [], undo: [], redo: [], pending: 0, lane: null, judge: -1,
  stored: null, storeError: "", message: "", labelling: null, results: [],
};
const annoEl = id => document.getElementById(id);

function annoMine() { return anno.marks.filter(m => m.annotator === anno.name); }
function annoSort() { anno.marks.sort((a, b) => a.frame - b.frame || (a.annotator < b.annotator ? -1 : a.annotator > b.annotator ? 1 : 0)); }
// Inner frames only: the first and last frames are the recording's edges, which the readers
// never take for boundaries.
function annoInner(f) { return f > 0 && f < N - 1; }
function annoSay(text) { anno.message = text; const e = annoEl("anno-message"); if (e) e.textContent = text; }

function annoInit() {
  if (!ANNO) return;
  const truth = meta.lanes.findIndex(l => l.type === "events" && l.kind === "truth");
  anno.lane = { type: "events", kind: "annotation", name: "your marks", tolerance_frames: ANNO.tolerance_frames, windows: [], judged_against: null, marks: [], others: [] };
  meta.lanes.splice(truth + 1, 0, anno.lane);
  const cand = meta.lanes.findIndex(l => l.type === "events" && l.kind === "fused");
  anno.judge = cand >= 0 ? cand : meta.lanes.findIndex(l => l.type === "events" && l.kind === "candidates");
  try { anno.name = localStorage.getItem(NAME_KEY) || ""; } catch (e) { anno.name = ""; }
  annoLoad();
  annoEl("annotate-toggle").hidden = false;
  annoEl("keys-annotate").hidden = false;
  annoEl("anno-name").value = anno.name;
  annoEl("anno-name").addEventListener("change", e => annoSetName(e.target.value));
  const buttons = { "anno-add": annoAdd, "anno-del": annoDelete, "anno-left": () => annoNudge(-1), "anno-right": () => annoNudge(1),
    "anno-label": annoLabelStart, "anno-accept": annoAccept, "anno-undo": annoUndo, "anno-redo": annoRedo,
    "anno-csv": annoDownloadCsv, "anno-eaf": annoDownloadEaf };
  for (const [id, f] of Object.entries(buttons)) annoEl(id).addEventListener("click", () => { f(); annoEl(id).blur(); });
  annoEl("annotate-toggle").addEventListener("click", () => { annoToggle(); annoEl("annotate-toggle").blur(); });
  annoEl("anno-flag").addEventListener("click", () => { if (!anno.on) annoToggle(); });
  annoEl("anno-load").addEventListener("change", e => { const f = e.target.files[0]; if (f) annoImport(f); e.target.value = ""; });
  const input = annoEl("anno-label-input");
  input.addEventListener("keydown", e => {
    if (e.key === "Enter") { annoLabelCommit(input.value); e.preventDefault(); }
    else if (e.key === "Escape") { annoLabelEnd(); e.preventDefault(); }
    e.stopPropagation();
  });
  window.addEventListener("beforeunload", e => {
    // Marks not downloaded may still be lost with the browser's storage: ask first.
    if (anno.pending > 0) { e.preventDefault(); e.returnValue = ""; }
  });
  // Marks kept from an earlier visit: carry on where they were left.
  if (anno.marks.length) annoShow(true);
  annoRefresh(false);
}

function annoToggle() { annoShow(!anno.on); annoRefresh(); }
function annoShow(on) {
  anno.on = on;
  annoEl("anno").hidden = !anno.on;
  annoEl("annotate-toggle").classList.toggle("on", anno.on);
  annoEl("annotate-toggle").textContent = anno.on ? "✎ annotating (a)" : "✎ annotate (a)";
  if (anno.on && !anno.name) annoEl("anno-name").focus();
}

function annoSetName(name) {
  anno.name = name.trim();
  try { localStorage.setItem(NAME_KEY, anno.name); } catch (e) { /* the name is only a convenience */ }
  annoEl("anno-name").value = anno.name;
  annoSave();
  annoRefresh();
}

// ---- edits: each one undoable, saved, and counted until the next download ----
function annoEdit(change) {
  const before = JSON.stringify(anno.marks);
  if (change() === false) return false;
  annoSort();
  if (JSON.stringify(anno.marks) === before) return false;
  anno.undo.push(before);
  anno.redo.length = 0;
  anno.pending++;
  annoSave();
  annoRefresh();
  return true;
}
function annoNeedName() {
  if (anno.name) return false;
  annoSay("Type your name first (it is the annotator column / ELAN tier of what you mark).");
  if (!anno.on) annoToggle();
  annoEl("anno-name").focus();
  return true;
}
function annoNearest() {
  let best = null;
  for (const m of annoMine()) if (!best || Math.abs(m.frame - state.frame) < Math.abs(best.frame - state.frame)) best = m;
  return best;
}
function annoAddAt(f, label, what) {
  if (annoNeedName()) return false;
  if (!annoInner(f)) { annoSay(`Frame ${f} is the motion's ${f === 0 ? "first" : "last"} frame, an edge rather than a boundary: not marked.`); return false; }
  if (annoMine().some(m => m.frame === f)) { annoSay(`You already marked frame ${f}.`); return false; }
  const done = annoEdit(() => { anno.marks.push({ frame: f, label: label || "", annotator: anno.name }); });
  if (done) annoSay(`${what} at frame ${f}.`);
  return done;
}
function annoAdd() { return annoAddAt(state.frame, "", "Boundary"); }
function annoDelete() {
  if (annoNeedName()) return;
  const m = annoNearest();
  if (!m) { annoSay("No mark of yours to delete."); return; }
  annoEdit(() => { anno.marks.splice(anno.marks.indexOf(m), 1); });
  annoSay(`Deleted the mark at frame ${m.frame}.`);
}
function annoNudge(frames) {
  if (annoNeedName()) return;
  const m = annoNearest();
  if (!m) { annoSay("No mark of yours to move."); return; }
  const to = Math.max(1, Math.min(N - 2, m.frame + frames));
  if (to === m.frame || annoMine().some(o => o.frame === to)) { annoSay(`Cannot move the mark at ${m.frame} to ${to}.`); return; }
  annoEdit(() => { m.frame = to; });
  setPlaying(false);
  seek(to);
  annoSay(`Moved the mark to frame ${to}.`);
}
function annoLabelStart() {
  if (annoNeedName()) return;
  const m = annoNearest();
  if (!m) { annoSay("No mark of yours to label."); return; }
  if (!anno.on) annoToggle();
  anno.labelling = m;
  setPlaying(false);
  seek(m.frame);
  annoEl("anno-label-row").hidden = false;
  annoEl("anno-label-frame").textContent = `frame ${m.frame}`;
  const input = annoEl("anno-label-input");
  input.value = m.label;
  input.focus();
  input.select();
}
function annoLabelCommit(text) {
  const m = anno.labelling;
  annoLabelEnd();
  if (!m || anno.marks.indexOf(m) < 0) return;
  const label = text.trim();
  if (annoEdit(() => { m.label = label; })) annoSay(`Labelled frame ${m.frame}: ${label || "(no label)"}.`);
}
function annoLabelEnd() {
  anno.labelling = null;
  annoEl("anno-label-row").hidden = true;
  annoEl("anno-label-input").blur();
}
// The chosen candidate lane's mark nearest the playhead becomes one of your marks.
function annoAccept() {
  const active = meta.lanes[state.activeLane];
  const lane = active && active.type === "events" && active !== anno.lane ? active : meta.lanes[anno.judge];
  if (!lane || !lane.marks.length) { annoSay("Choose a lane of candidates first (click its name)."); return; }
  let best = null;
  for (const m of lane.marks) if (!best || Math.abs(m.frame - state.frame) < Math.abs(best.frame - state.frame)) best = m;
  setPlaying(false);
  seek(best.frame);
  annoAddAt(best.frame, "", `Accepted ${lane.name}'s candidate`);
}
// Undo takes the last state from `anno.undo` (keeping the present for redo), redo the reverse.
function annoStep(from, to, word) {
  if (!from.length) { annoSay(`Nothing to ${word}.`); return; }
  to.push(JSON.stringify(anno.marks));
  anno.marks = JSON.parse(from.pop());
  anno.pending++;
  annoSave();
  annoRefresh();
  annoSay(`${word[0].toUpperCase()}${word.slice(1)} done.`);
}
function annoUndo() { annoStep(anno.undo, anno.redo, "undo"); }
function annoRedo() { annoStep(anno.redo, anno.undo, "redo"); }

// ---- the live judgement: maximum one-to-one matching within the tolerance ----
// Your marks are the truth, each accepting [t − tol, t + tol]; candidates are swept in order
// and each takes the open window that closes first (the earliest remaining truth, since all
// windows are equally wide) — the sweep motionlab-eval's boundaries.rs proves maximum.
function annoMatch(found, truths, tol) {
  const f = found.slice().sort((a, b) => a - b), t = truths.slice().sort((a, b) => a - b);
  const pairs = [];
  let j = 0;
  for (const a of f) {
    while (j < t.length && t[j] + tol < a) j++;
    if (j < t.length && t[j] - tol <= a) { pairs.push([a, t[j]]); j++; }
  }
  return pairs;
}
function annoJudge() {
  const truths = annoMine().map(m => m.frame);
  const tol = ANNO.tolerance_frames == null ? 0 : ANNO.tolerance_frames;
  anno.results = [];
  meta.lanes.forEach((l, i) => {
    if (l.type !== "events" || (l.kind !== "candidates" && l.kind !== "fused")) return;
    const found = l.marks.map(m => m.frame);
    const matched = annoMatch(found, truths, tol).length;
    const div = (a, b) => b ? a / b : NaN;
    anno.results.push({ lane: i, method: l.name, found: found.length, truths: truths.length, matched,
      precision: div(matched, found.length), recall: div(matched, truths.length), f1: div(2 * matched, found.length + truths.length) });
  });
  const judged = meta.lanes[anno.judge];
  const hit = new Set(judged ? annoMatch(judged.marks.map(m => m.frame), truths, tol).map(p => p[1]) : []);
  anno.lane.judged_against = judged ? judged.name : null;
  anno.lane.marks = annoMine().map(m => ({ frame: m.frame, label: m.label, status: judged ? (hit.has(m.frame) ? "matched" : "missed") : null }));
  anno.lane.others = anno.marks.filter(m => m.annotator !== anno.name);
  anno.lane.name = anno.name ? `marks: ${anno.name}` : "your marks";
  // Out of sight until used: a page nobody annotates looks as it always did.
  anno.lane.hidden = !anno.on && !anno.marks.length;
}

// Everything that shows the marks; `draw` false only before the page's first drawing.
function annoRefresh(draw = true) {
  if (!ANNO) return;
  annoJudge();
  const mine = anno.lane.marks.length, all = anno.marks.length;
  const who = [...new Set(anno.marks.map(m => m.annotator))];
  const status = annoEl("anno-status");
  let text = `${mine} mark${mine === 1 ? "" : "s"} by ${anno.name || "(no name yet)"}` + (all > mine ? ` · ${all} in all (${who.join(", ")})` : "");
  if (anno.storeError) text += ` · NOT kept in this browser (${anno.storeError}): download before you close the page`;
  else if (anno.stored) text += ` · kept in this browser (saved ${anno.stored})`;
  status.textContent = text;
  const unsaved = anno.pending > 0 && all > 0 || anno.storeError !== "" && all > 0;
  const warn = annoEl("anno-unsaved");
  warn.hidden = !unsaved;
  warn.textContent = anno.pending > 0 ? `⚠ ${anno.pending} change${anno.pending === 1 ? "" : "s"} not downloaded yet — keep them with ⤓ CSV or ⤓ ELAN` : "⚠ not kept in this browser";
  annoEl("anno-flag").hidden = !unsaved;
  annoEl("anno-flag").textContent = `⚠ ${anno.pending} annotation change${anno.pending === 1 ? "" : "s"} not downloaded`;
  const tol = ANNO.tolerance_frames;
  const rows = anno.results.map(r => `<tr data-lane="${r.lane}"${r.lane === anno.judge ? ' class="current"' : ""}><td></td><td class="num">${r.found}</td><td class="num">${r.matched}</td><td class="num">${annoFmt(r.precision)}</td><td class="num">${annoFmt(r.recall)}</td><td class="num">${annoFmt(r.f1)}</td></tr>`);
  const judge = annoEl("anno-judge");
  judge.innerHTML = `<div class="muted">candidates against your ${mine} mark${mine === 1 ? "" : "s"} at ±${tol == null ? 0 : +tol.toFixed(2)} frames (±${((tol || 0) / RATE).toFixed(3)} s), the run's tolerance; click a row to colour your marks by it</div>` +
    `<table><tr><th>method</th><th title="candidates">found</th><th title="matched to your marks">hits</th><th title="precision">P</th><th title="recall">R</th><th>F1</th></tr>${rows.join("")}</table>`;
  judge.querySelectorAll("tr[data-lane]").forEach((tr, k) => {
    tr.firstChild.textContent = anno.results[k].method;
    tr.addEventListener("click", () => { anno.judge = Number(tr.dataset.lane); annoRefresh(); });
  });
  annoEl("anno-undo").disabled = !anno.undo.length;
  annoEl("anno-redo").disabled = !anno.redo.length;
  if (draw) { buildList(); lanesImage = null; redraw(); }
}
function annoFmt(v) { return isFinite(v) ? v.toFixed(2) : "—"; }

// ---- browser storage, keyed by the take ----
function annoSave() {
  if (!ANNO) return;
  const record = { format: "motionlab marks 1", sequence: ANNO.sequence, frame_rate_hz: RATE, n_frames: N, annotator: anno.name,
    pending: anno.pending, marks: anno.marks, saved_utc: new Date().toISOString() };
  try {
    localStorage.setItem(STORE_KEY, JSON.stringify(record));
    anno.stored = new Date().toLocaleTimeString();
    anno.storeError = "";
  } catch (e) {
    anno.storeError = e.name || "storage refused";
  }
}
function annoLoad() {
  let record = null;
  try { record = JSON.parse(localStorage.getItem(STORE_KEY) || "null"); } catch (e) { anno.storeError = e.name || "storage unreadable"; }
  if (!record || !Array.isArray(record.marks)) return;
  let marks = record.marks.filter(m => Number.isInteger(m.frame) && typeof m.annotator === "string");
  // The same file prepared differently (resampled, trimmed) has other frames: go by time.
  if (record.frame_rate_hz !== RATE || record.n_frames !== N) {
    marks = marks.map(m => ({ ...m, frame: Math.round(m.frame / record.frame_rate_hz * RATE) })).filter(m => annoInner(m.frame));
    annoSay(`Marks kept for this take at ${record.frame_rate_hz} Hz / ${record.n_frames} frames were moved by time to this page's ${RATE} Hz / ${N} frames.`);
  }
  anno.marks = marks.map(m => ({ frame: m.frame, label: String(m.label || ""), annotator: m.annotator }));
  anno.pending = Number(record.pending) || 0;
  if (!anno.name && record.annotator) anno.name = record.annotator;
  anno.stored = record.saved_utc ? new Date(record.saved_utc).toLocaleTimeString() : "earlier";
  annoSort();
}

// ---- downloads ----
// One row per mark: sequence, frame, time_s (shortest decimal of frame / rate), label,
// annotator — write_boundaries_csv's bytes: a line break in a cell becomes a space, cells
// holding `,` or `"` are quoted.
function annoCsvCell(s) {
  s = String(s).split(/[\r\n]/).filter(p => p !== "").join(" ");
  return /[",\r\n]/.test(s) ? '"' + s.replace(/"/g, '""') + '"' : s;
}
function annoCsvText() {
  const lines = ["sequence,frame,time_s,label,annotator"];
  for (const who of annoAnnotators()) {
    for (const m of anno.marks.filter(m => m.annotator === who)) {
      lines.push([ANNO.sequence, m.frame, String(m.frame / RATE), m.label, who].map(annoCsvCell).join(","));
    }
  }
  return lines.join("\n") + "\n";
}
// Annotators in order: you first, then the others as loaded.
function annoAnnotators() {
  const who = [...new Set(anno.marks.map(m => m.annotator))];
  return who.includes(anno.name) ? [anno.name, ...who.filter(w => w !== anno.name)] : who;
}
function annoXml(s) {
  return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;").replace(/"/g, "&quot;").replace(/'/g, "&apos;");
}
// EAF 3.0 as motionlab_io::labels::elan_eaf::write_eaf writes it: one tier per annotator, one
// annotation from each mark to the next (the last to the motion's last frame) holding the
// mark's label, times round(frame / rate × 1000) ms (exact back to the frame up to 1000 Hz).
function annoEafText(date) {
  if (RATE > 1000) throw new Error(`ELAN keeps whole milliseconds, which tell frames apart only up to 1000 Hz; this motion is at ${RATE} Hz`);
  const ms = f => Math.round(f / RATE * 1000);
  const last = N - 1;
  // Two slots per annotation in document order; ids in time order, ties in document order.
  const slots = [], annotations = [];
  for (const who of annoAnnotators()) {
    const marks = anno.marks.filter(m => m.annotator === who && m.frame < last);
    annotations.push([who, marks.map((m, i) => {
      slots.push(ms(m.frame), ms(i + 1 < marks.length ? marks[i + 1].frame : last));
      return [slots.length - 2, m.label];
    })]);
  }
  const order = slots.map((_, i) => i).sort((a, b) => slots[a] - slots[b] || a - b);
  const id = [];
  order.forEach((i, rank) => { id[i] = rank + 1; });
  let tiers = "", next = 1;
  for (const [who, list] of annotations) {
    const name = annoXml(who);
    tiers += `    <TIER LINGUISTIC_TYPE_REF="default-lt" TIER_ID="${name}" ANNOTATOR="${name}">\n`;
    for (const [k, label] of list) {
      tiers += `        <ANNOTATION>\n            <ALIGNABLE_ANNOTATION ANNOTATION_ID="a${next}" TIME_SLOT_REF1="ts${id[k]}" TIME_SLOT_REF2="ts${id[k + 1]}">\n                <ANNOTATION_VALUE>${annoXml(label)}</ANNOTATION_VALUE>\n            </ALIGNABLE_ANNOTATION>\n        </ANNOTATION>\n`;
      next++;
    }
    tiers += "    </TIER>\n";
  }
  let out = '<?xml version="1.0" encoding="UTF-8"?>\n';
  out += `<ANNOTATION_DOCUMENT AUTHOR="motionlab" DATE="${annoXml(date)}" FORMAT="3.0" VERSION="3.0">\n`;
  out += '    <HEADER MEDIA_FILE="" TIME_UNITS="milliseconds">\n';
  out += `        <PROPERTY NAME="motionlab:sequence">${annoXml(ANNO.sequence)}</PROPERTY>\n`;
  out += `        <PROPERTY NAME="motionlab:input_sha256">${annoXml(ANNO.input_sha256)}</PROPERTY>\n`;
  out += `        <PROPERTY NAME="lastUsedAnnotationId">${next - 1}</PROPERTY>\n`;
  out += "    </HEADER>\n    <TIME_ORDER>\n";
  order.forEach((i, rank) => { out += `        <TIME_SLOT TIME_SLOT_ID="ts${rank + 1}" TIME_VALUE="${slots[i]}"/>\n`; });
  out += "    </TIME_ORDER>\n" + tiers;
  out += '    <LINGUISTIC_TYPE GRAPHIC_REFERENCES="false" LINGUISTIC_TYPE_ID="default-lt" TIME_ALIGNABLE="true"/>\n';
  out += "</ANNOTATION_DOCUMENT>\n";
  return out;
}
function annoDownload(name, text, type) {
  const url = URL.createObjectURL(new Blob([text], { type }));
  const a = document.createElement("a");
  a.href = url; a.download = name;
  document.body.appendChild(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
  anno.pending = 0;
  annoSave();
  annoRefresh();
  annoSay(`Downloaded ${name} (${anno.marks.length} marks).`);
}
function annoDownloadCsv() { annoDownload(`${ANNO.sequence}.csv`, annoCsvText(), "text/csv"); }
function annoDownloadEaf() {
  try { annoDownload(`${ANNO.sequence}.eaf`, annoEafText(new Date().toISOString().replace(/\.\d+Z$/, "Z")), "application/xml"); }
  catch (e) { annoSay(e.message); }
}

// ---- loading a truth or an earlier download ----
// Each annotator (CSV) or tier (ELAN) of the file replaces that annotator's marks here;
// boundaries are taken as the readers take them (rounded to the nearest frame, edges skipped;
// CSV segments give their starts and the last end, ELAN annotations their starts and ends).
async function annoImport(file) {
  const text = await file.text();
  let tracks;
  try {
    tracks = /^\s*(<\?xml|<ANNOTATION_DOCUMENT)/.test(text) ? annoParseEaf(text) : annoParseCsv(text);
  } catch (e) { annoSay(`${file.name}: ${e.message}`); return; }
  if (!tracks.length) { annoSay(`${file.name}: no boundaries of ${ANNO.sequence}.`); return; }
  annoEdit(() => {
    for (const t of tracks) {
      const who = t.annotator || anno.name || "imported";
      anno.marks = anno.marks.filter(m => m.annotator !== who);
      const seen = new Set();
      for (const m of t.marks) if (annoInner(m.frame) && !seen.has(m.frame)) { seen.add(m.frame); anno.marks.push({ frame: m.frame, label: m.label, annotator: who }); }
    }
  });
  if (!anno.name) annoSetName(tracks[0].annotator || "imported");
  annoSay(`${file.name}: loaded ${tracks.map(t => `${t.marks.length} marks of ${t.annotator || anno.name}`).join(", ")} (replacing theirs here; u undoes).`);
}
function annoParseEaf(text) {
  const doc = new DOMParser().parseFromString(text, "application/xml");
  if (doc.getElementsByTagName("parsererror").length) throw new Error("not well-formed XML");
  const slot = {};
  for (const s of doc.getElementsByTagName("TIME_SLOT")) if (s.hasAttribute("TIME_VALUE")) slot[s.getAttribute("TIME_SLOT_ID")] = Number(s.getAttribute("TIME_VALUE"));
  const frame = ms => Math.round(ms / 1000 * RATE);
  const tracks = [];
  for (const tier of doc.getElementsByTagName("TIER")) {
    const byFrame = new Map();
    for (const a of tier.getElementsByTagName("ALIGNABLE_ANNOTATION")) {
      const t1 = slot[a.getAttribute("TIME_SLOT_REF1")], t2 = slot[a.getAttribute("TIME_SLOT_REF2")];
      if (t1 === undefined || t2 === undefined) throw new Error(`annotation ${a.getAttribute("ANNOTATION_ID")} has an unaligned or undeclared time slot`);
      const v = a.getElementsByTagName("ANNOTATION_VALUE")[0];
      const label = v ? v.textContent.trim() : "";
      byFrame.set(frame(t1), label);
      if (!byFrame.has(frame(t2))) byFrame.set(frame(t2), "");
    }
    const marks = [...byFrame].map(([f, label]) => ({ frame: f, label })).filter(m => annoInner(m.frame)).sort((a, b) => a.frame - b.frame);
    if (marks.length) tracks.push({ annotator: tier.getAttribute("TIER_ID") || "", marks });
  }
  return tracks;
}
// RFC 4180 rows (quotes, doubled quotes, CRLF); `#` comment lines skipped.
function annoCsvRows(text, delim) {
  const rows = [];
  let row = [], cell = "", quoted = false, i = 0;
  text = text.replace(/^\uFEFF/, "");
  while (i < text.length) {
    const c = text[i];
    if (quoted) {
      if (c === '"' && text[i + 1] === '"') { cell += '"'; i++; }
      else if (c === '"') quoted = false;
      else cell += c;
    } else if (c === '"') quoted = true;
    else if (c === delim) { row.push(cell); cell = ""; }
    else if (c === "\n" || c === "\r") {
      if (c === "\r" && text[i + 1] === "\n") i++;
      row.push(cell); rows.push(row); row = []; cell = "";
    } else cell += c;
    i++;
  }
  if (cell !== "" || row.length) { row.push(cell); rows.push(row); }
  return rows.map(r => r.map(x => x.trim())).filter(r => r.some(x => x !== "") && !r[0].startsWith("#"));
}
function annoParseCsv(text) {
  const first = text.split(/\r?\n/).find(l => l.trim() !== "" && !l.trim().startsWith("#")) || "";
  const delim = first.includes(",") ? "," : first.includes("\t") ? "\t" : first.includes(";") ? ";" : ",";
  const rows = annoCsvRows(text, delim);
  if (!rows.length) throw new Error("empty file");
  const head = rows[0].map(h => h.toLowerCase());
  const col = n => head.indexOf(n);
  const num = (r, n) => { const v = Number(r[col(n)]); if (!isFinite(v) || v < 0 || r[col(n)] === "") throw new Error(`${n} ${JSON.stringify(r[col(n)])} is not a number ≥ 0`); return v; };
  let rowsOf = rows.slice(1);
  if (col("sequence") >= 0) {
    const named = [...new Set(rowsOf.map(r => r[col("sequence")]))];
    rowsOf = rowsOf.filter(r => r[col("sequence")] === ANNO.sequence);
    if (!rowsOf.length) throw new Error(`no row for sequence ${ANNO.sequence}; the file has ${named.join(", ")}`);
  }
  let point, seg;
  if (col("frame") >= 0) point = r => num(r, "frame");
  else if (col("time_s") >= 0) point = r => num(r, "time_s") * RATE;
  else if (col("start_frame") >= 0 && col("end_frame") >= 0) seg = r => [num(r, "start_frame"), num(r, "end_frame")];
  else if (col("start_s") >= 0 && col("end_s") >= 0) seg = r => [num(r, "start_s") * RATE, num(r, "end_s") * RATE];
  else throw new Error("no time column; expected frame, time_s, start_frame + end_frame or start_s + end_s");
  const tracks = new Map();
  for (const r of rowsOf) {
    const who = col("annotator") >= 0 ? r[col("annotator")] : "";
    if (!tracks.has(who)) tracks.set(who, { annotator: who, marks: [], lastEnd: -1 });
    const t = tracks.get(who), label = col("label") >= 0 ? r[col("label")] : "";
    if (point) t.marks.push({ frame: Math.round(point(r)), label });
    else { const [a, b] = seg(r); t.marks.push({ frame: Math.round(a), label }); t.lastEnd = Math.max(t.lastEnd, Math.round(b)); }
  }
  return [...tracks.values()].map(t => {
    if (t.lastEnd >= 0 && !t.marks.some(m => m.frame === t.lastEnd)) t.marks.push({ frame: t.lastEnd, label: "" });
    t.marks = t.marks.filter(m => annoInner(m.frame)).sort((a, b) => a.frame - b.frame);
    return t;
  }).filter(t => t.marks.length);
}

// Keys of annotation mode; true when the key was one (the caller then stops it).
function annoKey(e) {
  if (!ANNO) return false;
  const k = e.key;
  if (k === "a" && !e.ctrlKey && !e.metaKey) { annoToggle(); return true; }
  if (!anno.on) return false;
  const ctrl = e.ctrlKey || e.metaKey;
  if (ctrl && (k === "z" || k === "Z")) { if (e.shiftKey) annoRedo(); else annoUndo(); return true; }
  if (ctrl && k === "y") { annoRedo(); return true; }
  if (ctrl) return false;
  if (k === "b") { setPlaying(false); annoAdd(); }
  else if (k === "d" || k === "Delete" || k === "Backspace") annoDelete();
  else if (k === "," || k === "<") annoNudge(e.shiftKey || k === "<" ? -10 : -1);
  else if (k === "." || k === ">") annoNudge(e.shiftKey || k === ">" ? 10 : 1);
  else if (k === "l") annoLabelStart();
  else if (k === "c") annoAccept();
  else if (k === "u") annoUndo();
  else if (k === "r") annoRedo();
  else return false;
  return true;
}

// The mark `,` `.` `d` and `l` act on: your mark nearest the playhead, ringed on its lane.
function annoDrawNearest(ctx, w) {
  if (!ANNO || !anno.on) return;
  const m = annoNearest();
  const box = laneBoxes.find(b => meta.lanes[b.index] === anno.lane);
  if (!m || !box) return;
  const x = Math.round(xOf(m.frame, w)) + 0.5;
  if (x < LABEL_W || x > w - 10) return;
  ctx.strokeStyle = "#0b5cad"; ctx.lineWidth = 1.5;
  ctx.beginPath(); ctx.arc(x, box.y + box.h / 2, 6, 0, 2 * Math.PI); ctx.stroke();
}
