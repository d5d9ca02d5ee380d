// leapfrog serve: the page. Plain JavaScript, no build step, nothing fetched from elsewhere.
// The scenario is kept in the layout of a scenario file (what /api/scenarios gives); every
// edit plans it again (debounced; a newer request aborts and supersedes the older one).
"use strict";

const SVGNS = "http://www.w3.org/2000/svg";
const COLORS = {
  grid: "#e8ebef", axis: "#b8c0ca", label: "#6b7685",
  obstacle: "#c7ced8", obstacleEdge: "#59636f", selected: "#1565c0",
  path: "#1565c0", reverse: "#d81b60", notOptimal: "#ef6c00", alternative: "#8a94a3",
  start: "#1b7f3b", goal: "#b3261e", sweep: "#2e7d32", handle: "#ffffff", waypoint: "#7b1fa2",
};
const session = Math.random().toString(36).slice(2) + Date.now().toString(36);

const state = {
  scenario: null,        // the scenario file's layout
  name: "",              // what the scenario menu shows
  options: { method: "modified-newton", initial_paths: 3, partitions: 8 },
  selected: null,        // index of the selected obstacle
  selectedWaypoint: null, // index of the selected waypoint
  result: null,          // the last plan's view
  frame: null,           // the sweep shown (index into result.frames), null: none
  bounds: null,          // world box shown: {x0, y0, x1, y1}
  drag: null,
  map: null,             // the map opened (map.js): what /api/maps answered, and its image
  pendingMap: null,      // the [map] table of a scenario file whose map is not open yet
};

const $ = (id) => document.getElementById(id);

// ------------------------------------------------------------------ numbers and geometry

function num(text) {
  // a number when the text is one, else the text itself: the server names what is wrong
  const t = String(text).trim();
  if (t === "") return t;
  const v = Number(t);
  return Number.isFinite(v) ? v : t;
}

const val = (v, fallback = 0) => (typeof v === "number" && Number.isFinite(v) ? v : fallback);

function fmt(v, digits = 6) {
  if (v === null || v === undefined || !Number.isFinite(v)) return "–";
  return Number(v.toPrecision(digits)).toString();
}

function short(v) {
  return typeof v === "number" ? String(Number(v.toFixed(4))) : String(v);
}

function wrapPi(a) {
  return a - 2 * Math.PI * Math.round(a / (2 * Math.PI));
}

// ------------------------------------------------------------------ the panel

function setText(id, text) { $(id).textContent = text; }

function showError(message) {
  const box = $("error");
  box.textContent = message;
  box.hidden = !message;
}

function showResult() {
  const r = state.result;
  const status = $("status");
  if (!r) {
    status.className = "";
    status.textContent = "";
    for (const id of ["cost", "energy", "penalty", "clearance", "time", "sweeps"]) setText(id, "–");
    $("alternatives").textContent = "";
    return;
  }
  // A converged extremal with a cheaper collision-free motion beside it: a caution, not a pass.
  status.className = r.cheaper_motion === null ? r.status : `${r.status} caution`;
  status.replaceChildren();
  const b = document.createElement("b");
  b.textContent = r.status;
  status.append(b, r.success ? ` — ${r.message}` : `: ${r.message}`);
  setText("cost", fmt(r.cost));
  $("chosen-row").hidden = !r.free_time;
  if (r.free_time) {
    const f = r.free_time;
    const where = f.bound ? `on its ${f.bound} bound` : f.condition === null ? "no extremal there"
      : `k + H = ${f.condition.toExponential(1)}`;
    setText("chosen", `${fmt(f.horizon)} s (${where})`);
  }
  setText("energy", fmt(r.energy));
  setText("penalty", fmt(r.penalty));
  // null: free space, or no motion to measure (start and goal not connected)
  const none = r.path ? "no obstacles" : "–";
  setText("clearance", r.min_clearance === null ? none : fmt(r.min_clearance, 4));
  setText("time", `${(r.wall_time_s * 1e3).toFixed(0)} ms`);
  setText("sweeps", `${r.sweeps} (${r.newton_iterations} Newton iterations)`);
  const alts = r.alternatives.map((a) => `${a.label}: ${a.status}${a.cost === null ? "" : ", " + fmt(a.cost)}`);
  if (r.failed_alternatives) alts.push(`${r.failed_alternatives} others failed`);
  $("alternatives").textContent = alts.length ? `other initial paths — ${alts.join("; ")}` : "";
}

function refreshFields() {
  const s = state.scenario;
  if (!s) return;
  const put = (id, v) => { const e = $(id); if (document.activeElement !== e) e.value = short(v); };
  const free = s.horizon === "free";
  $("free-time").checked = free;
  $("cruise-speed").disabled = !free;
  $("horizon").disabled = free;
  if (!free) put("horizon", s.horizon);
  if (free && s.cost && s.cost.cruise_speed !== undefined) put("cruise-speed", s.cost.cruise_speed);
  put("weight", s.penalty ? s.penalty.weight : 100);
  $("close-map").disabled = !state.map;
  for (const key of ["start", "goal"]) s[key].forEach((v, i) => { if (i < 4) put(`${key}-${i}`, v); });
  refreshRobotFields(put);
  const ob = state.selected === null ? null : s.obstacles[state.selected];
  for (const [id, get] of [["ob-cx", (o) => o.center[0]], ["ob-cy", (o) => o.center[1]],
    ["ob-r", (o) => o.radius]]) {
    $(id).disabled = !ob;
    if (!ob) $(id).value = ""; else put(id, get(ob));
  }
  $("remove").disabled = !ob;
  $("method").value = state.options.method;
  put("initial_paths", state.options.initial_paths);
  put("partitions", state.options.partitions);
}

function setFrame(k) {
  const r = state.result;
  if (!r || !r.frames.length) { state.frame = null; setText("sweep-info", ""); return; }
  state.frame = Math.max(0, Math.min(k, r.frames.length - 1));
  $("sweep").value = state.frame;
  const f = r.frames[state.frame];
  setText("sweep-info", `${f.sweep === 0 ? "initial path" : "sweep " + f.sweep} of ${r.frames.length - 1}: q = ${f.q}, cost ${fmt(f.cost)}`);
}

function render() {
  drawRoom();
  drawPlots();
  showResult();
  refreshFields();
}

// ------------------------------------------------------------------ planning

let seq = 0, timer = null, inflight = null;

function schedule(delay = 180) {
  clearTimeout(timer);
  timer = setTimeout(planNow, delay);
}

function request() {
  return { scenario: state.scenario, options: state.options, session, seq };
}

async function planNow() {
  if (!state.scenario) return;
  const my = ++seq;
  if (inflight) inflight.abort();
  inflight = new AbortController();
  $("busy").hidden = false;
  const t0 = performance.now();
  try {
    const resp = await fetch("/api/plan", { method: "POST", signal: inflight.signal,
      headers: { "Content-Type": "application/json" }, body: JSON.stringify(request()) });
    const body = await resp.json();
    if (my !== seq) return; // a newer request is on its way
    if (resp.status === 409) return;
    if (resp.status === 503 && resp.headers.has("Retry-After")) { // its model is not ready yet
      waitingForSolver = true; // planned again as soon as it is
      showError("");
      state.result = null; // not the path of another model, or of an earlier edit
      render();
      watchSolver();
      return;
    }
    if (!resp.ok) {
      showError(body.error || `error ${resp.status}`);
      state.result = null;
    } else {
      showError("");
      const playing = animation !== null;
      state.result = body;
      $("sweep").max = Math.max(body.frames.length - 1, 0);
      if (playing || $("show-sweeps").checked) setFrame(playing ? 0 : body.frames.length - 1);
      else state.frame = null;
      setText("latency", `${(performance.now() - t0).toFixed(0)} ms`);
    }
    render();
  } catch (e) {
    if (e.name !== "AbortError" && my === seq) showError(`no answer from the server (${e.message})`);
  } finally {
    if (my === seq) $("busy").hidden = true;
  }
}

// ------------------------------------------------------------------ the solver's warm-up

// A first start on a machine compiles the kernels, about 20 s a model, one model after the
// other (the unicycle first). /api/health says each model's state ("ready", "compiling",
// "waiting", "failed") and where the warm-up is; a plan of a model not ready yet is answered
// with 503 and planned again as soon as its model is ready, while the others still compile.
let waitingForSolver = false, watching = false;

async function health() {
  try {
    return await (await fetch("/api/health")).json();
  } catch (e) {
    return null;
  }
}

function planModel() {
  const s = state.scenario;
  return (s && s.robot && s.robot.model) || "unicycle";
}

function preparingText(p, models, model) {
  const where = p.model ? `the ${p.model} kernels (model ${p.models_done + 1} of ${p.models}), ` : "";
  const then = models[model] === "ready" ? `the ${model} is ready: it plans meanwhile.`
    : `the plan runs as soon as the ${model} is ready.`;
  const seconds = p.model ? `${p.model_seconds.toFixed(0)} s on them, ${p.seconds.toFixed(0)} s in all`
    : `${p.seconds.toFixed(0)} s so far`;
  return `Preparing the solver: ${where}${seconds}. A first start on a ` +
    `machine compiles the kernels, about 20 s a model; ${then}`;
}

// Each model's state in a line: "unicycle ready · diff-drive compiling · car waiting".
function modelsText(models) {
  return Object.entries(models).map(([name, st]) => `${name} ${st}`).join(" · ");
}

function showPreparing(h) {
  $("preparing-text").textContent = preparingText(h.preparing, h.models, planModel());
  $("preparing-models").textContent = modelsText(h.models);
  $("preparing-bar").max = h.preparing.models;
  $("preparing-bar").value = h.preparing.models_done;
  $("preparing").hidden = false;
}

// What waited for the solver: planned once its model is ready, an error if its model failed.
function resumeWaiting(h) {
  if (!waitingForSolver) return;
  const model = planModel(), st = h.models[model];
  if (st === "ready" || st === undefined) { // undefined: a model the server does not warm up
    waitingForSolver = false;
    schedule(0);
  } else if (st === "failed") {
    waitingForSolver = false;
    showError(`the solver could not prepare the ${model} kernels (see the server's log)`);
  }
}

// Show the warm-up's progress while a model is still being prepared, and plan what waited.
async function watchSolver() {
  if (watching) return;
  watching = true;
  let h = await health();
  const pending = (x) => Object.values(x.models).some((st) => st !== "ready");
  while (h === null || (h.preparing !== null && pending(h))) {
    if (h !== null) {
      showPreparing(h);
      resumeWaiting(h);
    }
    await new Promise((resolve) => setTimeout(resolve, 1000));
    h = await health();
  }
  watching = false;
  $("preparing").hidden = true;
  resumeWaiting(h);
  if (waitingForSolver) { // its model is not ready and nothing is starting: see the server's log
    waitingForSolver = false;
    showError("no solver process is running (see the server's log)");
  }
}

// ------------------------------------------------------------------ the sweeps, animated

let animation = null;

function stopAnimation() {
  if (animation !== null) clearInterval(animation);
  animation = null;
  $("play").textContent = "▶ sweeps";
}

function play() {
  if (animation !== null) { stopAnimation(); return; }
  if (!state.result) return;
  $("show-sweeps").checked = true;
  setFrame(0);
  drawRoom();
  $("play").textContent = "❚❚ pause";
  animation = setInterval(() => {
    const r = state.result;
    if (!r || state.frame >= r.frames.length - 1) { stopAnimation(); return; }
    setFrame(state.frame + 1);
    drawRoom();
  }, 450);
}

// ------------------------------------------------------------------ dragging

function pointerWorld(ev) {
  const svg = $("view");
  const box = svg.getBoundingClientRect();
  const T = transform(svg);
  return [T.wx(ev.clientX - box.left), T.wy(ev.clientY - box.top)];
}

function onPointerDown(ev) {
  const t = ev.target, d = t.dataset || {};
  const [x, y] = pointerWorld(ev);
  const s = state.scenario;
  if (!s) return;
  if (d.obstacle !== undefined) {
    const i = Number(d.obstacle), ob = s.obstacles[i];
    state.selected = i;
    state.selectedWaypoint = null;
    state.drag = { kind: "obstacle", i, dx: val(ob.center[0]) - x, dy: val(ob.center[1]) - y };
  } else if (d.resize !== undefined) {
    state.selected = Number(d.resize);
    state.drag = { kind: "resize", i: Number(d.resize) };
  } else if (d.pose !== undefined) {
    const p = s[d.pose];
    state.drag = { kind: "pose", key: d.pose, dx: val(p[0]) - x, dy: val(p[1]) - y };
  } else if (d.heading !== undefined) {
    state.drag = { kind: "heading", key: d.heading };
  } else if (d.waypoint !== undefined) {
    const i = Number(d.waypoint), w = s.waypoints[i];
    state.selectedWaypoint = i;
    state.selected = null;
    state.drag = { kind: "waypoint", i, dx: val(w[0]) - x, dy: val(w[1]) - y };
  } else if (ev.shiftKey && !mapShown()) {
    addWaypoint(x, y);  // Shift+click: a waypoint there
    return;
  } else {
    state.selected = null;
    state.selectedWaypoint = null;
    placeLater(x, y);  // on a map, a click places the start or the goal
    render();
    return;
  }
  $("view").setPointerCapture(ev.pointerId);
  ev.preventDefault();
  render();
}

function onPointerMove(ev) {
  const d = state.drag;
  if (!d) return;
  const [x, y] = pointerWorld(ev);
  const s = state.scenario;
  if (d.kind === "obstacle") {
    s.obstacles[d.i].center = [x + d.dx, y + d.dy];
  } else if (d.kind === "resize") {
    const ob = s.obstacles[d.i];
    ob.radius = Math.max(Math.hypot(x - val(ob.center[0]), y - val(ob.center[1])), 1e-3);
  } else if (d.kind === "pose") {
    s[d.key][0] = x + d.dx;
    s[d.key][1] = y + d.dy;
    autoHorizon();
  } else if (d.kind === "waypoint") {
    s.waypoints[d.i] = [x + d.dx, y + d.dy];
  } else if (d.kind === "heading") {
    const p = s[d.key];
    const a = Math.atan2(y - val(p[1]), x - val(p[0]));
    p[2] = val(p[2]) + wrapPi(a - val(p[2]));
  }
  d.moved = true;
  drawRoom();
  refreshFields();
  schedule(40);
}

function onPointerUp() {
  const d = state.drag;
  state.drag = null;
  if (d && d.moved) schedule(0);
}

function addObstacle(x, y) {
  const b = state.bounds;
  const r = 0.05 * Math.max(b.x1 - b.x0, b.y1 - b.y0);
  state.scenario.obstacles.push({ center: [x, y], radius: Number(r.toPrecision(2)) });
  state.selected = state.scenario.obstacles.length - 1;
  render();
  schedule(0);
}

function removeObstacle() {
  if (state.selected === null) return;
  state.scenario.obstacles.splice(state.selected, 1);
  state.selected = null;
  render();
  schedule(0);
}

// ------------------------------------------------------------------ scenarios and files

function useScenario(scenario, name, map = null) {
  state.scenario = JSON.parse(JSON.stringify(scenario));
  state.scenario.obstacles = state.scenario.obstacles || [];
  scenarioMap(map);
  state.name = name;
  const solver = state.scenario.solver || {};
  state.options = {
    method: solver.method || "modified-newton",
    initial_paths: solver.initial_paths || 3,
    partitions: solver.partitions || 8,
  };
  state.selected = null;
  state.selectedWaypoint = null;
  state.result = null;
  state.frame = null;
  stopAnimation();
  state.bounds = null;
  fitBounds();
  buildRobotPanel();
  render();
  schedule(0);
}

let builtins = [];

// A menu of [value, title] options, each named by its value.
function fillMenu(menu, items) {
  menu.replaceChildren();
  for (const [value, title] of items) {
    const o = document.createElement("option");
    o.value = value;
    o.textContent = value;
    if (title) o.title = title;
    menu.appendChild(o);
  }
}

async function loadBuiltins() {
  await loadModels();
  const resp = await fetch("/api/scenarios");
  const body = await resp.json();
  builtins = body.scenarios;
  fillMenu($("scenario"), builtins.map((s) => [s.name]));
  if (builtins.length) useScenario(builtins[0].scenario, builtins[0].name);
}

async function openFile(file) {
  const text = await file.text();
  const resp = await fetch("/api/open", { method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ toml: text, name: file.name }) });
  const body = await resp.json();
  if (!resp.ok) { showError(body.error); return; }
  showError("");
  const menu = $("scenario");
  let o = menu.querySelector("option[data-file]");
  if (!o) { o = document.createElement("option"); o.dataset.file = "1"; menu.appendChild(o); }
  o.value = `file:${file.name}`;
  o.textContent = `${file.name} (file)`;
  menu.value = o.value;
  useScenario(body.scenario, file.name, body.map);
}

function saveBlob(blob, name) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = name;
  document.body.appendChild(a);
  a.click();
  setTimeout(() => { URL.revokeObjectURL(a.href); a.remove(); }, 1000);
}

async function download(path) {
  const resp = await fetch(path, { method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(request()) });
  if (!resp.ok) { showError((await resp.json()).error); return; }
  const cd = resp.headers.get("Content-Disposition") || "";
  const m = /filename="([^"]+)"/.exec(cd);
  saveBlob(await resp.blob(), m ? m[1] : "download");
}

function downloadPng() {
  const svg = $("view");
  const T = transform(svg);
  const copy = svg.cloneNode(true);
  copy.setAttribute("width", T.w);
  copy.setAttribute("height", T.h);
  const text = new XMLSerializer().serializeToString(copy);
  const img = new Image();
  img.onload = () => {
    const scale = 2;
    const canvas = document.createElement("canvas");
    canvas.width = T.w * scale;
    canvas.height = T.h * scale;
    const ctx = canvas.getContext("2d");
    ctx.scale(scale, scale);
    ctx.drawImage(img, 0, 0);
    canvas.toBlob((blob) => saveBlob(blob, `${state.scenario.name || "view"}.png`), "image/png");
  };
  img.src = "data:image/svg+xml;charset=utf-8," + encodeURIComponent(text);
}

// ------------------------------------------------------------------ wiring

function onField(id, apply) {
  $(id).addEventListener("input", () => { apply(num($(id).value)); drawRoom(); schedule(); });
}

function wire() {
  const svg = $("view");
  svg.addEventListener("pointerdown", onPointerDown);
  svg.addEventListener("pointermove", onPointerMove);
  svg.addEventListener("pointerup", onPointerUp);
  svg.addEventListener("pointercancel", onPointerUp);
  svg.addEventListener("dblclick", (ev) => {
    cancelPlace();
    const d = ev.target.dataset || {};
    if (ev.shiftKey || d.obstacle || d.pose || d.waypoint) return;
    const [x, y] = pointerWorld(ev);
    addObstacle(x, y);
  });
  document.addEventListener("keydown", (ev) => {
    const typing = ["INPUT", "SELECT", "TEXTAREA"].includes(document.activeElement.tagName);
    if (typing || !(ev.key === "Delete" || ev.key === "Backspace")) return;
    if (state.selectedWaypoint !== null) removeWaypoint(state.selectedWaypoint);
    else removeObstacle();
  });
  $("scenario").addEventListener("change", () => {
    const s = builtins.find((b) => b.name === $("scenario").value);
    if (s) useScenario(s.scenario, s.name);
  });
  $("open").addEventListener("change", (ev) => {
    if (ev.target.files.length) openFile(ev.target.files[0]);
    ev.target.value = "";
  });
  $("fit").addEventListener("click", () => { fitBounds(); drawRoom(); });
  $("method").addEventListener("change", () => { state.options.method = $("method").value; schedule(0); });
  onField("initial_paths", (v) => { state.options.initial_paths = v; });
  onField("partitions", (v) => { state.options.partitions = v; });
  onField("horizon", (v) => { state.scenario.horizon = v; });
  $("free-time").addEventListener("change", () => {
    const s = state.scenario;
    if ($("free-time").checked) {
      state.fixedHorizon = s.horizon;
      s.horizon = "free";
      s.cost = { cruise_speed: Number($("cruise-speed").value) || 1 };
    } else {
      s.horizon = state.fixedHorizon || 1;
      delete s.cost;
      delete s.time;
    }
    refreshFields();
    schedule(0);
  });
  onField("cruise-speed", (v) => { state.scenario.cost = { cruise_speed: v }; });
  onField("weight", (v) => {
    state.scenario.penalty = { ...(state.scenario.penalty || {}), weight: v };
  });
  for (const key of ["start", "goal"]) {
    for (const i of [0, 1, 2, 3]) {
      onField(`${key}-${i}`, (v) => { state.scenario[key][i] = v; autoHorizon(); });
    }
  }
  const ob = () => state.scenario.obstacles[state.selected];
  onField("ob-cx", (v) => { ob().center[0] = v; });
  onField("ob-cy", (v) => { ob().center[1] = v; });
  onField("ob-r", (v) => { ob().radius = v; });
  $("add").addEventListener("click", () => {
    const b = state.bounds;
    addObstacle((b.x0 + b.x1) / 2, (b.y0 + b.y1) / 2);
  });
  $("remove").addEventListener("click", removeObstacle);
  $("play").addEventListener("click", play);
  $("show-sweeps").addEventListener("change", () => {
    const r = state.result;
    if ($("show-sweeps").checked && r) setFrame(r.frames.length - 1);
    else { stopAnimation(); state.frame = null; setText("sweep-info", ""); }
    drawRoom();
  });
  $("sweep").addEventListener("input", () => {
    stopAnimation();
    $("show-sweeps").checked = true;
    setFrame(Number($("sweep").value));
    drawRoom();
  });
  $("dl-toml").addEventListener("click", () => download("/api/toml"));
  $("dl-json").addEventListener("click", () => download("/api/result.json"));
  $("dl-csv").addEventListener("click", () => download("/api/result.csv"));
  $("dl-png").addEventListener("click", downloadPng);
  window.addEventListener("resize", () => { drawRoom(); drawPlots(); });
  wireMap();
  wireRobot();
}

wire();
watchSolver();
loadBuiltins().catch((e) => showError(`could not load the scenarios (${e.message})`));
