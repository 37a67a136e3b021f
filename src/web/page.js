// The teacher's view: draws the session from /api/state and changes it only by statements
// (POST /api/statement), so the REPL and the journal see everything the page does. Re-reads the
// state on every statement announced on /api/events, from the page or from the REPL.
"use strict";
const token = new URLSearchParams(location.search).get("token");
const api = (p, q = "") => p + "?token=" + encodeURIComponent(token) + q;
const $ = (id) => document.getElementById(id);
const NS = "http://www.w3.org/2000/svg";
const COLOURS = { path: "#1f4e9c", flagged: "#d62728", advised: "#2ca02c", teacher: "#f09600", sel: "#ffbf00", after: "#ff7f0e", ball: "#e377c2", goal: "#2ca02c", drawn: "#7f7f7f" };

let S = null; // the last state read
let viewed = null; // the execution the page shows (null: the session's current one)
let drag = null; // {a, b}: the point indices of a drag in progress
let preview = null; // the last preview's data
let hovered = null; // the suggestion under the pointer
let previewTimer = null;
let overlay = null; // {index, path}: another execution drawn under the shown one (`plot compare`)

/** An SVG element with attributes, appended to `parent`. */
function el(parent, name, attrs = {}, text) {
  const e = document.createElementNS(NS, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  parent.appendChild(e);
  return e;
}

// ---- talking to the session ----

/** Show `text` (a diagnostic as the session renders it: code, message, help) or hide the box. */
function showError(text) {
  $("error").hidden = !text;
  $("error").title = "click to dismiss";
  $("error").textContent = text || "";
}

/** Run one statement; its reply, or its diagnostic shown at the top of the page. */
async function run(statement) {
  if (/^\s*run\b/.test(statement)) viewed = null; // show the new execution
  let res;
  try {
    res = await fetch(api("/api/statement"), { method: "POST", body: statement });
  } catch (e) {
    showError(`the view's server cannot be reached: ${e}`);
    return null;
  }
  if (!res.ok) {
    showError(`${statement}: HTTP ${res.status}: ${await res.text()}`);
    return null;
  }
  const r = await res.json();
  showError(r.ok ? "" : r.reply);
  await refresh();
  return r;
}

async function refresh() {
  const q = viewed === null ? "" : "&execution=" + viewed;
  const res = await fetch(api("/api/state", q));
  if (!res.ok) {
    showError(`the session's state: HTTP ${res.status}: ${await res.text()}`);
    return;
  }
  S = await res.json();
  draw();
}

// ---- the execution: path and actions ----

/** The length of a heading arrow (the goal's, the robot's at the end), m. */
const ARROW_M = 0.4;
/** Room kept on every side of the path plot for the names drawn beside marks, px. */
const LABEL_ROOM = 36;

/** The shown execution's world-to-screen map for the path plot, at equal scale: everything drawn
 *  (the path, the goal and its heading, the robot's final heading, the task's drawings, the ball,
 *  the arena) inside, with room around for their names. */
function pathFrame(ex, w, h) {
  const xs = [], ys = [];
  const add = (x, y) => { if (isFinite(x) && isFinite(y)) { xs.push(x); ys.push(y); } };
  ex.path.forEach(([x, y]) => add(x, y));
  if (ex.path.length && isFinite(ex.final_heading)) {
    const [x, y] = ex.path[ex.path.length - 1];
    add(x + ARROW_M * Math.cos(ex.final_heading), y + ARROW_M * Math.sin(ex.final_heading));
  }
  if (overlay) overlay.path.forEach(([x, y]) => add(x, y));
  (ex.ball || []).forEach(([x, y]) => add(x, y));
  for (const d of ex.drawn) {
    const r = d.shape === "circle" ? d.values[2] : 0;
    add(d.values[0] - r, d.values[1] - r);
    add(d.values[0] + r, d.values[1] + r);
    if (d.shape === "pose") add(d.values[0] + ARROW_M * Math.cos(d.values[2]), d.values[1] + ARROW_M * Math.sin(d.values[2]));
  }
  if (ex.arena) { add(-ex.arena.half_m, -ex.arena.half_m); add(ex.arena.half_m, ex.arena.half_m); }
  if (!xs.length) { add(-1, -1); add(1, 1); }
  let [x0, x1, y0, y1] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
  const px = Math.max((x1 - x0) * 0.06, 0.25), py = Math.max((y1 - y0) * 0.06, 0.25);
  [x0, x1, y0, y1] = [x0 - px, x1 + px, y0 - py, y1 + py];
  const m = Math.min(LABEL_ROOM, w / 6, h / 6);
  const k = Math.min((w - 2 * m) / (x1 - x0), (h - 2 * m) / (y1 - y0));
  const ox = (w - k * (x1 - x0)) / 2, oy = (h - k * (y1 - y0)) / 2;
  return { k, x: (x) => ox + k * (x - x0), y: (y) => h - oy - k * (y - y0), wx: (sx) => x0 + (sx - ox) / k, wy: (sy) => y0 + (h - oy - sy) / k, x0, x1, y0, y1 };
}

function polyline(svg, pts, attrs) {
  if (pts.length) el(svg, "polyline", { points: pts.map((p) => p.join(",")).join(" "), fill: "none", ...attrs });
}

/** The SVG's own coordinates of a mouse event. */
function svgPoint(svg, ev) {
  const r = svg.getBoundingClientRect(), vb = svg.viewBox.baseVal;
  return [(ev.clientX - r.left) * vb.width / r.width, (ev.clientY - r.top) * vb.height / r.height];
}

function drawPath(ex) {
  const svg = $("path");
  svg.replaceChildren();
  if (!ex) { el(svg, "text", { x: 20, y: 30 }, "No execution yet: run a goal (or a start)."); return; }
  const vb = svg.viewBox.baseVal, f = pathFrame(ex, vb.width, vb.height);
  svg._frame = f;
  const grid = el(svg, "g", { stroke: "#eee" });
  for (let g = Math.ceil(f.x0); g <= f.x1; g++) el(grid, "line", { x1: f.x(g), x2: f.x(g), y1: 0, y2: vb.height });
  for (let g = Math.ceil(f.y0); g <= f.y1; g++) el(grid, "line", { y1: f.y(g), y2: f.y(g), x1: 0, x2: vb.width });
  el(svg, "text", { x: 4, y: vb.height - 4 }, "grid 1 m");
  if (ex.arena) {
    const a = ex.arena.half_m;
    el(svg, "rect", { x: f.x(-a), y: f.y(a), width: 2 * a * f.k, height: 2 * a * f.k, fill: "none", stroke: "#999", "stroke-dasharray": "6 4" });
  }
  for (const d of ex.drawn) {
    const [x, y] = d.values, c = d.goal ? COLOURS.goal : COLOURS.drawn;
    if (!isFinite(x) || !isFinite(y)) continue;
    if (d.shape === "circle") el(svg, "circle", { cx: f.x(x), cy: f.y(y), r: d.values[2] * f.k, fill: "none", stroke: c, "stroke-dasharray": "4 3" });
    else el(svg, "circle", { cx: f.x(x), cy: f.y(y), r: 6, fill: c, "fill-opacity": 0.25, stroke: c });
    if (d.shape === "pose") {
      const th = d.values[2];
      el(svg, "line", { x1: f.x(x), y1: f.y(y), x2: f.x(x + ARROW_M * Math.cos(th)), y2: f.y(y + ARROW_M * Math.sin(th)), stroke: c, "stroke-width": 2.5 });
    }
    // A circle is named at its top, so it does not cover a point drawn at its centre. A name
    // that would run past the right edge goes left of its mark; one above the top, below it.
    let ly = d.shape === "circle" ? f.y(y + d.values[2]) - 4 : f.y(y) - 8;
    if (ly < 12) ly = d.shape === "circle" ? f.y(y - d.values[2]) + 14 : f.y(y) + 18;
    const right = f.x(x) + 8 + 7 * d.name.length > vb.width;
    el(svg, "text", { x: right ? f.x(x) - 8 : f.x(x) + 8, y: ly, fill: c, "text-anchor": right ? "end" : "start" }, d.name);
  }
  if (ex.ball && ex.ball.length) {
    polyline(svg, ex.ball.map(([x, y]) => [f.x(x), f.y(y)]), { stroke: COLOURS.ball, "stroke-dasharray": "5 3", "stroke-width": 1.5 });
    const [sx, sy] = ex.ball[0], [bx, by] = ex.ball[ex.ball.length - 1];
    el(svg, "circle", { cx: f.x(sx), cy: f.y(sy), r: 4, fill: "#fff", stroke: COLOURS.ball, "stroke-width": 1.5 });
    el(svg, "circle", { cx: f.x(bx), cy: f.y(by), r: 5, fill: COLOURS.ball });
    if (ex.arena) el(svg, "circle", { cx: f.x(bx), cy: f.y(by), r: ex.arena.capture_m * f.k, fill: "none", stroke: COLOURS.ball, "stroke-opacity": 0.5 });
    el(svg, "text", { x: f.x(bx) + 8, y: f.y(by) + 14, fill: COLOURS.ball }, "ball");
  }
  if (overlay && overlay.index !== ex.index) {
    polyline(svg, overlay.path.map(([x, y]) => [f.x(x), f.y(y)]), { class: "overlay", stroke: "#888", "stroke-width": 1.5, "stroke-dasharray": "6 3" });
  }
  const screen = ex.path.map(([x, y]) => [f.x(x), f.y(y)]);
  const stretch = (c, colour, width, opacity) => polyline(svg, screen.slice(c[0], c[1]), { stroke: colour, "stroke-width": width, "stroke-opacity": opacity, "stroke-linecap": "round" });
  const sel = drag ? [Math.min(drag.a, drag.b), Math.max(drag.a, drag.b) + 1] : ex.selection;
  if (sel) stretch(sel, COLOURS.sel, 12, 0.6);
  if (hovered && hovered.execution === ex.index) stretch([hovered.chunk.start, hovered.chunk.end], COLOURS.after, 12, 0.6);
  (ex.teacher || []).forEach((c) => stretch(c, COLOURS.teacher, 8, 0.6));
  ex.flagged.forEach((c) => stretch(c, COLOURS.flagged, 6, 0.7));
  ex.advised.forEach((c) => stretch(c, COLOURS.advised, 6, 0.7));
  polyline(svg, screen, { stroke: COLOURS.path, "stroke-width": 1.8 });
  if (screen.length) {
    el(svg, "circle", { cx: screen[0][0], cy: screen[0][1], r: 5, fill: "#fff", stroke: COLOURS.path, "stroke-width": 2 });
    const [lx, ly] = screen[screen.length - 1];
    el(svg, "rect", { x: lx - 4, y: ly - 4, width: 8, height: 8, fill: COLOURS.path });
    // The robot's heading at the end, an arrow as long as the goal's.
    if (isFinite(ex.final_heading)) {
      const [wx, wy] = ex.path[ex.path.length - 1], th = ex.final_heading;
      const tx = f.x(wx + ARROW_M * Math.cos(th)), ty = f.y(wy + ARROW_M * Math.sin(th));
      const head = (a) => [tx - 9 * Math.cos(a), ty + 9 * Math.sin(a)];
      el(svg, "line", { class: "final-heading", x1: lx, y1: ly, x2: tx, y2: ty, stroke: COLOURS.path, "stroke-width": 2.5 });
      polyline(svg, [head(th + 0.5), [tx, ty], head(th - 0.5)], { stroke: COLOURS.path, "stroke-width": 2.5 });
    }
  }
  const items = [["path, end heading", COLOURS.path], ["selection", COLOURS.sel], ["critiqued", COLOURS.flagged], ["advised", COLOURS.advised]];
  if ((ex.teacher || []).length) items.push(["the teacher drove", COLOURS.teacher]);
  if (overlay && overlay.index !== ex.index) items.push([`execution ${overlay.index}`, "#888"]);
  legend(svg, vb.width - 150, 16, items);
}

function legend(svg, x, y, items) {
  el(svg, "rect", { x: x - 4, y: y - 12, width: 160, height: 15 * items.length + 4, fill: "#fff", "fill-opacity": 0.85 });
  items.forEach(([name, colour], i) => {
    el(svg, "rect", { x, y: y + i * 15 - 8, width: 14, height: 8, fill: colour, "fill-opacity": 0.8 });
    el(svg, "text", { x: x + 20, y: y + i * 15 }, name);
  });
}

/** The actions plot's time axis (the SVG's x to seconds and back). */
function timeFrame(ex, w) {
  const t = ex.t, t0 = t[0] || 0, t1 = t[t.length - 1] || 1, left = 42, right = 10;
  const span = t1 > t0 ? t1 - t0 : 1;
  return { left, x: (s) => left + (w - left - right) * (s - t0) / span, s: (x) => t0 + (x - left) * span / (w - left - right) };
}

function drawActions(ex) {
  const svg = $("actions");
  svg.replaceChildren();
  if (!ex || !ex.series.length) return;
  const vb = svg.viewBox.baseVal, tf = timeFrame(ex, vb.width), n = ex.series.length;
  svg._time = tf;
  const strip = (vb.height - 20) / n;
  const sel = drag ? [Math.min(drag.a, drag.b), Math.max(drag.a, drag.b) + 1] : ex.selection;
  const band = (c, colour, opacity) => {
    const x0 = tf.x(ex.t[c[0]]), x1 = tf.x(ex.t[Math.min(c[1], ex.t.length) - 1]);
    el(svg, "rect", { x: x0, y: 0, width: Math.max(x1 - x0, 2), height: strip * n, fill: colour, "fill-opacity": opacity });
  };
  (ex.teacher || []).forEach((c) => band(c, COLOURS.teacher, 0.2));
  ex.flagged.forEach((c) => band(c, COLOURS.flagged, 0.15));
  ex.advised.forEach((c) => band(c, COLOURS.advised, 0.15));
  if (sel) band(sel, COLOURS.sel, 0.35);
  ex.series.forEach((s, i) => {
    const top = i * strip + 4, h = strip - 8;
    const shown = s.values.filter(isFinite);
    let extra = [];
    if (preview && preview.execution === ex.index && preview.space === "action" && s.dim !== null) extra = preview.after.map((v) => v[s.dim]);
    let lo = Math.min(0, ...shown, ...extra), hi = Math.max(0, ...shown, ...extra);
    if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
    const y = (v) => top + h - h * (v - lo) / (hi - lo);
    el(svg, "line", { x1: tf.left, x2: vb.width - 10, y1: y(0), y2: y(0), stroke: "#ccc" });
    el(svg, "text", { x: tf.left + 6, y: top + 11, class: "label" }, s.label);
    el(svg, "text", { x: tf.left - 4, y: top + 9, "text-anchor": "end" }, hi.toFixed(2));
    el(svg, "text", { x: tf.left - 4, y: top + h, "text-anchor": "end" }, lo.toFixed(2));
    polyline(svg, s.values.map((v, j) => [tf.x(ex.t[j]), y(v)]).filter((p) => isFinite(p[1])), { stroke: COLOURS.path, "stroke-width": 1.3 });
    if (extra.length) {
      preview.source_index.forEach((src, j) => el(svg, "circle", { cx: tf.x(ex.t[src]), cy: y(extra[j]), r: 2.2, fill: COLOURS.after }));
    }
  });
  if (preview && preview.execution === ex.index && preview.space === "action") {
    legend(svg, vb.width - 170, 12, [["executed", COLOURS.path], ["preview: " + preview.invocation.split("(")[0], COLOURS.after]]);
  }
  const t0 = ex.t[0] || 0, t1 = ex.t[ex.t.length - 1] || 0, step = niceStep(t1 - t0);
  for (let s = Math.ceil(t0 / step) * step; s <= t1 + 1e-9; s += step) {
    el(svg, "text", { x: tf.x(s), y: vb.height - 4, "text-anchor": "middle" }, `${+s.toFixed(1)} s`);
  }
}

function niceStep(span) {
  for (const s of [0.5, 1, 2, 5, 10, 20, 50, 100]) if (span / s <= 10) return s;
  return 200;
}

/** The point of the shown execution nearest a mouse event on the path or the actions. */
function pointAt(svg, ev) {
  const ex = S && S.shown;
  if (!ex || !ex.points) return null;
  const [sx, sy] = svgPoint(svg, ev);
  if (svg.id === "path") {
    const f = svg._frame;
    let best = 0, bd = Infinity;
    ex.path.forEach(([x, y], i) => {
      const d = (f.x(x) - sx) ** 2 + (f.y(y) - sy) ** 2;
      if (d < bd) { bd = d; best = i; }
    });
    return best;
  }
  const s = svg._time.s(sx);
  let best = 0;
  ex.t.forEach((t, i) => { if (Math.abs(t - s) < Math.abs(ex.t[best] - s)) best = i; });
  return best;
}

/** Where point `i` of the shown execution is drawn on the path, in the page's pixels. */
function pathPointOnScreen(i) {
  const svg = $("path"), f = svg._frame, [x, y] = S.shown.path[i];
  const r = svg.getBoundingClientRect(), vb = svg.viewBox.baseVal;
  return [r.left + f.x(x) * r.width / vb.width, r.top + f.y(y) * r.height / vb.height];
}
window.pathPointOnScreen = pathPointOnScreen;

/** Shift-click on the plane: its x and y become the goal's first values. */
function setGoal(ev) {
  const f = $("path")._frame;
  if (!f) return;
  const [sx, sy] = svgPoint($("path"), ev);
  const rest = $("goal").value.trim().split(/\s+/).slice(2);
  $("goal").value = [f.wx(sx).toFixed(2), f.wy(sy).toFixed(2), ...rest].join(" ");
  $("goal").focus();
}

function selecting(svg) {
  svg.addEventListener("pointerdown", (ev) => {
    if (ev.shiftKey && svg.id === "path") return setGoal(ev);
    const i = pointAt(svg, ev);
    if (i === null) return;
    drag = { a: i, b: i };
    svg.setPointerCapture(ev.pointerId);
    ev.preventDefault();
  });
  svg.addEventListener("pointermove", (ev) => {
    if (!drag) return;
    const i = pointAt(svg, ev);
    if (i !== null && i !== drag.b) { drag.b = i; draw(); }
  });
  svg.addEventListener("pointerup", async () => {
    if (!drag) return;
    const [a, b] = [Math.min(drag.a, drag.b), Math.max(drag.a, drag.b)];
    drag = null;
    if (a === b) {
      if (S.shown.index !== S.current) {
        $("why").hidden = false;
        $("why").textContent = `why explains points of the current execution (${S.current}); this is execution ${S.shown.index}.`;
        return;
      }
      const r = await run(`why ${a}`);
      $("why").hidden = !(r && r.ok);
      if (r && r.ok) $("why").textContent = r.reply;
      return;
    }
    preview = null;
    await run(`select ${a}..${b + 1} in ${S.shown.index}`);
    schedulePreview();
  });
}

// ---- operators and their preview ----

function invocation() {
  const op = S && S.operators.find((o) => o.name === $("op").value);
  if (!op) return null;
  if (!op.params.length) return op.name;
  const args = op.params.map((p) => $("param-" + p.name).value);
  return `${op.name}(${args.join(", ")})`;
}

function drawOperators() {
  const names = S.operators.map((o) => o.name);
  const have = [...$("op").options].map((o) => o.value);
  if (names.join() === have.join()) return;
  const keep = $("op").value;
  $("op").replaceChildren(...names.map((n) => new Option(n, n)));
  if (names.includes(keep)) $("op").value = keep;
  drawParams();
}

function drawParams() {
  const op = S.operators.find((o) => o.name === $("op").value);
  $("params").replaceChildren();
  $("opdoc").textContent = op ? op.doc : "";
  if (!op) return;
  for (const p of op.params) {
    const row = document.createElement("label");
    row.className = "param";
    const range = document.createElement("input");
    const value = document.createElement("input");
    value.id = "param-" + p.name;
    value.type = "number";
    value.value = p.default;
    row.append(p.name, range, value);
    if (p.lo !== null && p.hi !== null) {
      range.type = "range";
      const step = (p.hi - p.lo) / 100;
      for (const i of [range, value]) Object.assign(i, { min: p.lo, max: p.hi, step });
      range.value = p.default;
      range.oninput = () => { value.value = range.value; schedulePreview(); };
    } else {
      range.hidden = true;
    }
    value.oninput = () => { range.value = value.value; schedulePreview(); };
    $("params").append(row);
  }
}

function schedulePreview() {
  clearTimeout(previewTimer);
  previewTimer = setTimeout(runPreview, 250);
}

/** Preview the chosen operator on the selection: the synthesized actions drawn over the executed. */
async function runPreview() {
  const inv = invocation();
  if (!inv || !S.selection) { preview = null; draw(); return; }
  const res = await fetch(api("/api/preview"), { method: "POST", body: `preview ${inv}` });
  const r = res.ok ? await res.json() : { ok: false, reply: `HTTP ${res.status}: ${await res.text()}` };
  showError(r.ok ? "" : r.reply);
  preview = r.ok && r.preview ? r.preview : null;
  if (preview) {
    const mean = (rows, d) => rows.reduce((s, r) => s + r[d], 0) / Math.max(rows.length, 1);
    const changes = preview.dims
      .map((name, d) => [name, mean(preview.before, d), mean(preview.after, d)])
      .filter(([, b, a]) => Math.abs(a - b) > 1e-12)
      .map(([name, b, a]) => `${name} ${b.toFixed(3)} → ${a.toFixed(3)}`);
    $("previewtext").textContent = `preview ${preview.invocation}: ${preview.after.length} points (${preview.space} space); mean ${changes.join(", ") || "unchanged"}`;
  } else {
    $("previewtext").textContent = r.ok ? r.reply : "no preview (see the error above)";
  }
  await refresh();
}

// ---- history, evals, log ----

function drawSide() {
  $("task").textContent = S.task;
  $("status").textContent = S.status;
  const ex = $("exec");
  const labels = S.executions.map((e) => `${e.index}: ${e.label} (${e.points} points)`);
  if ([...ex.options].map((o) => o.text).join() !== labels.join()) {
    ex.replaceChildren(...S.executions.map((e, i) => new Option(labels[i], e.index)));
  }
  if (S.shown) ex.value = S.shown.index;
  const over = $("overlay");
  if (over.options.length !== labels.length + 1) {
    over.replaceChildren(new Option("none", ""), ...S.executions.map((e, i) => new Option(labels[i], e.index)));
    over.value = overlay ? overlay.index : "";
  }
  $("outcome").textContent = S.shown ? S.shown.outcome || "" : "";
  const sel = S.shown && S.shown.selection;
  $("seltext").className = sel ? "hint on" : "hint";
  const previewed = preview && preview.space === "action" ? ` · preview ${preview.invocation} in orange on the actions` : "";
  $("seltext").textContent = sel ? `select ${sel[0]}..${sel[1]} in ${S.shown.index}   (${sel[1] - sel[0]} points)${previewed}` : "Drag over the path or the actions to select a chunk; click a point to ask why; shift-click the plane to set a goal.";
  $("history").replaceChildren(...S.history.map((h) => {
    const li = document.createElement("li");
    li.value = h.number;
    li.textContent = h.text;
    if (h.undone) li.className = "undone";
    return li;
  }));
  drawCurve();
  drawLog();
  drawSuggestions();
}

/** The last `suggest` of the shown execution: hover previews one (its chunk on the path, its
 * points on the actions, its re-run in words), a click accepts it (`accept K`). */
function drawSuggestions() {
  const sug = S.suggestions, list = $("suggestions");
  const mine = sug && S.shown && sug.execution === S.shown.index ? sug : null;
  $("suggest").disabled = !S.shown;
  if (!mine) { list.replaceChildren(); return; }
  const fmt = (m) => `${m.success ? "succeeded" : "failed"}, error ${m.error.toFixed(2)}${m.heading_error == null ? "" : `, heading ${m.heading_error.toFixed(2)} rad`}, length ${m.length_m.toFixed(2)} m`;
  const before = mine.trial.kind === "simulated" ? mine.trial.before : null;
  list.replaceChildren(...mine.suggestions.map((s) => {
    const li = document.createElement("li");
    li.value = s.number;
    li.className = "suggestion";
    li.textContent = `${s.chunk.start}..${s.chunk.end} ${s.invocation} [${s.flaws.join(", ")}]`;
    const effect = before && s.after ? `re-run: ${fmt(before)} → ${fmt(s.after)}` : "not re-run";
    li.title = `accept ${s.number}: select ${s.chunk.start}..${s.chunk.end} in ${s.execution}, advise ${s.invocation}; ${effect}`;
    li.onmouseenter = () => {
      hovered = s;
      preview = { execution: s.execution, invocation: s.invocation, space: s.preview.space, dims: s.preview.dims, source_index: s.preview.source_index, before: s.preview.before, after: s.preview.after };
      $("sugtext").textContent = `${s.invocation} on ${s.chunk.start}..${s.chunk.end}: ${effect}`;
      drawPath(S.shown); drawActions(S.shown);
    };
    li.onmouseleave = () => { hovered = null; preview = null; drawPath(S.shown); drawActions(S.shown); };
    li.onclick = () => { hovered = null; dropPreview(); run(`accept ${s.number}`); };
    return li;
  }));
  if (mine.trial.kind !== "simulated") $("sugtext").textContent = `candidates without a re-run (${mine.trial.why})`;
}

function drawCurve() {
  const svg = $("curve"), ev = S.evals;
  svg.replaceChildren();
  if (!ev.length) { el(svg, "text", { x: 6, y: 20 }, "eval: the success rate over the session"); $("evaltext").textContent = ""; return; }
  const last = ev[ev.length - 1], prev = ev[ev.length - 2];
  const pct = (r) => (100 * r).toFixed(0) + "%";
  $("evaltext").textContent = `success ${pct(last.success_rate)}` + (prev ? ` (${last.success_rate >= prev.success_rate ? "+" : ""}${(100 * (last.success_rate - prev.success_rate)).toFixed(0)} points since the last)` : "");
  const x = (i) => 30 + 260 * (ev.length > 1 ? i / (ev.length - 1) : 0.5), y = (r) => 62 - 54 * r;
  el(svg, "line", { x1: 30, x2: 290, y1: y(0), y2: y(0), stroke: "#ccc" });
  el(svg, "text", { x: 2, y: y(1) + 4 }, "100%");
  el(svg, "text", { x: 10, y: y(0) + 4 }, "0%");
  polyline(svg, ev.map((e, i) => [x(i), y(e.success_rate)]), { stroke: COLOURS.advised, "stroke-width": 2 });
  ev.forEach((e, i) => el(svg, "circle", { cx: x(i), cy: y(e.success_rate), r: 3, fill: COLOURS.advised }));
}

function drawLog() {
  const log = $("log");
  const atBottom = log.scrollTop + log.clientHeight >= log.scrollHeight - 4;
  log.replaceChildren(...S.log.slice(-200).map((l) => {
    const div = document.createElement("div");
    const head = document.createElement("div");
    head.innerHTML = `<span class="from">#${l.seq} ${l.from}&gt;</span> <span class="stmt"></span>`;
    head.querySelector(".stmt").textContent = l.statement;
    const body = document.createElement("pre");
    body.textContent = l.reply;
    if (!l.ok) body.className = "err";
    div.append(head, body);
    return div;
  }));
  if (atBottom) log.scrollTop = log.scrollHeight;
}

function draw() {
  if (!S) return;
  drawOperators();
  drawPath(S.shown);
  drawActions(S.shown);
  drawSide();
}

// ---- controls ----

function onSubmit(id, statement) {
  $(id).onsubmit = (e) => { e.preventDefault(); const s = statement(); if (s) run(s); };
}
onSubmit("runf", () => `run goal ${$("goal").value.trim()}`);
onSubmit("startf", () => `run start ${$("start").value}`);
onSubmit("f", () => $("stmt").value.trim());
/** The preview is of the state before a change: drop it once the session changes. */
function dropPreview() {
  preview = null;
  $("previewtext").textContent = "Change an operator's parameter to preview it again.";
}
$("advise").onclick = () => { const inv = invocation(); dropPreview(); if (inv) run(`advise ${inv}`); };
$("critique").onclick = () => { dropPreview(); run($("directional").checked ? "critique --directional" : "critique"); };
$("error").onclick = () => showError("");
$("undo").onclick = () => run("undo");
$("redo").onclick = () => run("redo");
$("eval").onclick = () => run("eval");
$("suggest").onclick = () => { if (S.shown) run(`suggest ${S.shown.index}`); };
$("op").onchange = () => { drawParams(); schedulePreview(); };
$("exec").onchange = () => { viewed = +$("exec").value; preview = null; run(`show ${viewed}`); };
$("overlay").onchange = async () => {
  const v = $("overlay").value;
  overlay = null;
  if (v !== "") {
    const res = await fetch(api("/api/state", "&execution=" + v));
    const other = res.ok ? (await res.json()).shown : null;
    if (other) overlay = { index: other.index, path: other.path };
  }
  draw();
};
$("stop").onclick = async () => {
  const res = await fetch(api("/api/stop"), { method: "POST" });
  showError(res.ok ? "" : `Stop: HTTP ${res.status}`);
  if (res.ok) $("status").textContent = (await res.json()).reply;
};
/** The hold-to-drive pad: while held, where the pointer is (up: forward, left: turn left, as
 * fractions of the base's limits) is posted every 100 ms; the server hands back to the learner
 * on release or when the posts stop. */
(function pad() {
  const p = $("pad");
  let held = null, timer = null;
  const send = (body) => fetch(api("/api/takeover"), { method: "POST", body: JSON.stringify(body) }).catch(() => {});
  const at = (e) => {
    const r = p.getBoundingClientRect();
    const clamp = (v) => Math.max(-1, Math.min(1, v));
    return { speed: clamp(-((e.clientY - r.top) / r.height * 2 - 1)), turn: clamp(-((e.clientX - r.left) / r.width * 2 - 1)) };
  };
  const release = () => {
    if (!held) return;
    held = null;
    clearInterval(timer);
    p.classList.remove("held");
    send({ release: true });
  };
  p.addEventListener("pointerdown", (e) => {
    p.setPointerCapture(e.pointerId);
    held = at(e);
    p.classList.add("held");
    send(held);
    timer = setInterval(() => held && send(held), 100);
  });
  p.addEventListener("pointermove", (e) => { if (held) held = at(e); });
  p.addEventListener("pointerup", release);
  p.addEventListener("pointercancel", release);
  window.addEventListener("blur", release);
})();
selecting($("path"));
selecting($("actions"));
new EventSource(api("/api/events")).addEventListener("statement", refresh);
refresh();
