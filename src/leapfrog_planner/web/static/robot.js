// leapfrog serve: the robot and the waypoints, as a scenario file's [robot] table and its
// waypoints = [[x, y], ...] give them. The models, their controls and their parameters come
// from /api/models: the model's parameters and a [min, max] bound for each of its controls
// are fields of the Robot panel (empty: the default, or no bound), the footprint is the
// radius and the margin; waypoints are added on the scene (Shift+click) or with the button,
// dragged, and removed. Uses app.js's state and helpers.
"use strict";

let models = [];  // what /api/models answered

async function loadModels() {
  const resp = await fetch("/api/models");
  models = (await resp.json()).models;
  fillMenu($("model"), models.map((m) => [m.name, m.description]));
}

function currentModel() {
  const s = state.scenario;
  const name = (s && s.robot && s.robot.model) || "unicycle";
  return models.find((m) => m.name === name) || null;
}

function robotRadius() {
  const s = state.scenario;
  return Math.max(val(s && s.robot ? s.robot.radius : 0), 0);
}

function setRobotRadius(r) {
  state.scenario.robot = { ...(state.scenario.robot || {}), radius: r };
}

function robotTable() {
  const s = state.scenario;
  s.robot = s.robot || { model: "unicycle" };
  return s.robot;
}

// Another model: the footprint and the bounds on controls of the same name kept, its own
// parameters at their defaults, and the start and goal given as many numbers as it has
// states (the car's fourth, the steering angle, 0).
function setModel(name) {
  const m = models.find((x) => x.name === name);
  const s = state.scenario;
  if (!m || !s) return;
  const old = s.robot || {};
  const robot = { model: name };
  for (const k of ["radius", "margin"]) if (k in old) robot[k] = old[k];
  for (const c of m.controls) if (Array.isArray(old[c])) robot[c] = old[c];
  s.robot = robot;
  matchStates(s);
  state.result = null;
  buildRobotPanel();
  render();
  schedule(0);
}

// The start and the goal of `s` as many numbers as its model has states (added ones 0).
function matchStates(s) {
  const m = models.find((x) => x.name === ((s.robot && s.robot.model) || "unicycle"));
  if (!m) return;
  for (const key of ["start", "goal"]) {
    const p = s[key].slice(0, m.states.length);
    while (p.length < m.states.length) p.push(0);
    s[key] = p;
  }
}

function field(id, title, cls = "num") {
  const input = document.createElement("input");
  input.id = id;
  input.className = cls;
  input.inputMode = "decimal";
  input.title = title;
  return input;
}

function row(label, ...children) {
  const div = document.createElement("div");
  div.className = "row";
  const span = document.createElement("span");
  span.textContent = label;
  div.append(span, ...children);
  return div;
}

// The Robot panel's fields of the model: its parameters and a bound for each control.
function buildRobotPanel() {
  const m = currentModel();
  $("model").value = m ? m.name : "unicycle";
  $("model").title = m ? m.description : "";
  const params = $("model-params"), bounds = $("bounds");
  params.replaceChildren();
  bounds.replaceChildren();
  if (!m) return;
  for (const p of m.parameters) {
    const input = field(`param-${p.name}`, `${p.name} (default ${p.default}; empty: the default)`);
    input.placeholder = String(p.default);
    input.addEventListener("input", () => {
      const v = num(input.value), robot = robotTable();
      if (v === "") delete robot[p.name]; else robot[p.name] = v;
      drawRoom();
      schedule();
    });
    params.append(row(p.name, input));
  }
  for (const c of m.controls) {
    const lo = field(`bound-${c}-min`, `the least ${c} (empty on both sides: no bound)`);
    const hi = field(`bound-${c}-max`, `the greatest ${c}`);
    lo.placeholder = "min";
    hi.placeholder = "max";
    const apply = () => {
      const robot = robotTable(), a = num(lo.value), b = num(hi.value);
      if (a === "" && b === "") delete robot[c]; else robot[c] = [a, b];
      drawPlots();
      schedule();
    };
    lo.addEventListener("input", apply);
    hi.addEventListener("input", apply);
    bounds.append(row(c, lo, hi));
  }
  const four = m.states.length > 3;
  for (const key of ["start", "goal"]) {
    $(`${key}-3`).hidden = !four;
    $(`${key}-3`).closest(".row").classList.toggle("four", four);
  }
}

function refreshRobotFields(put) {
  const s = state.scenario, m = currentModel(), robot = s.robot || {};
  if (!m) return;
  if ($("model").value !== m.name) buildRobotPanel();
  put("radius", robot.radius !== undefined ? robot.radius : 0);
  put("margin", robot.margin !== undefined ? robot.margin : 0);
  for (const p of m.parameters) {
    put(`param-${p.name}`, robot[p.name] !== undefined ? robot[p.name] : "");
  }
  for (const c of m.controls) {
    const b = Array.isArray(robot[c]) ? robot[c] : ["", ""];
    put(`bound-${c}-min`, b[0]);
    put(`bound-${c}-max`, b[1]);
  }
  refreshWaypoints(put);
}

// ------------------------------------------------------------------ waypoints

const legs = () => {
  const s = state.scenario;
  return [s.start, ...(s.waypoints || []), s.goal].map((p) => [val(p[0]), val(p[1])]);
};

// A waypoint at (x, y), put in the order where it lengthens the guide the least.
function addWaypoint(x, y) {
  const s = state.scenario, pts = legs();
  let best = 0, cost = Infinity;
  for (let i = 0; i + 1 < pts.length; i++) {
    const [a, b] = [pts[i], pts[i + 1]];
    const c = Math.hypot(x - a[0], y - a[1]) + Math.hypot(b[0] - x, b[1] - y)
      - Math.hypot(b[0] - a[0], b[1] - a[1]);  // what the detour through (x, y) adds
    if (c < cost) { cost = c; best = i; }
  }
  s.waypoints = s.waypoints || [];
  s.waypoints.splice(best, 0, [Number(x.toFixed(3)), Number(y.toFixed(3))]);
  state.selectedWaypoint = best;
  state.selected = null;
  render();
  schedule(0);
}

// The button's waypoint: the middle of the guide's longest leg, moved out of any obstacle the
// footprint would touch there (the user drags it where it should be).
function addWaypointButton() {
  const pts = legs();
  let i = 0;
  for (let k = 1; k + 1 < pts.length; k++) {
    const d = (j) => Math.hypot(pts[j + 1][0] - pts[j][0], pts[j + 1][1] - pts[j][1]);
    if (d(k) > d(i)) i = k;
  }
  let x = (pts[i][0] + pts[i + 1][0]) / 2, y = (pts[i][1] + pts[i + 1][1]) / 2;
  const b = state.bounds, gap = 0.02 * Math.max(b.x1 - b.x0, b.y1 - b.y0);
  for (const ob of state.scenario.obstacles || []) {
    const cx = val(ob.center[0]), cy = val(ob.center[1]), r = val(ob.radius) + robotRadius() + gap;
    const d = Math.hypot(x - cx, y - cy);
    if (d < r) {
      const [ux, uy] = d > 1e-9 ? [(x - cx) / d, (y - cy) / d] : [0, 1];
      x = cx + r * ux; y = cy + r * uy;
    }
  }
  addWaypoint(x, y);
}

function removeWaypoint(i) {
  const s = state.scenario;
  if (!s.waypoints || i === null || i < 0 || i >= s.waypoints.length) return;
  s.waypoints.splice(i, 1);
  if (!s.waypoints.length) delete s.waypoints;
  state.selectedWaypoint = null;
  render();
  schedule(0);
}

// The list of waypoints in the panel: x, y and a remove button each (rebuilt when their
// number changes).
function refreshWaypoints(put) {
  const w = state.scenario.waypoints || [], list = $("waypoint-list");
  const onMap = Boolean(mapShown());
  $("add-waypoint").disabled = onMap;
  $("waypoint-help").textContent = onMap ? "waypoints are not taken with a map"
    : w.length ? "" : "none: Shift+click the room to add one";
  if (list.children.length !== w.length) {
    list.replaceChildren();
    w.forEach((_, i) => {
      const x = field(`wp-${i}-x`, `waypoint ${i + 1}: x`);
      const y = field(`wp-${i}-y`, `waypoint ${i + 1}: y`);
      for (const [input, k] of [[x, 0], [y, 1]]) {
        input.addEventListener("input", () => {
          state.scenario.waypoints[i][k] = num(input.value);
          drawRoom();
          schedule();
        });
      }
      const remove = document.createElement("button");
      remove.type = "button";
      remove.id = `wp-${i}-remove`;
      remove.textContent = "✕";
      remove.title = `remove waypoint ${i + 1}`;
      remove.addEventListener("click", () => removeWaypoint(i));
      list.append(row(String(i + 1), x, y, remove));
    });
  }
  w.forEach((p, i) => {
    put(`wp-${i}-x`, p[0]);
    put(`wp-${i}-y`, p[1]);
    list.children[i].classList.toggle("selected", i === state.selectedWaypoint);
  });
}

function wireRobot() {
  $("model").addEventListener("change", () => setModel($("model").value));
  onField("radius", (v) => { setRobotRadius(v); });
  onField("margin", (v) => { robotTable().margin = v; });
  $("add-waypoint").addEventListener("click", addWaypointButton);
}
