// leapfrog serve: the plots of the controls below the room, one a control of the model the
// plan used (v and omega for the unicycle, omega_R and omega_L for the differential drive,
// v, sigma and the planning aid omega for the car), each with round ticks and the bounds the
// scenario sets on it (dashed). Uses app.js's state and helpers and draw.js's ticks.
"use strict";

const PLOT_COLORS = ["#1565c0", "#6a1b9a", "#00897b", "#ef6c00"];

function drawPlot(svg, t, ys, name, color, bound) {
  svg.replaceChildren();
  const box = svg.getBoundingClientRect();
  const w = Math.max(box.width, 100), h = Math.max(box.height, 80);
  svg.setAttribute("viewBox", `0 0 ${w} ${h}`);
  el("rect", { x: 0, y: 0, width: w, height: h, fill: "#fff" }, svg);
  const font = { "font-size": 10, "font-family": "sans-serif", fill: COLORS.label };
  const title = el("text", { ...font, "font-size": 11, x: 8, y: 14, fill: "#333",
    "font-weight": "bold", class: "plot-title" }, svg, bound ? `${name}(t) in [${fmt(bound[0], 4)},`
    + ` ${fmt(bound[1], 4)}]` : `${name}(t)`);
  if (!t || !ys || t.length < 2) return;
  const good = ys.filter((v) => v !== null);
  if (good.every((v) => v === 0)) title.textContent += " = 0";  // the car's omega: its aid, unused
  let lo = Math.min(0, ...good, ...(bound || [])), hi = Math.max(0, ...good, ...(bound || []));
  if (hi - lo < 1e-9) { hi += 1; lo -= 1; }
  const pad = 0.04 * (hi - lo);
  lo -= pad; hi += pad;
  const L = 44, R = 12, top = 22, bottom = 18;
  const t0 = t[0], t1 = t[t.length - 1];
  const X = (v) => L + ((v - t0) / (t1 - t0 || 1)) * (w - L - R);
  const Y = (v) => top + (1 - (v - lo) / (hi - lo)) * (h - top - bottom);
  const across = Math.max(3, Math.floor((h - top - bottom) / 24));
  for (const { k, v, text } of ticks(lo, hi, across).values) {
    const stroke = k === 0 ? COLORS.axis : COLORS.grid;
    el("line", { x1: L, y1: Y(v), x2: w - R, y2: Y(v), stroke }, svg);
    el("text", { ...font, x: L - 4, y: Y(v) + 3.5, "text-anchor": "end", class: "tick" }, svg, text);
  }
  const tt = ticks(t0, t1, Math.max(2, Math.floor((w - L - R) / 55))).values;
  tt.forEach(({ v, text }, i) => {
    el("line", { x1: X(v), y1: h - bottom, x2: X(v), y2: h - bottom + 3, stroke: COLORS.axis },
      svg);
    const last = i === tt.length - 1, anchor = last && X(v) > w - R - 20 ? "end" : "middle";
    el("text", { ...font, x: X(v), y: h - 5, "text-anchor": anchor, class: "tick" }, svg,
      last ? `${text} s` : text);
  });
  el("line", { x1: L, y1: top, x2: L, y2: h - bottom, stroke: COLORS.axis }, svg);
  for (const b of bound || []) {
    el("line", { x1: L, y1: Y(b), x2: w - R, y2: Y(b), stroke: COLORS.goal, "stroke-width": 1,
      "stroke-dasharray": "5 3", class: "bound" }, svg);
  }
  const pts = t.map((v, i) => (ys[i] === null ? null
    : `${X(v).toFixed(1)},${Y(ys[i]).toFixed(1)}`));
  el("polyline", { points: pts.filter((p) => p).join(" "), fill: "none", stroke: color,
    "stroke-width": 2 }, svg);
}

// The plots of the plan's controls (before a plan: those of the scenario's model).
function drawPlots() {
  const r = state.result;
  const model = currentModel();
  const names = r ? r.control_names : model ? model.controls : ["v", "omega"];
  const holder = $("plots");
  while (holder.children.length > names.length) holder.lastChild.remove();
  while (holder.children.length < names.length) {
    el("svg", { id: `plot-${holder.children.length}`, class: "plot" }, holder);
  }
  holder.style.gridTemplateColumns = `repeat(${names.length}, minmax(0, 1fr))`;
  const robot = (state.scenario && state.scenario.robot) || {};
  names.forEach((name, k) => {
    const svg = holder.children[k];
    svg.dataset.control = name;
    const bound = Array.isArray(robot[name]) && robot[name].every((v) => typeof v === "number")
      ? robot[name] : null;
    drawPlot(svg, r && r.path ? r.path.t : null, r && r.path ? r.path[name] : null, name,
      PLOT_COLORS[k % PLOT_COLORS.length], bound);
  });
}
