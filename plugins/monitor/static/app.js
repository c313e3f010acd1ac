// The monitor page: one websocket, the tree, the camera, the overhead view, the blackboard,
// the events and the outcome; controls for a live run, a timeline for a recording.

import { TreeView } from "./tree.js";
import { CameraView, OverheadView } from "./views.js";

const $ = (id) => document.getElementById(id);
const token = new URLSearchParams(location.search).get("token");
const LEVELS = {
  exception: 4, component_error: 4, hook_error: 4, halt_error: 4, stop_timeout: 4, forced_exit: 4,
  fail: 4, paused: 2, resumed: 2, step: 2, reload: 2, start: 2,
};

const PLAY_ICON = '<svg viewBox="0 0 12 12"><path d="M2 1v10l9-5z"/></svg>';
const PAUSE_ICON = '<svg viewBox="0 0 12 12"><rect x="1.5" y="1" width="3" height="10" rx="0.8"/><rect x="7.5" y="1" width="3" height="10" rx="0.8"/></svg>';

const page = {
  mode: "live",
  run: {},
  tree: null,
  letters: "",
  blackboard: {},
  written: new Set(),
  events: [],
  result: null,
  control: "running",
  ended: false,
  ws: null,
  // Replay
  ticks: 0,
  tick: 0,
  playing: false,
  waiting: false,
  // For tests and the latency benchmark: status changes seen, and how late they were drawn.
  log: { ticks: [], latencies: [], received: [], statusChanges: 0 },
};
window.armtree = page;

const treeView = new TreeView($("tree"), $("tooltip"), showDetail);
const camera = new CameraView($("camera"), $("camera-caption"), $("camera-empty"));
const overhead = new OverheadView($("overhead"), $("scene-caption"), $("scene-empty"));

function escapeHtml(text) {
  return String(text).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]);
}

function compact(value) {
  if (typeof value === "string") return value;
  const text = JSON.stringify(value);
  return text === undefined ? String(value) : text;
}

// ------------------------------------------------------------------ connection

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${scheme}://${location.host}/ws${token ? "?token=" + encodeURIComponent(token) : ""}`);
  ws.binaryType = "arraybuffer";
  page.ws = ws;
  ws.onmessage = (event) => {
    if (typeof event.data === "string") handle(JSON.parse(event.data));
    else image(event.data);
  };
  ws.onclose = () => {
    page.ws = null;
    if (page.ended || page.mode === "replay") {
      if (!page.ended) setState("disconnected", "disconnected");
      return;
    }
    setState("disconnected", "disconnected");
    setTimeout(connect, 1000);
  };
}

function send(message) {
  if (page.ws && page.ws.readyState === WebSocket.OPEN) page.ws.send(JSON.stringify(message));
}

function handle(m) {
  switch (m.type) {
    case "hello": return hello(m);
    case "state": return state(m);
    case "tick": return tick(m);
    case "control": page.control = m.state; return refreshState();
    case "scene": return overhead.show(m.scene);
    case "clients": $("st-viewers").textContent = m.count > 1 ? `${m.count} pages watching` : ""; return;
    case "speed": $("speed").value = m.speed === null ? "max" : String(m.speed); return;
    case "end": return end(m.result);
    case "watch": return watchNews(m);
    case "timeline": return timeline(m);
    default: return undefined;
  }
}

async function image(buffer) {
  const view = new DataView(buffer);
  const length = view.getUint32(0);
  const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
  await camera.show(header, new Uint8Array(buffer, 4 + length));
  if (page.mode === "live") send({ type: "image_ack" });
}

// ------------------------------------------------------------------ messages

function hello(m) {
  page.mode = m.mode;
  page.run = m.run || {};
  $("mode").textContent = m.mode;
  $("tree-name").textContent = page.run.tree || "tree";
  document.title = `${page.run.tree || "tree"} · armtree monitor`;
  const live = m.mode === "live";
  $("controls").hidden = !live;
  $("timeline").hidden = live;
  $("speed-box").hidden = !(live && page.run.clock === "virtual");
  if (live && page.run.speed !== undefined) $("speed").value = page.run.speed === null ? "max" : String(page.run.speed);
  if (!live) {
    setState("replay", "replay");
    if (m.notice) banner(m.notice, "info");
  }
}

function state(m) {
  if (m.tree && (!page.tree || JSON.stringify(m.tree.nodes.map((n) => n.path)) !== JSON.stringify(page.tree.nodes.map((n) => n.path)))) {
    page.tree = m.tree;
    treeView.setTree(m.tree);
    requestAnimationFrame(() => treeView.fit());
  } else if (m.tree) {
    page.tree = m.tree;
  }
  page.letters = m.letters;
  treeView.feedback = {};
  treeView.setStatuses(m.letters, intKeys(m.feedback));
  page.blackboard = { ...(m.blackboard || {}) };
  page.written = new Set(Array.isArray(m.written) ? m.written : Object.keys(m.written || {}));
  renderBlackboard();
  page.events = m.events || [];
  renderEvents();
  stats(m);
  if (m.control) page.control = m.control;
  if (m.scene) overhead.show(m.scene);
  if (m.result) end(m.result, true); else if (page.mode === "replay") hideOutcome();
  if (m.reload_error) watchNews(m.reload_error);
  if (page.mode === "replay") {
    page.tick = m.tick;
    page.waiting = false;
    $("tl-slider").value = String(m.tick);
    $("tl-label").textContent = `tick ${m.tick} / ${page.ticks} · t ${Number(m.t).toFixed(2)} s`;
    if (!m.image) camera.clear(m.image_note || "no camera frame at or before this tick");
  }
  refreshState();
  document.body.dataset.tick = String(m.tick);
}

function intKeys(object) {
  const out = {};
  for (const [k, v] of Object.entries(object || {})) out[Number(k)] = v;
  return out;
}

function tick(m) {
  const changed = m.letters !== page.letters;
  page.letters = m.letters;
  treeView.setStatuses(m.letters, intKeys(m.feedback));
  if (changed) {
    page.log.statusChanges += 1;
    if (m.wall) {
      const wall = m.wall;
      page.log.received.push(Date.now() / 1000 - wall);
      requestAnimationFrame(() => page.log.latencies.push(Date.now() / 1000 - wall));
      if (page.log.received.length > 5000) { page.log.received.splice(0, 2500); page.log.latencies.splice(0, 2500); }
    }
  }
  page.log.ticks.push(m.tick);
  if (page.log.ticks.length > 2000) page.log.ticks.splice(0, 1000);
  const written = m.written || {};
  Object.assign(page.blackboard, written);
  page.written = new Set(Object.keys(written));
  if (Object.keys(written).length || page.hadWrites) renderBlackboard();
  page.hadWrites = Object.keys(written).length > 0;
  if (m.records && m.records.length) {
    for (const r of m.records) {
      if (r.kind === "result") page.result = r; else page.events.push(r);
    }
    renderEvents();
  }
  stats(m);
  document.body.dataset.tick = String(m.tick);
  document.body.dataset.letters = m.letters;
}

function stats(m) {
  $("st-tick").textContent = m.tick;
  $("st-t").textContent = Number(m.t || 0).toFixed(2);
  const s = m.stats || {};
  if (s.rate_hz !== undefined) $("st-rate").textContent = s.rate_hz ? s.rate_hz.toFixed(1) : "–";
  if (s.tick_ms_mean !== undefined) $("st-ms").textContent = `${s.tick_ms_mean.toFixed(1)} / ${s.tick_ms_max.toFixed(1)}`;
  if (s.overruns !== undefined) $("st-over").textContent = s.overruns;
}

function setState(cls, text) {
  const el = $("state");
  el.className = `badge state-${cls}`;
  el.textContent = text;
  document.body.dataset.state = cls;
}

function refreshState() {
  if (page.mode === "replay") return;
  if (page.ended) return;
  setState(page.control, page.control);
  const paused = page.control === "paused";
  $("btn-pause").disabled = page.control !== "running";
  $("btn-resume").disabled = page.control === "running";
  $("btn-step").disabled = !(paused || page.control === "running");
  $("btn-stop").disabled = false;
}

function end(result, fromState = false) {
  page.result = result;
  if (page.mode === "live") {
    page.ended = true;
    const status = result ? result.status : "ENDED";
    setState(`ended-${status}`, `ended: ${status.toLowerCase()}`);
    for (const id of ["btn-pause", "btn-step", "btn-resume", "btn-stop"]) $(id).disabled = true;
    $("speed").disabled = true;
  }
  if (result) showOutcome(result);
  if (!fromState) renderEvents();
}

function hideOutcome() { $("outcome-panel").hidden = true; }

function showOutcome(r) {
  const verdict = r.verdict || r.status;
  const good = r.status === "SUCCESS" && verdict !== "false success";
  const expectations = (r.expectations || []).map((e) => {
    const status = String(e.status || "").toLowerCase();
    const cls = status.startsWith("pass") || status === "ok" ? "pass" : status.startsWith("fail") ? "fail" : "other";
    const detail = [e.measured !== undefined && e.measured !== null ? compact(e.measured) : "", e.detail || ""].filter(Boolean).join(" · ");
    return `<li class="${cls}">${escapeHtml(compact(e.expect))}${detail ? ` <span class="tip-type">${escapeHtml(detail)}</span>` : ""}</li>`;
  }).join("");
  const chain = (r.chain || []).map((f) => `${f.node}${f.why ? ": " + f.why : ""}`).join("\n  ← ");
  $("outcome").innerHTML = `
    <div class="verdict ${good ? "good" : "bad"}">${escapeHtml(verdict)} · ${r.ticks} ticks · ${Number(r.seconds).toFixed(2)} s</div>
    ${r.message ? `<div class="why">${escapeHtml(r.message)}</div>` : ""}
    ${expectations ? `<ul class="expects">${expectations}</ul>` : ""}
    ${chain ? `<div class="why">failed: ${escapeHtml(chain)}</div>` : ""}`;
  $("outcome-panel").hidden = false;
}

function watchNews(m) {
  if (!m) return;
  if (m.kind === "invalid") banner(`${m.text}:\n${(m.errors || []).join("\n")}`);
  else banner(m.text, "info");
}

function banner(text, kind = "error") {
  const el = $("banner");
  el.hidden = !text;
  el.className = kind === "info" ? "info" : "";
  el.textContent = text || "";
}

// ------------------------------------------------------------------ side panels

function renderBlackboard() {
  const body = $("blackboard").tBodies[0];
  const keys = Object.keys(page.blackboard).sort();
  const rows = keys.map((key) => {
    const tr = document.createElement("tr");
    if (page.written.has(key)) tr.className = "written";
    const k = document.createElement("td");
    k.className = "key";
    k.textContent = key;
    const v = document.createElement("td");
    v.className = "value";
    const text = compact(page.blackboard[key]);
    v.textContent = text.length > 300 ? text.slice(0, 297) + "…" : text;
    v.title = text;
    tr.append(k, v);
    return tr;
  });
  if (!rows.length) {
    const tr = document.createElement("tr");
    tr.innerHTML = `<td class="value" colspan="2">nothing on the blackboard yet</td>`;
    rows.push(tr);
  }
  body.replaceChildren(...rows);
}

function levelOf(r) {
  return LEVELS[r.event] || 3;
}

function renderEvents() {
  const list = $("events");
  const events = page.events;
  $("events-count").textContent = events.length ? `${events.length}` : "";
  if (!events.length) {
    list.innerHTML = `<li class="empty">no events: collisions, drops, retries, faults and interrupts appear here</li>`;
    return;
  }
  const items = events.slice(-300).map((r) => {
    const li = document.createElement("li");
    li.className = `lv-${levelOf(r)}`;
    const rest = Object.entries(r).filter(([k]) => !["kind", "tick", "t", "event", "traceback"].includes(k));
    const detail = rest.map(([k, v]) => `${k}: ${compact(v)}`).join("  ");
    li.innerHTML = `<span class="tk">#${r.tick}</span><span class="tk">${Number(r.t).toFixed(2)} s</span>` +
      `<span class="ev">${escapeHtml(r.event || r.kind)}</span>` +
      (detail ? `<span class="det">${escapeHtml(detail)}</span>` : "");
    return li;
  });
  list.replaceChildren(...items);
  list.scrollTop = list.scrollHeight;
}

function showDetail(id, refresh) {
  const box = $("node-detail");
  if (id === null) { box.hidden = true; return; }
  box.innerHTML = `<button class="close" title="close">×</button>${treeView.details(id)}`;
  box.querySelector(".close").onclick = () => treeView.select(id);
  box.hidden = false;
}

// ------------------------------------------------------------------ replay

function timeline(m) {
  page.ticks = m.ticks;
  const slider = $("tl-slider");
  slider.max = String(m.ticks);
  const marks = $("tl-marks");
  marks.replaceChildren(...(m.marks || []).map((mark) => {
    const i = document.createElement("i");
    i.style.left = `${m.ticks ? (100 * mark.tick) / m.ticks : 0}%`;
    i.className = `lv-${mark.level || 3}`;
    i.title = `#${mark.tick} ${mark.label}`;
    return i;
  }));
  if (m.notice) banner(m.notice, m.truncated ? "error" : "info");
  setState("replay", m.truncated ? "cut short" : "recorded");
}

function seek(tickNumber) {
  const t = Math.max(0, Math.min(page.ticks, Math.round(tickNumber)));
  page.waiting = true;
  send({ type: "seek", tick: t });
}

let playTimer = null;
function play(on) {
  page.playing = on;
  $("tl-play").innerHTML = on ? PAUSE_ICON : PLAY_ICON;
  if (playTimer) { clearInterval(playTimer); playTimer = null; }
  if (!on) return;
  if (page.tick >= page.ticks) seek(0);
  let last = performance.now();
  let position = page.tick;
  playTimer = setInterval(() => {
    const now = performance.now();
    const speed = Number($("tl-speed").value);
    position += ((now - last) / 1000) * speed * (page.run.tick_hz || 20);
    last = now;
    if (position >= page.ticks) { position = page.ticks; play(false); }
    if (!page.waiting && Math.floor(position) !== page.tick) seek(Math.floor(position));
  }, 30);
}

// ------------------------------------------------------------------ controls

function control(action, value) { send({ type: "control", action, value }); }

$("btn-pause").onclick = () => control("pause");
$("btn-step").onclick = () => control("step");
$("btn-resume").onclick = () => control("resume");
$("btn-stop").onclick = () => control("stop");
$("speed").onchange = (e) => control("speed", e.target.value);
$("btn-fit").onclick = () => treeView.fit();
$("btn-expand").onclick = () => treeView.expandAll();
$("tl-slider").oninput = (e) => { play(false); seek(Number(e.target.value)); };
$("tl-start").onclick = () => { play(false); seek(0); };
$("tl-end").onclick = () => { play(false); seek(page.ticks); };
$("tl-back").onclick = () => { play(false); seek(page.tick - 1); };
$("tl-fwd").onclick = () => { play(false); seek(page.tick + 1); };
$("tl-play").onclick = () => play(!page.playing);

window.addEventListener("keydown", (e) => {
  if (e.target.tagName === "INPUT" || e.target.tagName === "SELECT") return;
  if (e.key === "f") treeView.fit();
  if (page.mode === "live" && !page.ended) {
    if (e.key === " ") { e.preventDefault(); control(page.control === "running" ? "pause" : "resume"); }
    if (e.key === "n") control("step");
  } else if (page.mode === "replay") {
    if (e.key === " ") { e.preventDefault(); play(!page.playing); }
    if (e.key === "ArrowRight") { play(false); seek(page.tick + 1); }
    if (e.key === "ArrowLeft") { play(false); seek(page.tick - 1); }
    if (e.key === "Home") { play(false); seek(0); }
    if (e.key === "End") { play(false); seek(page.ticks); }
  }
});
window.addEventListener("resize", () => { if (!treeView.fitted) treeView.fit(); });

renderBlackboard();
renderEvents();
connect();
