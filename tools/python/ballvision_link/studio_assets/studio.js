// ballvision studio page: polls /api/state, draws the frames, the top view and the Fig. 5 plot.
// No libraries: everything is plain DOM and canvas, so the page works without internet.
"use strict";

const BALL_COLOUR = "rgb(255, 120, 0)";
const ROBOT_COLOUR = "rgb(20, 60, 200)";
const state = { data: null, cur: 0, gen: -1, playing: false, busy: false, shownKey: "" };
const $ = (id) => document.getElementById(id);

async function api(path, body, timeoutMs) {
  const ctl = new AbortController();
  const timer = setTimeout(() => ctl.abort(), timeoutMs || 5000);
  try {
    const opts = { signal: ctl.signal, cache: "no-store" };
    if (body !== undefined) {
      opts.method = "POST";
      opts.headers = { "Content-Type": "application/json" };
      opts.body = JSON.stringify(body);
    }
    const r = await fetch(path, opts);
    return await r.json();
  } finally {
    clearTimeout(timer);
  }
}

function showMessage(text, info) {
  const m = $("message");
  m.textContent = text || "";
  m.classList.toggle("hidden", !text);
  m.classList.toggle("info", !!info);
}

function frames() {
  return state.data && state.data.sequence ? state.data.sequence.frames : [];
}

function liveStates() {
  return state.data && state.data.live ? state.data.live.states : [];
}

// The states the views draw: the live link's when it sends, else the sequence's.
function viewStates() {
  const live = liveStates();
  return live.length ? live : frames();
}

async function poll() {
  let d;
  try {
    d = await api("/api/state", undefined, 4000);
  } catch (e) {
    showMessage("The studio server does not answer (" + e.name + "): is it still running?");
    return;
  }
  state.data = d;
  document.body.classList.toggle("live", !!d.live);
  const seq = d.sequence;
  $("source").textContent = d.live ? "link " + d.live.source + (seq.dir ? " · sequence " + seq.dir : "")
                                   : "sequence " + (seq.dir || "(none)");
  const ls = $("link-state");
  if (d.live) {
    ls.textContent = d.live.connected ? "connected" : "link down";
    ls.classList.toggle("down", !d.live.connected);
  }
  const problems = [];
  if (seq.error) problems.push(seq.error);
  if (d.live && d.live.error) problems.push(d.live.error);
  const note = state.note && Date.now() < state.note.until ? state.note : null;
  if (!state.busy) {
    if (problems.length) showMessage(problems.join("\n"));
    else showMessage(note ? note.text : "", note ? note.ok : false);
  }
  if (seq.gen !== state.gen) {
    state.gen = seq.gen;
    state.cur = Math.min(state.cur, Math.max(frames().length - 1, 0));
  }
  $("slider").max = Math.max(frames().length - 1, 0);
  $("teach-report").textContent = seq.teach ? "taught: " + seq.teach : "";
  $("save").classList.toggle("hidden", !seq.lut_file);
  render();
}

function render() {
  const fs = frames();
  const f = fs[state.cur];
  $("slider").value = state.cur;
  $("frame-label").textContent = f ? "frame " + f.index + " (" + (state.cur + 1) + "/" + fs.length +
                                       "), t = " + (f.t_us / 1e6).toFixed(3) + " s" : "no frames";
  for (const cam of ["omni", "persp"]) {
    const img = $("img-" + cam);
    const key = f && f.images.includes(cam) ? "/api/frame?cam=" + cam + "&i=" + f.index + "&gen=" + state.gen : "";
    if (img.dataset.src !== key) {
      img.dataset.src = key;
      if (key) img.src = key; else img.removeAttribute("src");
      img.classList.toggle("empty", !key);
    }
  }
  drawTopView();
  drawFig5();
  drawCounters();
}

// ---- top view ------------------------------------------------------------------------------

function robotToField(pose, x, y) {
  const h = pose.heading * Math.PI / 180, s = Math.sin(h), c = Math.cos(h);
  return [pose.x + x * s + y * c, pose.y - x * c + y * s];
}

function currentPose() {
  const d = state.data;
  if (d.live && d.live.pose && d.live.pose.usable) {
    return { x: d.live.pose.x, y: d.live.pose.y, heading: d.live.pose.heading * 180 / Math.PI };
  }
  const f = frames()[state.cur];
  if (!d.live && f && f.pose_x !== null && f.pose_x !== undefined) {
    return { x: f.pose_x, y: f.pose_y, heading: f.pose_heading_deg };
  }
  return null;
}

// world (field or robot frame, m) -> canvas px; exposed for the browser test.
function makeView(canvas, field, pose) {
  const W = canvas.width, H = canvas.height;
  if (pose) {
    const L = field.length + 2 * field.border, Wd = field.width + 2 * field.border;
    const k = Math.min(W / L, H / Wd);
    return { frame: "field", k, toCanvas: (x, y) => [W / 2 + x * k, H / 2 - y * k],
             fromRobot: (x, y) => robotToField(pose, x, y) };
  }
  const k = Math.min(W, H) / 12;  // robot-centred, 6 m around the robot, +y (ahead) up
  return { frame: "robot", k, toCanvas: (x, y) => [W / 2 + x * k, H / 2 - y * k],
           fromRobot: (x, y) => [x, y] };
}

function drawField(g, v, field) {
  const L = field.length / 2, Wd = field.width / 2;
  g.fillStyle = "rgb(60, 140, 70)";
  g.fillRect(0, 0, g.canvas.width, g.canvas.height);
  g.strokeStyle = "#fff";
  g.lineWidth = 2;
  const rect = (x0, y0, x1, y1) => {
    const a = v.toCanvas(x0, y0), b = v.toCanvas(x1, y1);
    g.strokeRect(Math.min(a[0], b[0]), Math.min(a[1], b[1]), Math.abs(b[0] - a[0]), Math.abs(b[1] - a[1]));
  };
  rect(-L, -Wd, L, Wd);
  const c0 = v.toCanvas(0, -Wd), c1 = v.toCanvas(0, Wd);
  g.beginPath(); g.moveTo(c0[0], c0[1]); g.lineTo(c1[0], c1[1]); g.stroke();
  const cc = v.toCanvas(0, 0);
  g.beginPath(); g.arc(cc[0], cc[1], field.center_circle_radius * v.k, 0, 2 * Math.PI); g.stroke();
  for (const s of [-1, 1]) {
    const pw = field.penalty_area_width / 2, gw = field.goal_area_width / 2;
    rect(s * L, -pw, s * (L - field.penalty_area_depth), pw);
    rect(s * L, -gw, s * (L - field.goal_area_depth), gw);
    g.strokeStyle = "#ddd";
    rect(s * L, -field.goal_width / 2, s * (L + field.goal_depth), field.goal_width / 2);
    g.strokeStyle = "#fff";
  }
}

function disc(g, p, r, fill, stroke) {
  g.beginPath();
  g.arc(p[0], p[1], r, 0, 2 * Math.PI);
  if (fill) { g.fillStyle = fill; g.fill(); }
  if (stroke) { g.strokeStyle = stroke; g.lineWidth = 2; g.stroke(); }
}

function drawTopView() {
  const canvas = $("topview"), g = canvas.getContext("2d"), d = state.data;
  const pose = currentPose();
  const v = makeView(canvas, d.field, pose);
  window.studioView = v;
  if (pose) drawField(g, v, d.field);
  else {
    g.fillStyle = "rgb(60, 140, 70)";
    g.fillRect(0, 0, canvas.width, canvas.height);
  }
  $("top-caption").textContent = pose ? "field frame, robot pose (" + pose.x.toFixed(2) + ", " +
      pose.y.toFixed(2) + ", " + pose.heading.toFixed(0) + "°)" : "pose unknown: robot frame, ahead is up";
  const states = viewStates();
  const s = liveStates().length ? states[states.length - 1] : states[state.cur];
  const obstacles = d.live && liveStates().length ? d.live.obstacles : (s && s.obstacles) || [];
  for (const o of obstacles) disc(g, v.toCanvas(...v.fromRobot(o[0], o[1])), Math.max(o[2] * v.k, 3), "rgba(30, 30, 30, 0.8)");
  // the robot: a disc with its heading (+y of the robot frame)
  const rp = v.toCanvas(...v.fromRobot(0, 0)), ra = v.toCanvas(...v.fromRobot(0, 0.5));
  disc(g, rp, 0.25 * v.k, ROBOT_COLOUR);
  g.strokeStyle = ROBOT_COLOUR; g.lineWidth = 3;
  g.beginPath(); g.moveTo(rp[0], rp[1]); g.lineTo(ra[0], ra[1]); g.stroke();
  canvas.dataset.robotPx = rp.map(Math.round).join(",");
  canvas.dataset.ballPx = "";
  if (!s || !s.found) return;
  const path = s.path || [];
  if (path.length > 1) {
    g.strokeStyle = "rgb(250, 240, 90)"; g.lineWidth = 2; g.setLineDash([6, 4]);
    g.beginPath();
    path.forEach((p, i) => { const c = v.toCanvas(...v.fromRobot(p[1], p[2])); if (i) g.lineTo(...c); else g.moveTo(...c); });
    g.stroke(); g.setLineDash([]);
  }
  (s.contacts || []).forEach((c, i) => {
    const p = v.toCanvas(...v.fromRobot(c[1], c[2]));
    g.strokeStyle = i ? "rgb(250, 240, 90)" : "rgb(255, 40, 40)"; g.lineWidth = 3;
    g.beginPath(); g.moveTo(p[0] - 6, p[1] - 6); g.lineTo(p[0] + 6, p[1] + 6);
    g.moveTo(p[0] + 6, p[1] - 6); g.lineTo(p[0] - 6, p[1] + 6); g.stroke();
  });
  const bp = v.toCanvas(...v.fromRobot(s.x, s.y));
  disc(g, bp, Math.max(0.11 * v.k, 6), BALL_COLOUR, "#000");
  canvas.dataset.ballPx = bp.map((x) => x.toFixed(1)).join(",");
  canvas.dataset.ballXy = [s.x, s.y].map((x) => x.toFixed(4)).join(",");
}

// ---- Fig. 5: height and vertical velocity over time -----------------------------------------

function drawFig5() {
  const canvas = $("fig5"), g = canvas.getContext("2d");
  const W = canvas.width, H = canvas.height, m = { l: 44, r: 44, t: 10, b: 26 };
  g.fillStyle = "#fff"; g.fillRect(0, 0, W, H);
  const states = viewStates().filter((s) => s.found);
  if (!states.length) { g.fillStyle = "#777"; g.fillText("no ball found yet", W / 2 - 40, H / 2); return; }
  const live = liveStates().length > 0;
  const cur = live ? states[states.length - 1] : frames()[state.cur];
  const pred = cur && cur.found ? (cur.path || []) : [];
  const t0 = states[0].t_us / 1e6;
  let t1 = Math.max(states[states.length - 1].t_us / 1e6, ...pred.map((p) => p[0] / 1e6), t0 + 1);
  let zmax = Math.max(1, ...states.map((s) => s.z), ...pred.map((p) => p[3]));
  let vmax = Math.max(2, ...states.map((s) => Math.abs(s.vz)));
  const X = (t) => m.l + (t - t0) / (t1 - t0) * (W - m.l - m.r);
  const Yz = (z) => H - m.b - z / zmax * (H - m.t - m.b);
  const Yv = (vz) => m.t + (1 - (vz + vmax) / (2 * vmax)) * (H - m.t - m.b);
  g.strokeStyle = "#bbb"; g.lineWidth = 1;
  g.strokeRect(m.l, m.t, W - m.l - m.r, H - m.t - m.b);
  g.fillStyle = "#333"; g.font = "11px sans-serif";
  for (let k = 0; k <= 4; ++k) {
    g.fillText((zmax * k / 4).toFixed(2), 4, Yz(zmax * k / 4) + 4);
    g.fillText((-vmax + 2 * vmax * k / 4).toFixed(1), W - m.r + 4, Yv(-vmax + 2 * vmax * k / 4) + 4);
    const t = t0 + (t1 - t0) * k / 4;
    g.fillText(t.toFixed(2) + " s", X(t) - 14, H - 8);
  }
  const line = (pts, colour, dash) => {
    g.strokeStyle = colour; g.lineWidth = 2; g.setLineDash(dash || []);
    g.beginPath();
    pts.forEach((p, i) => (i ? g.lineTo(p[0], p[1]) : g.moveTo(p[0], p[1])));
    g.stroke(); g.setLineDash([]);
  };
  line(states.map((s) => [X(s.t_us / 1e6), Yv(s.vz)]), "rgb(40, 90, 220)");
  line(states.map((s) => [X(s.t_us / 1e6), Yz(s.z)]), BALL_COLOUR);
  if (pred.length) line(pred.map((p) => [X(p[0] / 1e6), Yz(p[3])]), "rgb(120, 120, 120)", [5, 4]);
  if (cur) line([[X(cur.t_us / 1e6), m.t], [X(cur.t_us / 1e6), H - m.b]], "rgba(0,0,0,0.3)");
  g.fillStyle = BALL_COLOUR; g.fillText("z (m)", m.l + 6, m.t + 12);
  g.fillStyle = "rgb(40, 90, 220)"; g.fillText("vz (m/s)", m.l + 50, m.t + 12);
  g.fillStyle = "#777"; g.fillText("predicted z", m.l + 110, m.t + 12);
}

// ---- counters ------------------------------------------------------------------------------

function drawCounters() {
  const rows = [], d = state.data, seq = d.sequence, fs = frames();
  if (fs.length) {
    const found = fs.filter((f) => f.found).length;
    const tri = fs.filter((f) => f.ray_gap !== null).length;
    const omni = fs.filter((f) => f.omni_u !== null).length, persp = fs.filter((f) => f.persp_u !== null).length;
    const proc = fs.reduce((a, f) => a + (f.proc_us || 0), 0) / fs.length;
    const f = fs[state.cur];
    rows.push(["frames", fs.length], ["ball found", found + " (" + (100 * found / fs.length).toFixed(0) + " %)"],
              ["seen by omni / persp", omni + " / " + persp], ["triangulated", tri],
              ["mean processing", proc.toFixed(0) + " µs (host)"], ["colour table", seq.lut || ""]);
    if (f) {
      rows.push(["this frame", f.found ? f.mode + " at (" + [f.x, f.y, f.z].map((x) => x.toFixed(2)).join(", ") + ") m" : "no ball"],
                ["line points / obstacles", f.line_points + " / " + f.obstacles.length]);
    }
  }
  if (d.live) {
    const l = d.live;
    rows.push(["link", (l.connected ? "connected, " : "down, ") + l.packets + " packets"]);
    const errs = Object.entries(l.decoder_errors).filter((e) => e[1]).map((e) => e[0] + " " + e[1]);
    rows.push(["decoder errors", errs.join(", ") || "none"]);
    if (l.sync) rows.push(["clock", "offset " + (l.sync.offset_us / 1e3).toFixed(3) + " ms, drift " + l.sync.drift_ppm.toFixed(1) + " ppm"]);
    if (l.capture) rows.push(["capture", l.capture]);
    const st = l.status;
    if (st) {
      for (const k of ["frames_processed", "frame_rate_hz", "frames_dropped", "deadline_overruns", "packets_dropped",
                       "pairs_omni_missing", "pairs_persp_missing", "rx_errors", "command_errors", "pipeline_errors",
                       "last_proc_us", "max_proc_us", "lut_state", "calibration_state", "omni_camera",
                       "persp_camera", "pairs_omni_unusable", "pairs_persp_unusable"]) {
        rows.push([k.replace(/_/g, " "), typeof st[k] === "number" && !Number.isInteger(st[k]) ? st[k].toFixed(1) : st[k]]);
      }
    }
  }
  const key = JSON.stringify(rows);
  if (key === state.shownKey) return;
  state.shownKey = key;
  const t = $("counters");
  t.replaceChildren(...rows.map((r) => {
    const tr = document.createElement("tr");
    for (const c of r) { const td = document.createElement("td"); td.textContent = String(c); tr.appendChild(td); }
    return tr;
  }));
}

// ---- actions -------------------------------------------------------------------------------

async function action(path, body, waitText, timeoutMs) {
  if (state.busy) return null;
  state.busy = true;
  showMessage(waitText, true);
  document.body.classList.add("busy");
  try {
    const r = await api(path, body, timeoutMs);
    state.note = { text: r.message, ok: r.ok, until: Date.now() + 20000 };
    showMessage(r.message, r.ok);
    return r;
  } catch (e) {
    state.note = { text: path + ": no answer (" + e.name + ")", ok: false, until: Date.now() + 20000 };
    showMessage(state.note.text);
    return null;
  } finally {
    state.busy = false;
    document.body.classList.remove("busy");
    await poll();
  }
}

function teachClick(cam, e) {
  const f = frames()[state.cur], img = e.currentTarget;
  if (!f || !img.naturalWidth) return;
  const u = e.offsetX * img.naturalWidth / img.clientWidth, v = e.offsetY * img.naturalHeight / img.clientHeight;
  action("/api/teach", { index: f.index, camera: cam, u, v },
         "Teaching from a click at (" + u.toFixed(0) + ", " + v.toFixed(0) + ") in " + cam + " …", 600000);
}

function step(dn) {
  const n = frames().length;
  if (!n) return;
  state.cur = (state.cur + dn + n) % n;
  render();
}

$("img-omni").addEventListener("click", (e) => teachClick("omni", e));
$("img-persp").addEventListener("click", (e) => teachClick("persp", e));
$("prev").onclick = () => step(-1);
$("next").onclick = () => step(1);
$("slider").oninput = (e) => { state.cur = Number(e.target.value); render(); };
$("play").onclick = () => { state.playing = !state.playing; };
$("upload").onclick = () => action("/api/upload", {}, "Uploading the table …", 120000);
$("grab").onclick = () => action("/api/capture", { pairs: 1, mode: 2 }, "Asking for a capture …", 10000);
$("open").onclick = () => action("/api/open", { path: $("open-path").value }, "Opening …", 600000);
setInterval(() => { if (state.playing && !state.busy) step(1); }, 100);
setInterval(() => { if (!state.busy) poll(); }, 700);
poll();
