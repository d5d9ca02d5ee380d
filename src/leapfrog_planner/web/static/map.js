// leapfrog serve: a ROS map on the page. The map's YAML file and its image are uploaded
// together; the server loads them with the project's loader and answers with an id (which
// every plan names), the map's place in the world and a start and goal in open space. The map
// is drawn under everything as the server's PNG (one pixel a cell, grey as ROS shows it),
// placed at its origin and turned by the origin's yaw. Uses app.js's state and helpers (and
// robot.js's).
"use strict";

const MAX_MAP_MB = 64;       // the server's bound on the two files together
const CLICK_DELAY_MS = 250;  // a click waits this long, so that a double-click is not two

let pendingClick = null;

function mapShown() {
  const s = state.scenario;
  return state.map && s && s.map && s.map.id === state.map.id ? state.map : null;
}

function readBase64(file) {
  return new Promise((resolve, reject) => {
    const reader = new FileReader();
    reader.onload = () => resolve(String(reader.result).replace(/^data:[^,]*,/, ""));
    reader.onerror = () => reject(reader.error);
    reader.readAsDataURL(file);
  });
}

function readDataUrl(blob) {
  return new Promise((resolve, reject) => {
    const reader = new FileReader();
    reader.onload = () => resolve(String(reader.result));
    reader.onerror = () => reject(reader.error);
    reader.readAsDataURL(blob);
  });
}

function mapNote(text) {
  $("map-info").textContent = text;
}

function autoHorizon() {
  const m = mapShown(), s = state.scenario;
  if (!m || !$("auto-horizon").checked || s.horizon === "free") return;
  const d = Math.hypot(val(s.goal[0]) - val(s.start[0]), val(s.goal[1]) - val(s.start[1]));
  s.horizon = Math.max(1, Math.round((10 * d) / m.speed) / 10);
}

async function openMap() {
  const yaml = $("map-yaml").files[0], image = $("map-image").files[0];
  if (!yaml || !image) {
    mapNote(yaml ? "now choose the map's image (PGM or PNG)" : "now choose the map's YAML file");
    return;
  }
  if (yaml.size + image.size > MAX_MAP_MB * 2 ** 20) {
    showError(`map: the YAML file and its image are larger than ${MAX_MAP_MB} MB`);
    return;
  }
  mapNote(`opening ${yaml.name}…`);
  try {
    const body = JSON.stringify({
      yaml: { name: yaml.name, data: await readBase64(yaml) },
      image: { name: image.name, data: await readBase64(image) },
    });
    const resp = await fetch("/api/maps", { method: "POST", body,
      headers: { "Content-Type": "application/json" } });
    const info = await resp.json();
    if (!resp.ok) { showError(info.error || `error ${resp.status}`); mapNote(""); return; }
    const png = await fetch(info.image);
    if (!png.ok) { showError(`map: its image was not served (error ${png.status})`); return; }
    info.href = await readDataUrl(await png.blob());  // kept in the PNG download of the view
    showError("");
    useMap(info);
  } catch (e) {
    showError(`map: not opened (${e.message})`);
    mapNote("");
  }
}

function useMap(info) {
  const s = state.scenario;
  const pending = state.pendingMap;
  state.map = info;
  state.pendingMap = null;
  if (pending && pending.file === info.name) {
    // the map of the scenario file just opened: its task kept as the file gives it
    s.map = { id: info.id, ...(pending.unknown ? { unknown: pending.unknown } : {}),
      ...(pending.length ? { length: pending.length } : {}) };
    $("auto-horizon").checked = false;
    mapNote(`${info.name}: ${info.columns} × ${info.rows} cells of ${fmt(info.resolution)} m,`
      + " with the scenario file's task.");
  } else {
    s.map = { id: info.id };
    s.name = info.name.replace(/\.[^.]*$/, "") || "map";
    s.obstacles = [];
    delete s.waypoints;  // not taken with a map
    s.penalty = { ...(s.penalty || {}), weight: 1 };
    setRobotRadius(info.radius);
    if (info.start && info.goal) { s.start = info.start; s.goal = info.goal; }
    matchStates(s);  // the car's steering angle, 0
    $("auto-horizon").checked = true;
    autoHorizon();
    mapNote(`${info.name}: ${info.columns} × ${info.rows} cells of ${fmt(info.resolution)} m.`
      + ` Set for the map: robot radius ${info.radius} m, weight W 1, no discs, and the horizon`
      + ` from the straight-line distance at ${info.speed} m/s (untick "horizon from the distance" to type your own).`
      + " Click the map to place the start, then the goal; drag them as before.");
  }
  $("click-sets").value = "start";
  $("close-map").disabled = false;
  state.selected = null;
  state.result = null;
  state.frame = null;
  state.bounds = null;
  fitBounds();
  render();
  schedule(0);
}

function closeMap() {
  if (!state.map) return;
  state.map = null;
  if (state.scenario) delete state.scenario.map;
  $("close-map").disabled = true;
  $("map-yaml").value = "";
  $("map-image").value = "";
  mapNote("");
  state.result = null;
  render();
  schedule(0);
}

// A scenario file opened with a [map] table: its map is attached when it is the one open,
// else the page asks for it (the server reads no file of the user's machine).
function scenarioMap(table) {
  state.pendingMap = null;
  if (!table) {
    if (state.map) { state.map = null; mapNote(""); }
    return;
  }
  if (state.map && table.file === state.map.name) {
    state.scenario.map = { ...table, id: state.map.id };
    delete state.scenario.map.file;
    return;
  }
  state.map = null;
  state.pendingMap = table;
  mapNote(`This scenario plans on the map ${table.file || "(unnamed)"}: open it below`
    + " (its YAML file and its image).");
}

function mapBounds(add) {
  const m = mapShown();
  if (!m) return;
  const [x0, x1, y0, y1] = m.known;
  add(x0, y0);
  add(x1, y1);
}

function drawMap(parent, T) {
  const m = mapShown();
  if (!m) return;
  const [ox, oy, yaw] = m.origin;
  const w = m.columns * m.resolution * T.s, h = m.rows * m.resolution * T.s;
  const deg = (-yaw * 180) / Math.PI;
  const place = `translate(${T.X(ox)} ${T.Y(oy)}) rotate(${deg})`;
  el("image", { id: "map", href: m.href, x: 0, y: -h, width: w, height: h,
    preserveAspectRatio: "none", style: "image-rendering: pixelated", transform: place,
    "data-map": m.id }, parent);
  // its edge: free cells are nearly white
  el("rect", { x: 0, y: -h, width: w, height: h, transform: place, fill: "none",
    stroke: COLORS.axis, "stroke-width": 1 }, parent);
}

function placeLater(x, y) {
  if (!mapShown()) return;
  clearTimeout(pendingClick);
  pendingClick = setTimeout(() => placePose(x, y), CLICK_DELAY_MS);
}

function cancelPlace() {
  clearTimeout(pendingClick);
  pendingClick = null;
}

function placePose(x, y) {
  const key = $("click-sets").value, p = state.scenario[key];
  p[0] = Number(x.toFixed(3));
  p[1] = Number(y.toFixed(3));
  // headed from the start to the goal (both, once the goal is placed)
  const s = state.scenario;
  const a = Math.atan2(val(s.goal[1]) - val(s.start[1]), val(s.goal[0]) - val(s.start[0]));
  for (const k of key === "goal" ? ["start", "goal"] : ["start"]) s[k][2] = Number(a.toFixed(4));
  $("click-sets").value = key === "start" ? "goal" : "start";
  autoHorizon();
  render();
  schedule(0);
}

function wireMap() {
  for (const id of ["map-yaml", "map-image"]) $(id).addEventListener("change", openMap);
  $("close-map").addEventListener("click", closeMap);
  $("auto-horizon").addEventListener("change", () => { autoHorizon(); render(); schedule(0); });
  $("horizon").addEventListener("input", () => { $("auto-horizon").checked = false; });
}
