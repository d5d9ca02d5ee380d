// leapfrog serve: the room as the page draws it (an SVG): the grid with round ticks, the map,
// the obstacles, the other initial paths' extremals with labels placed clear of each other,
// the path, the robot's footprint, the waypoints, the start and the goal, and the legend.
// Uses app.js's state and helpers.
"use strict";

// ------------------------------------------------------------------ ticks

// Round ticks between lo and hi, about `count` of them: steps of 1, 2 or 5 times a power of
// ten, each tick an integer multiple of the step, labelled to the step's decimals (so that a
// tick at zero reads 0, never -5.551e-17).
function ticks(lo, hi, count) {
  if (!(hi > lo) || !Number.isFinite(hi - lo)) return { step: 1, values: [] };
  const raw = (hi - lo) / Math.max(count, 1);
  const p = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((m) => m * p).find((v) => v >= raw * (1 - 1e-9)) || 10 * p;
  return { step, values: multiples(lo, hi, step) };
}

// The multiples of `step` in [lo, hi], each {k, v: k * step, text}.
function multiples(lo, hi, step) {
  const digits = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
  const values = [];
  const k0 = Math.ceil(lo / step - 1e-9), k1 = Math.floor(hi / step + 1e-9);
  for (let k = k0; k <= k1 && values.length < 1000; k++) {
    values.push({ k, v: k * step, text: tickText(k * step, digits) });
  }
  return values;
}

function tickText(v, digits) {
  return String(Number(v.toFixed(digits)));  // 0.5, 1, 1.5 (and -0 reads 0)
}

function fitBounds() {
  const s = state.scenario;
  if (!s) return;
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  const add = (x, y, r = 0) => {
    x = val(x, NaN); y = val(y, NaN); r = Math.max(val(r), 0);
    if (!Number.isFinite(x) || !Number.isFinite(y)) return;
    x0 = Math.min(x0, x - r); x1 = Math.max(x1, x + r);
    y0 = Math.min(y0, y - r); y1 = Math.max(y1, y + r);
  };
  add(s.start[0], s.start[1]);
  add(s.goal[0], s.goal[1]);
  for (const ob of s.obstacles || []) add(ob.center[0], ob.center[1], ob.radius);
  for (const w of s.waypoints || []) add(w[0], w[1], robotRadius());
  for (const shape of [...(s.polygons || []), ...(s.walls || [])]) {
    for (const q of shape.points || []) add(q[0], q[1], val(shape.thickness) / 2);
  }
  mapBounds(add);
  const path = state.result && state.result.path;
  if (path) path.x.forEach((x, i) => add(x, path.y[i]));
  if (!Number.isFinite(x0)) { x0 = -1; y0 = -1; x1 = 1; y1 = 1; }
  const span = Math.max(x1 - x0, y1 - y0, 0.5);
  const pad = 0.12 * span;
  state.bounds = { x0: x0 - pad, y0: y0 - pad, x1: x1 + pad, y1: y1 + pad };
}

function transform(svg) {
  const box = svg.getBoundingClientRect();
  const w = Math.max(box.width, 100), h = Math.max(box.height, 100);
  const b = state.bounds;
  const s = Math.min(w / (b.x1 - b.x0), h / (b.y1 - b.y0));
  const ox = (w - s * (b.x1 - b.x0)) / 2, oy = (h - s * (b.y1 - b.y0)) / 2;
  return {
    w, h, s,
    X: (x) => ox + (x - b.x0) * s,
    Y: (y) => h - oy - (y - b.y0) * s,
    wx: (px) => b.x0 + (px - ox) / s,
    wy: (py) => b.y0 + (h - oy - py) / s,
  };
}

function el(name, attrs, parent, text) {
  const e = document.createElementNS(SVGNS, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  if (parent) parent.appendChild(e);
  return e;
}

// ------------------------------------------------------------------ the room

function drawGrid(svg, T) {
  const b = state.bounds;
  const step = ticks(0, Math.max(b.x1 - b.x0, b.y1 - b.y0), 8).step;
  const g = el("g", { id: "grid" }, svg);
  el("rect", { x: 0, y: 0, width: T.w, height: T.h, fill: "#ffffff" }, g);
  drawMap(g, T);
  if (mapShown()) g.setAttribute("stroke-opacity", 0.45);
  const label = { fill: COLORS.label, "font-size": 10, "font-family": "sans-serif", class: "tick" };
  const across = (lo, hi) => multiples(lo, hi, step);
  for (const { k, v, text } of across(T.wx(0), T.wx(T.w))) {
    const X = T.X(v);
    el("line", { x1: X, y1: 0, x2: X, y2: T.h, stroke: k === 0 ? COLORS.axis : COLORS.grid }, g);
    const room = X > 24 && X + 2 + 6 * text.length < T.w;  // clear of the y labels and the edge
    if (room) el("text", { ...label, x: X + 2, y: T.h - 4 }, g, text);
  }
  for (const { k, v, text } of across(T.wy(T.h), T.wy(0))) {
    const Y = T.Y(v);
    el("line", { x1: 0, y1: Y, x2: T.w, y2: Y, stroke: k === 0 ? COLORS.axis : COLORS.grid }, g);
    if (Y > 14 && Y < T.h - 18) el("text", { ...label, x: 3, y: Y - 3 }, g, text);
  }
}

function polyline(parent, T, xs, ys, attrs) {
  const pts = xs.map((x, i) => `${T.X(x).toFixed(1)},${T.Y(ys[i]).toFixed(1)}`).join(" ");
  return el("polyline", { points: pts, fill: "none", ...attrs }, parent);
}

function arrowHead(parent, T, x, y, theta, color, size = 7) {
  const X = T.X(x), Y = T.Y(y), c = Math.cos(theta), s = -Math.sin(theta);
  const p = [
    [X + size * c, Y + size * s],
    [X - size * c * 0.6 - size * s * 0.55, Y - size * s * 0.6 + size * c * 0.55],
    [X - size * c * 0.6 + size * s * 0.55, Y - size * s * 0.6 - size * c * 0.55],
  ];
  el("polygon", { points: p.map((q) => q.map((v) => v.toFixed(1)).join(",")).join(" "),
    fill: color }, parent);
}

function drawAlternatives(svg, T) {
  const r = state.result;
  if (!r) return;
  const g = el("g", { id: "alternatives-layer", opacity: 0.5 }, svg);
  for (const a of r.alternatives) {
    if (!a.path) continue;
    polyline(g, T, a.path.x, a.path.y, {
      stroke: COLORS.alternative, "stroke-width": 2, "stroke-dasharray": "5 4" });
  }
}

// Where a label may go along a path: its middle first, then further out on either side.
const LABEL_PLACES = [0.5, 0.4, 0.6, 0.3, 0.7, 0.45, 0.55, 0.35, 0.65, 0.25, 0.75, 0.2, 0.8];

const overlaps = (a, b, pad = 2) => a.x < b.x + b.width + pad && b.x < a.x + a.width + pad
  && a.y < b.y + b.height + pad && b.y < a.y + a.height + pad;

// The boxes a label of an alternative must keep clear of: the start's and goal's labels, the
// legend; and the points of the path drawn (a label on them is a last resort).
function labelObstacles(svg, T) {
  const boxes = [...svg.querySelectorAll("#start text, #goal text, #legend rect")]
    .map((e) => e.getBBox());
  return { boxes, points: pathPoints(T) };
}

// The drawn path's points on the screen.
function pathPoints(T) {
  const p = state.result && state.result.path;
  return p ? p.x.map((x, i) => [T.X(x), T.Y(p.y[i])]) : [];
}

// The alternatives' labels ("converged 5.66387"), each at the first place along its path
// where it overlaps no label placed before it (nor the legend, the start's and goal's), off
// the drawn path where it can; a label with no free place is left out.
function drawAlternativeLabels(svg, T) {
  const r = state.result;
  if (!r) return;
  const g = el("g", { id: "alternative-labels", fill: COLORS.label, "font-size": 11,
    "font-family": "sans-serif", stroke: "#fff", "stroke-width": 3, "paint-order": "stroke",
    "stroke-linejoin": "round" }, svg);
  const { boxes, points } = labelObstacles(svg, T);
  const inside = (b) => points.filter(([x, y]) => x > b.x - 3 && x < b.x + b.width + 3
    && y > b.y - 3 && y < b.y + b.height + 3).length;
  r.alternatives.forEach((a, i) => {
    if (!a.path) return;
    const n = a.path.x.length;
    const text = el("text", { class: "alternative-label", "data-alternative": i }, g,
      `${a.status} ${fmt(a.cost)}`);
    let best = null;
    for (const f of LABEL_PLACES) {
      const m = Math.min(n - 1, Math.floor(f * (n - 1)));
      for (const dy of [-5, 15]) {
        text.setAttribute("x", T.X(a.path.x[m]) + 5);
        text.setAttribute("y", T.Y(a.path.y[m]) + dy);
        const b = text.getBBox();
        if (b.x < 0 || b.y < 0 || b.x + b.width > T.w || b.y + b.height > T.h) continue;
        if (boxes.some((o) => overlaps(o, b))) continue;
        const score = inside(b);
        if (best === null || score < best.score) best = { score, at: [m, dy] };
        if (score === 0) break;
      }
      if (best && best.score === 0) break;
    }
    if (best === null) { text.remove(); return; }
    text.setAttribute("x", T.X(a.path.x[best.at[0]]) + 5);
    text.setAttribute("y", T.Y(a.path.y[best.at[0]]) + best.at[1]);
    boxes.push(text.getBBox());
  });
}

function drawPath(svg, T) {
  const r = state.result;
  if (!r || !r.path) return;
  const p = r.path;
  const g = el("g", { id: "path", "data-cost": String(r.cost) }, svg);
  const base = r.optimal ? COLORS.path : COLORS.notOptimal;
  const dash = r.optimal ? "none" : "7 4";
  // split into forward and reversing stretches (v < 0)
  let i = 0;
  while (i < p.x.length - 1) {
    const rev = p.reverse[i];
    let j = i;
    while (j < p.x.length - 1 && p.reverse[j] === rev) j++;
    polyline(g, T, p.x.slice(i, j + 1), p.y.slice(i, j + 1), {
      stroke: rev ? COLORS.reverse : base, "stroke-width": 3,
      "stroke-dasharray": rev ? "2 3" : dash, "stroke-linecap": "round",
      class: rev ? "reversing" : "forward" });
    i = j;
  }
  const n = p.x.length, every = Math.max(1, Math.round(n / 14));
  for (let k = every; k < n - every / 2; k += every) {
    arrowHead(g, T, p.x[k], p.y[k], p.theta[k], p.reverse[k] ? COLORS.reverse : base, 7);
  }
}

function drawSweep(svg, T) {
  const r = state.result;
  if (!r || state.frame === null || !r.frames[state.frame]) return;
  const f = r.frames[state.frame];
  const g = el("g", { id: "sweep-layer" }, svg);
  polyline(g, T, f.x, f.y, { stroke: COLORS.sweep, "stroke-width": 1.5, "stroke-dasharray": "4 3" });
  f.x.forEach((x, i) => el("circle", { cx: T.X(x), cy: T.Y(f.y[i]), r: 4, fill: COLORS.sweep,
    stroke: "#fff", "stroke-width": 1 }, g));
}

// Polygons and walls (thick polylines) of the scenario, in the discs' grey: the planner keeps
// clear of them as of the discs.
function drawShapes(svg, T) {
  const s = state.scenario, g = el("g", { id: "shapes" }, svg);
  const points = (shape) => (shape.points || [])
    .map((q) => `${T.X(val(q[0])).toFixed(1)},${T.Y(val(q[1])).toFixed(1)}`).join(" ");
  for (const shape of s.polygons || []) {
    el("polygon", { points: points(shape), fill: COLORS.obstacle, "fill-opacity": 0.85,
      stroke: COLORS.obstacleEdge, "stroke-width": 1, class: "polygon" }, g);
  }
  for (const shape of s.walls || []) {
    el("polyline", { points: points(shape), fill: "none", stroke: COLORS.obstacle,
      "stroke-width": Math.max(val(shape.thickness) * T.s, 1), "stroke-linecap": "round",
      "stroke-linejoin": "round", class: "wall" }, g);
  }
}

function drawObstacles(svg, T) {
  drawShapes(svg, T);
  const g = el("g", { id: "obstacles" }, svg);
  (state.scenario.obstacles || []).forEach((ob, i) => {
    const cx = val(ob.center[0]), cy = val(ob.center[1]), r = Math.max(val(ob.radius), 0);
    const sel = i === state.selected;
    el("circle", { cx: T.X(cx), cy: T.Y(cy), r: Math.max(r * T.s, 2), fill: COLORS.obstacle,
      "fill-opacity": 0.85, stroke: sel ? COLORS.selected : COLORS.obstacleEdge,
      "stroke-width": sel ? 2.5 : 1, "data-obstacle": i, class: "obstacle",
      style: "cursor: move" }, g);
    el("circle", { cx: T.X(cx + r), cy: T.Y(cy), r: 4.5, fill: COLORS.handle,
      stroke: sel ? COLORS.selected : COLORS.obstacleEdge, "stroke-width": 1.2,
      "data-resize": i, class: "resize", style: "cursor: ew-resize" }, g);
  });
}

// The robot's footprint (a disc of the scenario's radius): about the start and the goal, and
// faint along the path; the obstacles grown by it dashed (where the robot's centre may not go).
function drawFootprint(svg, T) {
  const R = robotRadius();
  if (!(R > 0)) return;
  const g = el("g", { id: "footprint", fill: "none", "stroke-width": 1 }, svg);
  for (const ob of state.scenario.obstacles || []) {
    el("circle", { cx: T.X(val(ob.center[0])), cy: T.Y(val(ob.center[1])),
      r: (Math.max(val(ob.radius), 0) + R) * T.s, stroke: COLORS.obstacleEdge,
      "stroke-opacity": 0.5, "stroke-dasharray": "3 3", class: "grown" }, g);
  }
  const p = state.result && state.result.path;
  if (p) {
    const n = p.x.length, every = Math.max(1, Math.round(n / 10));
    for (let k = 0; k < n; k += every) {
      el("circle", { cx: T.X(p.x[k]), cy: T.Y(p.y[k]), r: R * T.s, stroke: COLORS.path,
        "stroke-opacity": 0.35, class: "footprint" }, g);
    }
  }
  for (const [key, color] of [["start", COLORS.start], ["goal", COLORS.goal]]) {
    const q = state.scenario[key];
    el("circle", { cx: T.X(val(q[0])), cy: T.Y(val(q[1])), r: R * T.s, fill: color,
      "fill-opacity": 0.12, stroke: color, "stroke-opacity": 0.7, class: "footprint" }, g);
  }
}

// The waypoints, numbered in order, and the guide from the start through them to the goal.
function drawWaypoints(svg, T) {
  const s = state.scenario, w = s.waypoints || [];
  if (!w.length) return;
  const g = el("g", { id: "waypoints" }, svg);
  const xs = [s.start[0], ...w.map((p) => p[0]), s.goal[0]].map((v) => val(v));
  const ys = [s.start[1], ...w.map((p) => p[1]), s.goal[1]].map((v) => val(v));
  polyline(g, T, xs, ys, { stroke: COLORS.waypoint, "stroke-width": 1, "stroke-dasharray": "2 4" });
  w.forEach((p, i) => {
    const X = T.X(val(p[0])), Y = T.Y(val(p[1])), sel = i === state.selectedWaypoint;
    el("rect", { x: X - 6, y: Y - 6, width: 12, height: 12, transform: `rotate(45 ${X} ${Y})`,
      fill: COLORS.waypoint, stroke: sel ? COLORS.selected : "#fff", "stroke-width": sel ? 2.5 : 1.5,
      "data-waypoint": i, class: "waypoint", style: "cursor: move" }, g);
    el("text", { x: X + 9, y: Y - 7, fill: COLORS.waypoint, "font-size": 11, "font-weight": "bold",
      "font-family": "sans-serif" }, g, String(i + 1));
  });
}

function drawPose(svg, T, key, color) {
  const p = state.scenario[key];
  const x = val(p[0]), y = val(p[1]), th = val(p[2]);
  const g = el("g", { id: key }, svg);
  const L = 34, hx = T.X(x) + L * Math.cos(th), hy = T.Y(y) - L * Math.sin(th);
  el("line", { x1: T.X(x), y1: T.Y(y), x2: hx, y2: hy, stroke: color, "stroke-width": 2 }, g);
  arrowHead(g, { X: () => hx, Y: () => hy }, 0, 0, th, color, 9);
  el("circle", { cx: T.X(x), cy: T.Y(y), r: 8, fill: color, stroke: "#fff", "stroke-width": 2,
    "data-pose": key, style: "cursor: move" }, g);
  el("circle", { cx: hx, cy: hy, r: 6, fill: "transparent", stroke: color, "stroke-width": 1.5,
    "data-heading": key, style: "cursor: grab" }, g);
  const label = el("text", { fill: color, "font-size": 12, "font-family": "sans-serif",
    "font-weight": "bold" }, g, key);
  placePoseLabel(label, T, T.X(x), T.Y(y), [hx, hy]);
}

// A pose's label beside its point: below right, else at the first corner where it covers
// neither the path drawn nor the heading's handle (the fewest points of them).
function placePoseLabel(label, T, X, Y, handle) {
  const points = pathPoints(T);
  points.push(handle, [(X + handle[0]) / 2, (Y + handle[1]) / 2]);
  let best = null;
  for (const [dx, dy, anchor] of [[10, 20, "start"], [10, -12, "start"], [-10, 20, "end"],
    [-10, -12, "end"]]) {
    label.setAttribute("x", X + dx);
    label.setAttribute("y", Y + dy);
    label.setAttribute("text-anchor", anchor);
    const b = label.getBBox();
    const score = points.filter(([px, py]) => px > b.x - 4 && px < b.x + b.width + 4
      && py > b.y - 4 && py < b.y + b.height + 4).length;
    if (best === null || score < best.score) best = { score, dx, dy, anchor };
    if (score === 0) break;
  }
  label.setAttribute("x", X + best.dx);
  label.setAttribute("y", Y + best.dy);
  label.setAttribute("text-anchor", best.anchor);
}

// What the returned motion is: the optimal path only when converged, else what the result
// says it is (a Leapfrog iterate, the initial path, an extremal of a fixed horizon), not optimal.
function motionLabel(r) {
  if (r.optimal) return r.status === "converged" ? "optimal path" : "extremal, collides";
  const s = r.trajectory_source;
  return s.includes("not optimal") || s.includes("not a motion") ? s : `${s}, not optimal`;
}

function drawLegend(svg, T) {
  const r = state.result;
  const g = el("g", { id: "legend", "font-size": 11, "font-family": "sans-serif" }, svg);
  const rows = [];
  if (r) {
    if (r.path) rows.push([r.optimal ? COLORS.path : COLORS.notOptimal, motionLabel(r)]);
    if (r.path && r.path.reverse.some((v) => v)) rows.push([COLORS.reverse, "reversing (v < 0)"]);
    if (r.alternatives.some((a) => a.path)) rows.push([COLORS.alternative, "other initial paths"]);
    if (state.frame !== null) rows.push([COLORS.sweep, "Leapfrog junctions"]);
  }
  if ((state.scenario.waypoints || []).length) rows.push([COLORS.waypoint, "waypoints"]);
  if (robotRadius() > 0) rows.push([COLORS.obstacleEdge, `footprint r = ${fmt(robotRadius(), 4)}`]);
  if (!rows.length) return;
  const box = el("rect", { y: 6, height: 8 + 16 * rows.length, fill: "#fff", "fill-opacity": 0.85,
    stroke: COLORS.grid }, g);
  const items = rows.map(([c, text], i) => [
    el("line", { y1: 18 + 16 * i, y2: 18 + 16 * i, stroke: c, "stroke-width": 3 }, g),
    el("text", { y: 22 + 16 * i, fill: "#333" }, g, text)]);
  // as wide as its longest entry (a motion that is not optimal says what it is), at least 150
  const w = Math.max(150, 42 + Math.max(...items.map(([, t]) => t.getComputedTextLength())));
  const x = T.w - w - 8;
  box.setAttribute("x", x);
  box.setAttribute("width", w);
  for (const [line, text] of items) {
    line.setAttribute("x1", x + 8);
    line.setAttribute("x2", x + 28);
    text.setAttribute("x", x + 34);
  }
}

function drawRoom() {
  const svg = $("view");
  svg.replaceChildren();
  if (!state.scenario) return;
  if (!state.bounds) fitBounds();
  const T = transform(svg);
  svg.setAttribute("viewBox", `0 0 ${T.w} ${T.h}`);
  svg.setAttribute("width", T.w);
  svg.setAttribute("height", T.h);
  drawGrid(svg, T);
  drawObstacles(svg, T);
  drawFootprint(svg, T);
  drawAlternatives(svg, T);
  drawPath(svg, T);
  drawSweep(svg, T);
  drawWaypoints(svg, T);
  drawPose(svg, T, "start", COLORS.start);
  drawPose(svg, T, "goal", COLORS.goal);
  drawLegend(svg, T);
  drawAlternativeLabels(svg, T);
}

