// The kerf console: one page for every machine, built from what the machine
// announces (/api/machine), kept live by the station's events (/api/stream).
"use strict";

const WINDOW_S = 10;          // seconds of machine time the plots show
const MAX_POINTS = 6000;      // samples kept per plot
const COLOURS = ["#1f5fa8", "#b3261e", "#2f7d32", "#a86a1f", "#6a3fa0", "#00838f"];
const $ = (id) => document.getElementById(id);

const state = { machine: null, charts: [], t: [], v: [], dirty: false };
// Latency from the host reading a sample to the page drawing it, ms.
window.kerfLatency = { count: 0, sum: 0, max: 0, pending: [] };
window.kerfSamples = 0;
window.kerfState = state;  // for the browser test: the plotted samples

async function api(path, options) {
  const r = await fetch(path, options);
  const body = await r.json().catch(() => ({ error: r.statusText }));
  if (!r.ok) throw new Error(body.error || r.statusText);
  return body;
}

function post(path, body) {
  return api(path, {
    method: "POST",
    headers: { "content-type": "application/json" },
    body: JSON.stringify(body || {}),
  });
}

// Charts: each axis beside its reference (x with x_ref), then the rest by unit.
function buildCharts(channels) {
  const names = channels.map((c) => c[0]);
  const used = new Set();
  const charts = [];
  names.forEach((n, i) => {
    const r = names.indexOf(n + "_ref");
    if (r >= 0) {
      charts.push({
        title: n + " against its reference (" + channels[i][1] + ")",
        series: [{ name: n, index: i }, { name: n + "_ref", index: r, dashed: true }],
      });
      used.add(i); used.add(r);
    }
  });
  // Errors apart from the quantities they are errors of (micrometres beside metres).
  const byUnit = new Map();
  channels.forEach(([n, unit], i) => {
    if (used.has(i)) return;
    const key = (n.includes("error") ? "error " : "") + unit;
    if (!byUnit.has(key)) byUnit.set(key, { unit, series: [] });
    byUnit.get(key).series.push({ name: n, index: i });
  });
  for (const { unit, series } of byUnit.values()) {
    charts.push({ title: series.map((s) => s.name).join(", ") + (unit && unit !== "1" ? " (" + unit + ")" : ""), series });
  }
  const host = $("plots");
  host.innerHTML = "";
  charts.forEach((c) => {
    const div = document.createElement("div");
    div.className = "panel plot";
    div.innerHTML = "<h3></h3><canvas></canvas>";
    div.querySelector("h3").textContent = c.title;
    c.canvas = div.querySelector("canvas");
    c.canvas.id = "plot-" + c.series[0].name;
    c.series.forEach((s, j) => { s.colour = COLOURS[j % COLOURS.length]; });
    host.appendChild(div);
  });
  state.charts = charts;
}

function draw(chart) {
  const cv = chart.canvas;
  const w = (cv.width = cv.clientWidth * devicePixelRatio);
  const h = (cv.height = cv.clientHeight * devicePixelRatio);
  const g = cv.getContext("2d");
  g.clearRect(0, 0, w, h);
  const t = state.t;
  if (t.length < 2) return;
  const t1 = t[t.length - 1], t0 = t1 - WINDOW_S;
  let lo = Infinity, hi = -Infinity;
  let first = t.findIndex((x) => x >= t0);
  for (const s of chart.series) for (let i = first; i < t.length; i++) {
    const y = state.v[i][s.index];
    if (y < lo) lo = y;
    if (y > hi) hi = y;
  }
  if (!(hi > lo)) { hi = lo + 1e-9; lo -= 1e-9; }
  const pad = 28 * devicePixelRatio;
  const X = (x) => pad + ((x - t0) / WINDOW_S) * (w - pad - 4);
  const Y = (y) => h - 14 * devicePixelRatio - ((y - lo) / (hi - lo)) * (h - 24 * devicePixelRatio);
  g.font = 10 * devicePixelRatio + "px sans-serif";
  g.fillStyle = "#56607a";
  g.fillText(hi.toPrecision(3), 2, 10 * devicePixelRatio);
  g.fillText(lo.toPrecision(3), 2, h - 16 * devicePixelRatio);
  g.fillText(t1.toFixed(1) + " s", w - 50 * devicePixelRatio, h - 2);
  chart.series.forEach((s, j) => {
    g.strokeStyle = s.colour;
    g.lineWidth = devicePixelRatio;
    g.setLineDash(s.dashed ? [6, 4] : []);
    g.beginPath();
    for (let i = first; i < t.length; i++) {
      const x = X(t[i]), y = Y(state.v[i][s.index]);
      if (i === first) g.moveTo(x, y); else g.lineTo(x, y);
    }
    g.stroke();
    g.fillStyle = s.colour;
    g.fillText(s.name, pad + (50 + j * 60) * devicePixelRatio, 10 * devicePixelRatio);
  });
}

function frame() {
  if (state.dirty) {
    state.dirty = false;
    state.charts.forEach(draw);
    const now = Date.now();
    const L = window.kerfLatency;
    for (const sent of L.pending) {
      const d = now - sent;
      L.count++; L.sum += d; L.max = Math.max(L.max, d);
    }
    L.pending = [];
    L.mean = L.count ? L.sum / L.count : 0;
  }
  requestAnimationFrame(frame);
}

function addSample(t, values, hostMs) {
  if (state.t.length && t < state.t[state.t.length - 1]) { state.t = []; state.v = []; }
  state.t.push(t); state.v.push(values);
  if (state.t.length > MAX_POINTS) { state.t.shift(); state.v.shift(); }
  if (hostMs) window.kerfLatency.pending.push(hostMs);
  window.kerfSamples++;
  state.dirty = true;
}

function logLine(line) {
  const li = document.createElement("li");
  li.textContent = (line.t == null ? "" : line.t.toFixed(3) + " s  ") + line.text;
  $("log").prepend(li);
}

function settingsTable(settings, values) {
  const table = $("settings");
  table.innerHTML = "<tr><th>setting</th><th>value</th><th>preset</th><th>unit</th><th>range</th></tr>";
  for (const s of settings) {
    const tr = document.createElement("tr");
    tr.innerHTML = "<td class=path></td><td class=value><input> <button>Set</button><div class=error></div></td><td class=preset></td><td class=unit></td><td class=range></td>";
    tr.querySelector(".path").textContent = s.path;
    tr.querySelector(".preset").textContent = String(s.preset);
    tr.querySelector(".unit").textContent = s.unit;
    tr.querySelector(".range").textContent = s.range || "any";
    const input = tr.querySelector("input");
    input.dataset.path = s.path;
    const v = values.find((p) => p[0] === s.path);
    input.value = v ? v[1] : "";
    const err = tr.querySelector(".error");
    // The row's data-answer says how the machine answered the last change.
    tr.querySelector("button").onclick = async () => {
      err.textContent = "";
      tr.dataset.answer = "";
      try {
        const r = await post("/api/set", { path: s.path, value: input.value });
        input.value = r.answer.split(" = ").pop();
        state.lastSet = Date.now();
        tr.dataset.answer = "taken";
      } catch (e) {
        err.textContent = e.message;
        tr.dataset.answer = "refused";
      }
    };
    table.appendChild(tr);
  }
}

async function refresh() {
  const asked = Date.now();
  const st = await api("/api/status");
  $("mode").textContent = st.mode;
  $("mode").className = "mode " + st.mode.replace(/[^A-Za-z]/g, "");
  $("fault").textContent = st.last_fault ? "last fault: " + st.last_fault : "";
  $("health").textContent = st.closed ? st.closed
    : st.samples + " samples, " + st.bad_frames + " bad frames, heard " + st.quiet_ms + " ms ago";
  $("settings-origin").textContent = "settings: " + st.settings_origin;
  const j = st.job;
  $("job-info").textContent = j
    ? j.name + ": " + j.kind + (j.parts > 1 ? ", " + j.parts + " parts" : "") + ", about " + j.duration_s.toFixed(1) + " s, cut " + (j.cut_length_m * 1e3).toFixed(1) + " mm"
    : "no job loaded";
  // A status asked before the last change was answered holds the value before it.
  if (asked > (state.lastSet || 0)) for (const [path, value] of st.values) {
    const input = document.querySelector('input[data-path="' + path + '"]');
    if (input && document.activeElement !== input) input.value = value;
  }
  return st;
}

async function command(what) {
  $("command-error").textContent = "";
  try { await post("/api/" + what); } catch (e) { $("command-error").textContent = e.message; }
  refresh();
}

async function loadJob(file) {
  $("job-error").textContent = "";
  try {
    const r = await fetch("/api/job?name=" + encodeURIComponent(file.name), { method: "POST", body: file });
    const body = await r.json();
    if (!r.ok) throw new Error(body.error);
    const img = $("preview");
    img.hidden = false;
    img.src = "/api/job/preview?" + Date.now();
    img.onerror = () => { img.hidden = true; };
  } catch (e) { $("job-error").textContent = e.message; }
  refresh();
}

async function main() {
  const m = await api("/api/machine");
  state.machine = m.machine;
  $("machine").textContent = m.machine.name + " (link v" + m.machine.version + ")";
  document.title = "kerf: " + m.machine.name;
  buildCharts(m.machine.channels);
  const st = await refresh();
  settingsTable(m.settings, st.values);
  st.log.forEach(logLine);
  for (const [t, values] of await api("/api/recent")) addSample(t, values, 0);
  $("start").onclick = () => command("start");
  $("stop").onclick = () => command("stop");
  $("reset").onclick = () => command("reset");
  $("save").onclick = () => command("save");
  $("job-file").onchange = (e) => e.target.files[0] && loadJob(e.target.files[0]);
  const events = new EventSource("/api/stream");
  events.addEventListener("sample", (e) => { const s = JSON.parse(e.data); addSample(s.t, s.values, s.host_ms); });
  events.addEventListener("line", (e) => logLine(JSON.parse(e.data)));
  events.addEventListener("upload", (e) => {
    const u = JSON.parse(e.data);
    const bar = $("upload");
    bar.hidden = false; bar.max = u.of; bar.value = u.bytes;
  });
  events.addEventListener("state", () => refresh());
  events.onerror = () => { $("health").textContent = "console lost the station; retrying"; };
  setInterval(refresh, 1000);
  requestAnimationFrame(frame);
}

main().catch((e) => { $("mode").textContent = "cannot reach the station: " + e.message; });
