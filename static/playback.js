// Playing a recording so that it can be studied: under viser's 3D player, a timeline in simulated seconds with
// markers (pushes, stands, falls, goal, restarts) and plots (rank chosen, commanded and measured velocity, planner
// time per plan) whose cursor follows the player's scrubber; the page's header and progress bar show the
// recording's frame, not the live session. Data: the recording's data track (GET /api/recordings/NAME/track,
// app/recordings/track.py); a recording made before tracks were kept plays without them, and the panel says so.
//
// viser's client (in the iframe, same origin: served at /viewer/, or an srcdoc document in the one-file player)
// has no API to drive its player: its scrubber's time is read from the slider's aria-valuenow, and a seek types
// the time into its time field (which seeks and pauses, as viser's own scrubbing does). Both only read or set what
// a person sees; if a viser release changes them, the plots stay without a cursor and the 3D view still plays.
//
// Used by the front page (Playback.open / close from app.js) and by the one-file player
// (Playback.standalone, app/recordings/player.py), which inlines this file: no network, no CDN.
"use strict";

const Playback = (() => {
  const SVG = "http://www.w3.org/2000/svg";
  const POLL_MS = 80;
  const MARGIN = { left: 46, right: 12 };
  const KIND_LABEL = { push: "push", stand: "stand", fall: "fall", goal: "goal", end: "run ended", restart: "restart" };
  let s = null;  // what is being played: {iframe, panel, track, note, title, name, scene, timer, t, frame, ...}

  // ---- small helpers ----------------------------------------------------------------------------------------
  const el = (id) => document.getElementById(id);

  function node(tag, attrs, parent) {
    const element = document.createElementNS(SVG, tag);
    for (const [key, value] of Object.entries(attrs || {})) element.setAttribute(key, String(value));
    if (parent) parent.append(element);
    return element;
  }

  function html(tag, className, text) {
    const element = document.createElement(tag);
    if (className) element.className = className;
    if (text != null) element.textContent = text;
    return element;
  }

  function fmt(value, digits) {
    return value === null || value === undefined || !Number.isFinite(value) ? "–" : Number(value).toFixed(digits);
  }

  /** Index of the last element of sorted `values` <= `x` (0 when none is). */
  function lastAtOrBefore(values, x) {
    let lo = 0;
    let hi = values.length - 1;
    if (hi < 0 || values[0] > x) return 0;
    while (lo < hi) {
      const mid = (lo + hi + 1) >> 1;
      if (values[mid] <= x + 1e-6) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  }

  function niceStep(span, count) {
    const raw = span / Math.max(1, count);
    for (const step of [0.1, 0.2, 0.5, 1, 2, 5, 10, 15, 30, 60, 120, 300]) if (step >= raw) return step;
    return 600;
  }

  // ---- viser's player in the iframe -------------------------------------------------------------------------
  function playerDocument() {
    try {
      return s && s.iframe.contentDocument;
    } catch (e) {
      return null;  // another origin: no cursor, the 3D view plays all the same
    }
  }

  /** The player's time (s of the recording) and length, or null while it loads. */
  function playerTime() {
    const doc = playerDocument();
    const slider = doc && doc.querySelector(".mantine-Slider-root [role=slider]");
    if (!slider) return null;
    const t = parseFloat(slider.getAttribute("aria-valuenow"));
    const max = parseFloat(slider.getAttribute("aria-valuemax"));
    return Number.isFinite(t) ? { t, max: Number.isFinite(max) ? max : null } : null;
  }

  /** Move the player to `t` s of the recording (it pauses there, as when its own scrubber is dragged). */
  function seek(t) {
    const doc = playerDocument();
    const input = doc && doc.querySelector(".mantine-NumberInput-input");
    if (!input) return false;
    const win = doc.defaultView;
    const setter = Object.getOwnPropertyDescriptor(win.HTMLInputElement.prototype, "value").set;
    setter.call(input, Math.max(0, t).toFixed(3));
    input.dispatchEvent(new win.Event("input", { bubbles: true }));
    tick(true);
    return true;
  }

  // ---- the data track ---------------------------------------------------------------------------------------
  /** Runs of frames between restarts: [{i0, i1, rec0, sim0, rec1}] (sim_t = sim0 + rec_t - rec0 within one). */
  function segmentsOf(track, duration) {
    const f = track.frames;
    const n = f.rec_t.length;
    const segments = [];
    let i0 = 0;
    for (let i = 1; i <= n; i += 1) {
      if (i === n || f.sim_t[i] < f.sim_t[i - 1] - 1e-6) {
        segments.push({ i0, i1: i - 1, rec0: f.rec_t[i0], sim0: f.sim_t[i0], rec1: i < n ? f.rec_t[i] : duration });
        i0 = i;
      }
    }
    return segments;
  }

  /** Simulated time at `t` s of the recording. */
  function simAt(t) {
    if (!s.track) return null;
    const f = s.track.frames;
    const i = lastAtOrBefore(f.rec_t, t);
    return f.sim_t[i] + Math.max(0, t - f.rec_t[i]);
  }

  // ---- drawing ----------------------------------------------------------------------------------------------
  function scaleX(width) {
    const span = Math.max(s.duration, 1e-3);
    return (t) => MARGIN.left + (width - MARGIN.left - MARGIN.right) * Math.min(1, Math.max(0, t / span));
  }

  function widthOf(svg) {
    return Math.max(200, Math.round(svg.getBoundingClientRect().width || svg.parentElement.clientWidth || 600));
  }

  function cursorOf(svg, height) {
    return node("line", { class: "pb-cursor", x1: MARGIN.left, x2: MARGIN.left, y1: 0, y2: height }, svg);
  }

  function drawTimeline() {
    const svg = s.timeline;
    svg.replaceChildren();
    const width = widthOf(svg);
    const height = 46;
    svg.setAttribute("viewBox", `0 0 ${width} ${height}`);
    svg.setAttribute("height", height);
    const x = scaleX(width);
    const axisY = 28;
    node("rect", { class: "pb-lane", x: MARGIN.left, y: 8, width: x(s.duration) - MARGIN.left, height: 22 }, svg);
    node("text", { class: "pb-axis-name", x: 4, y: axisY - 6 }, svg).textContent = "t [s]";
    // ticks in simulated seconds, run by run (the clock starts again at a restart)
    const step = niceStep(s.duration, Math.max(3, Math.floor(width / 90)));
    for (const seg of s.segments) {
      const first = Math.ceil((seg.sim0 - 1e-6) / step) * step;
      for (let sim = first; sim <= seg.sim0 + (seg.rec1 - seg.rec0) + 1e-6; sim += step) {
        const px = x(seg.rec0 + sim - seg.sim0);
        node("line", { class: "pb-tick", x1: px, x2: px, y1: axisY, y2: axisY + 4 }, svg);
        const label = node("text", { class: "pb-tick-label", x: px, y: axisY + 14, "text-anchor": "middle" }, svg);
        label.textContent = step < 1 ? sim.toFixed(1) : String(Math.round(sim));
      }
    }
    // markers: stands as short ticks along the bottom of the lane, the rest as symbols on top
    for (const [k, event] of s.events.entries()) {
      const px = x(event.rec_t);
      const g = node("g", { class: `pb-marker pb-${event.kind}`, "data-kind": event.kind, "data-index": k,
        "data-rec-t": event.rec_t, transform: `translate(${px.toFixed(1)},0)`, tabindex: 0, role: "button",
        "aria-label": `${KIND_LABEL[event.kind] || event.kind} at t ${fmt(event.sim_t, 2)} s` }, svg);
      node("title", {}, g).textContent = `${event.text} · t ${fmt(event.sim_t, 2)} s (simulated)`;
      if (event.kind === "stand") {
        node("rect", { x: -1.5, y: 22, width: 3, height: 8 }, g);
      } else if (event.kind === "restart") {
        node("line", { x1: 0, x2: 0, y1: 4, y2: 30 }, g);
        node("text", { x: 3, y: 12 }, g).textContent = "⟲";
      } else if (event.kind === "push") {
        node("path", { d: "M0,20 L-6,9 L6,9 Z" }, g);
      } else if (event.kind === "fall") {
        node("path", { d: "M-5,9 L5,19 M5,9 L-5,19" }, g);
      } else {  // goal, end
        node("line", { x1: 0, x2: 0, y1: 6, y2: 26 }, g);
        node("path", { d: "M0,6 L9,10 L0,14 Z" }, g);
      }
      g.addEventListener("click", (e) => { e.stopPropagation(); seek(event.rec_t); });
      g.addEventListener("keydown", (e) => { if (e.key === "Enter" || e.key === " ") { e.preventDefault(); seek(event.rec_t); } });
    }
    s.cursors.timeline = cursorOf(svg, height - 12);
    svg.onclick = (e) => {
      const box = svg.getBoundingClientRect();
      const fraction = (e.clientX - box.left - MARGIN.left) / Math.max(1, box.width - MARGIN.left - MARGIN.right);
      seek(Math.min(1, Math.max(0, fraction)) * s.duration);
    };
  }

  /** A plot of `series` ([{x: [], y: [], kind: "line"|"dots", cls}]) on svg `svg`, its y range [lo, hi], `label(v)`
   *  the text of a value on the y axis, `grid` values with a faint line. */
  function drawPlot(svg, name, series, lo, hi, label, grid = []) {
    svg.replaceChildren();
    const width = widthOf(svg);
    const height = 62;
    const top = 6;
    const bottom = height - 6;
    svg.setAttribute("viewBox", `0 0 ${width} ${height}`);
    svg.setAttribute("height", height);
    const x = scaleX(width);
    if (!(hi > lo)) hi = lo + 1;
    const y = (v) => bottom - (bottom - top) * (Math.min(hi, Math.max(lo, v)) - lo) / (hi - lo);
    node("rect", { class: "pb-frame", x: MARGIN.left, y: top, width: x(s.duration) - MARGIN.left, height: bottom - top }, svg);
    for (const [value, anchor] of [[hi, top + 8], [lo, bottom]]) {
      const text = node("text", { class: "pb-y-label", x: MARGIN.left - 4, y: anchor, "text-anchor": "end" }, svg);
      text.textContent = label(value);
    }
    for (const value of lo < 0 && hi > 0 ? [0, ...grid] : grid) {
      node("line", { class: "pb-zero", x1: MARGIN.left, x2: x(s.duration), y1: y(value), y2: y(value) }, svg);
    }
    for (const line of series) {
      if (line.kind === "dots") {
        const g = node("g", { class: `pb-dots ${line.cls}` }, svg);
        line.x.forEach((t, i) => {
          if (line.y[i] !== null && line.y[i] !== undefined) {
            node("circle", { cx: x(t).toFixed(1), cy: y(line.y[i]).toFixed(1), r: line.r || 2.2 }, g);
          }
        });
      } else {
        let d = "";
        let penUp = true;  // a new piece after a gap or a restart
        line.x.forEach((t, i) => {
          const v = line.y[i];
          if (v === null || v === undefined || !Number.isFinite(v)) {
            penUp = true;
            return;
          }
          d += `${penUp || (line.breaks && line.breaks.has(i)) ? "M" : "L"}${x(t).toFixed(1)},${y(v).toFixed(1)}`;
          penUp = false;
        });
        node("path", { class: `pb-line ${line.cls}`, d }, svg);
      }
    }
    node("text", { class: "pb-plot-name", x: MARGIN.left + 6, y: top + 11 }, svg).textContent = name;
    s.readouts[svg.dataset.plot] = node("text", { class: "pb-readout", x: width - MARGIN.right - 4, y: bottom - 4,
      "text-anchor": "end" }, svg);
    s.cursors[svg.dataset.plot] = cursorOf(svg, height);
  }

  function drawPlots() {
    const f = s.track.frames;
    const p = s.track.plans;
    const breaks = new Set(s.segments.slice(1).map((seg) => seg.i0));
    // rank chosen per plan (stands and plans without a ranking left out)
    const ranks = p.rank.map((r, i) => (p.stand[i] ? null : r));
    const rankMax = Math.max(4, ...ranks.filter((r) => r !== null));
    const ranked = ranks.some((r) => r !== null);
    drawPlot(s.plots.rank, ranked ? "rank chosen (0 = first choice)" : "rank chosen: no ranking (this planner ranks no candidates)",
      [{ x: p.rec_t, y: ranks, kind: "dots", cls: "pb-rank", r: 2.6 },
       { x: p.rec_t, y: p.stand.map((stand) => (stand ? 0 : null)), kind: "dots", cls: "pb-stand-dot", r: 2.2 }],
      0, rankMax, String);
    // velocity: the command and the base's measured velocity, forward (x) and sideways (y), heading frame
    // (its range leaves out the 2 % most extreme measurements, e.g. a fall's: they stand at the edge)
    const measured = [...f.vx, ...f.vy].filter(Number.isFinite).sort((a, b) => a - b);
    const pick = (q) => (measured.length ? measured[Math.floor(q * (measured.length - 1))] : 0);
    const commands = [...f.vx_cmd, ...f.vy_cmd].filter(Number.isFinite);
    const vLo = Math.min(0, pick(0.02), ...commands);
    const vHi = Math.max(0.05, pick(0.98), ...commands);
    drawPlot(s.plots.velocity, "velocity m/s: vx, vx commanded (dashed), vy (light)", [
      { x: f.rec_t, y: f.vy, kind: "line", cls: "pb-vy", breaks },
      { x: f.rec_t, y: f.vx_cmd, kind: "line", cls: "pb-cmd", breaks },
      { x: f.rec_t, y: f.vx, kind: "line", cls: "pb-vx", breaks },
    ], Math.floor(vLo * 20) / 20, Math.ceil(vHi * 20) / 20, (v) => v.toFixed(2));
    // planner and optimizer milliseconds per plan, on a log scale (0.1 ms planner calls, a first call's warm-up of
    // a few hundred ms and the optimizer's few ms all show)
    const log = (v) => (Number.isFinite(v) && v > 0 ? Math.log10(Math.max(v, 0.01)) : null);
    const logs = [...p.planner_ms, ...p.trajopt_ms].map(log).filter((v) => v !== null);
    const lo = logs.length ? Math.floor(Math.min(...logs)) : -1;
    const hi = Math.max(lo + 1, logs.length ? Math.ceil(Math.max(...logs)) : 1);
    const decades = [];
    for (let d = lo + 1; d < hi; d += 1) decades.push(d);
    drawPlot(s.plots.planner, "ms per plan (log): ● planner, ○ optimizer", [
      { x: p.rec_t, y: p.trajopt_ms.map(log), kind: "dots", cls: "pb-trajopt", r: 2.2 },
      { x: p.rec_t, y: p.planner_ms.map(log), kind: "dots", cls: "pb-planner", r: 2.6 },
    ], lo, hi, (v) => String(Number((10 ** v).toPrecision(1))), decades);
  }

  function draw() {
    if (!s || !s.track) return;
    s.cursors = {};
    s.readouts = {};
    drawTimeline();
    drawPlots();
    s.lastDrawnT = null;
    tick(true);
  }

  // ---- following the scrubber -------------------------------------------------------------------------------
  function stateClass(state) {
    if (/^(ERROR|FELL)/.test(state)) return "state-fell";
    if (/^GOAL/.test(state)) return "state-goal";
    if (/^(paused|starting|waiting)/.test(state)) return "state-paused";
    if (/^standing/.test(state)) return "state-standing";
    return "state-running";
  }

  /** The header and the progress bar: the recording at frame `i` (the front page's sentence, app/live/view.py). */
  function renderHeader(i, t) {
    const line = el("status-line");
    const detail = el("status-detail");
    const badge = html("span", "pb-badge", "▶ recording");
    if (!s.track) {
      line.replaceChildren(badge, document.createTextNode(` · ${s.title} · t ${fmt(t, 1)} s of the recording`));
      detail.textContent = [s.scene, s.note].filter(Boolean).join(" · ");
      return;
    }
    const f = s.track.frames;
    const state = s.track.states[f.state[i]] || "";
    const parts = [`t ${fmt(f.sim_t[i], 1)} s`, `x ${fmt(f.x[i], 2)} m (${Math.round(100 * f.progress[i])} %)`,
      `steps ${f.steps[i]}`];
    if (f.stood[i]) parts.push(`stood ${f.stood[i]}`);
    if (f.rank[i] !== null) parts.push(`rank ${f.rank[i]}`);
    parts.push(`run ${f.run[i]}`);
    line.replaceChildren(badge, document.createTextNode(" "), html("span", stateClass(state), state),
      document.createTextNode(` · ${parts.join(" · ")}`));
    const scene = s.track.scenes[f.scene[i]] || s.scene || "";
    detail.textContent = `${s.title} · ${scene} · cmd (${fmt(f.vx_cmd[i], 2)}, ${fmt(f.vy_cmd[i], 2)}) m/s`
      + ` · frame ${i + 1} of ${f.rec_t.length} · ${fmt(t, 1)} of ${fmt(s.duration, 1)} s recorded`;
    renderProgress(f, i, scene, state);
  }

  function renderProgress(f, i, scene, state) {
    const row = el("progress-row");
    const box = el("tracks");
    if (!row || !box) return;
    row.hidden = false;
    row.classList.remove("comparing");
    let track = box.firstElementChild;
    if (!track || box.children.length !== 1) {  // the same markup as the live bars (overlays.js)
      box.replaceChildren();
      track = html("div", "track");
      track.innerHTML = '<span class="track-label"></span><div class="track-bar" role="progressbar" aria-valuemin="0" '
        + 'aria-valuemax="100"><div class="track-fill"></div></div><span class="track-text"></span>'
        + '<span class="track-detail"></span>';
      box.append(track);
    }
    const percent = Math.round(100 * Math.min(1, Math.max(0, f.progress[i])));
    const planner = scene.split(" · ").slice(2).join(" · ") || "recording";
    track.className = `track pb-track ${/^FELL/.test(state) ? "bad" : /^GOAL/.test(state) ? "good" : ""}`;
    track.dataset.planner = planner;
    track.querySelector(".track-label").textContent = planner;
    const bar = track.querySelector(".track-bar");
    bar.setAttribute("aria-valuenow", String(percent));
    bar.setAttribute("aria-label", `recording: ${percent} % of the way to the goal`);
    track.querySelector(".track-fill").style.width = `${percent}%`;
    track.querySelector(".track-text").textContent = `x ${fmt(f.x[i], 2)} m · ${percent} %`;
    track.querySelector(".track-detail").textContent = `recording · run ${f.run[i]}`;
  }

  function moveCursors(t) {
    for (const [name, line] of Object.entries(s.cursors || {})) {
      const svg = line.ownerSVGElement;
      const px = scaleX(widthOf(svg))(t).toFixed(1);
      line.setAttribute("x1", px);
      line.setAttribute("x2", px);
      if (name === "timeline") s.timeline.dataset.cursorX = px;
    }
  }

  function renderReadouts(i, t) {
    const f = s.track.frames;
    const p = s.track.plans;
    const k = p.rec_t.length && p.rec_t[0] <= t + 1e-6 ? lastAtOrBefore(p.rec_t, t) : -1;
    const r = s.readouts;
    if (r.rank) r.rank.textContent = k < 0 ? "" : p.stand[k] ? "stood" : `rank ${p.rank[k] ?? "–"}`;
    if (r.velocity) r.velocity.textContent = `vx ${fmt(f.vx[i], 3)} (cmd ${fmt(f.vx_cmd[i], 2)}) · vy ${fmt(f.vy[i], 3)} m/s`;
    if (r.planner) r.planner.textContent = k < 0 ? "" : `${fmt(p.planner_ms[k], 2)} ms · optimizer ${fmt(p.trajopt_ms[k], 1)} ms`;
    const sim = simAt(t);
    s.clock.textContent = `t ${fmt(sim, 2)} s simulated · run ${f.run[i]}`;
    const near = s.events.filter((e) => e.kind !== "stand" && Math.abs(e.rec_t - t) < 0.5);
    s.eventText.textContent = near.length ? near.map((e) => e.text).join(" · ") : "";
  }

  /** Read the scrubber; redraw what follows it when it moved (or `force`). */
  function tick(force) {
    if (!s) return;
    const now = playerTime();
    if (now === null) {
      if (!s.track) renderHeader(0, null);
      return;
    }
    if (now.max && Math.abs(now.max - s.duration) > 1e-3) {
      s.duration = now.max;  // the timeline spans the player's length (the track's ends one frame earlier)
      draw();
      return;
    }
    const header = el("status-line");
    if (!force && s.t === now.t && header && header.querySelector(".pb-badge")) return;  // (a live poll may write it)
    s.t = now.t;
    s.panel.dataset.t = String(now.t);
    if (!s.track) {
      renderHeader(0, now.t);
      return;
    }
    const i = lastAtOrBefore(s.track.frames.rec_t, now.t);
    s.frame = i;
    s.panel.dataset.frame = String(i);
    s.panel.dataset.simT = String(s.track.frames.sim_t[i]);
    moveCursors(now.t);
    renderHeader(i, now.t);
    renderReadouts(i, now.t);
  }

  // ---- the panel --------------------------------------------------------------------------------------------
  function jump(direction) {
    const events = s.events.filter((e) => e.kind !== "stand");
    const t = s.t ?? 0;
    const target = direction > 0 ? events.find((e) => e.rec_t > t + 0.05) : [...events].reverse().find((e) => e.rec_t < t - 0.05);
    if (target) seek(target.rec_t);
    else seek(direction > 0 ? Math.max(0, s.duration - 0.05) : 0);
  }

  function legend() {
    const box = html("span", "pb-legend");
    for (const [kind, text] of [["push", "▲ push"], ["stand", "▮ stand"], ["fall", "✕ fall"], ["goal", "⚑ goal"],
      ["restart", "⟲ restart"]]) {
      const count = s.events.filter((e) => e.kind === kind || (kind === "goal" && e.kind === "end")).length;
      const item = html("span", `pb-key pb-key-${kind}`, `${text} ${count}`);
      item.title = `${count} ${KIND_LABEL[kind]} marker(s) on the timeline`;
      box.append(item);
    }
    return box;
  }

  function buildPanel(stage, iframe) {
    const panel = html("section", "", null);
    panel.id = "playback-panel";
    panel.setAttribute("aria-label", "the recording's timeline and plots");
    const head = html("div", "pb-head");
    s.clock = html("span", "pb-clock", "loading the recording…");
    const prev = html("button", "pb-jump", "◀ event");
    prev.type = "button";
    prev.title = "the previous push, fall, goal or restart";
    prev.addEventListener("click", () => jump(-1));
    const next = html("button", "pb-jump", "event ▶");
    next.type = "button";
    next.title = "the next push, fall, goal or restart";
    next.addEventListener("click", () => jump(1));
    s.eventText = html("span", "pb-event", "");
    head.append(s.clock, prev, next, s.eventText);
    panel.append(head);
    if (!s.track) {
      const note = html("p", "pb-note", s.note || "no data track: it plays without the timeline's markers and plots");
      panel.append(note);
    } else {
      head.append(legend());
      s.timeline = node("svg", { class: "pb-timeline", role: "group", "aria-label": "timeline, simulated seconds" });
      panel.append(s.timeline);
      s.plots = {};
      for (const name of ["rank", "velocity", "planner"]) {
        const svg = node("svg", { class: `pb-plot pb-plot-${name}`, "data-plot": name });
        s.plots[name] = svg;
        panel.append(svg);
      }
    }
    iframe.insertAdjacentElement("afterend", panel);
    stage.classList.add("pb-stage");
    return panel;
  }

  function start(options) {
    close();
    const track = options.track || null;
    s = {
      iframe: options.iframe,
      track,
      note: options.note || null,
      title: options.title || options.name || "recording",
      name: options.name || "",
      scene: options.scene || "",
      t: null,
      frame: -1,
      duration: track ? Math.max(track.duration_s, ...track.frames.rec_t.slice(-1), 1e-3) : 1,
      events: track ? track.events : [],
      segments: track ? segmentsOf(track, track.duration_s) : [],
      cursors: {},
      readouts: {},
    };
    document.body.classList.add("playback");
    s.panel = buildPanel(options.iframe.parentElement, options.iframe);
    s.panel.dataset.track = track ? "yes" : "no";
    draw();
    renderHeader(0, null);
    s.timer = setInterval(() => tick(false), POLL_MS);
    let width = s.panel.clientWidth;
    s.resize = new ResizeObserver(() => {  // the window, or the recordings list opening beside the 3D view
      if (s && s.panel.clientWidth !== width) {
        width = s.panel.clientWidth;
        draw();
      }
    });
    s.resize.observe(s.panel);
  }

  /** Play recording `r` (an entry of GET /api/recordings) in `iframe` (whose src the caller set to r.play_url):
   *  fetch its data track (when it has one) and show the panel. */
  async function open(r, iframe) {
    const token = {};
    open.token = token;
    let track = null;
    let note = null;
    if (r.track_url) {
      try {
        const response = await fetch(r.track_url);
        if (!response.ok) {
          let detail = response.statusText;
          try { detail = (await response.json()).detail; } catch (e) { /* not JSON */ }
          throw new Error(detail);
        }
        track = await response.json();
      } catch (e) {
        note = `the data track could not be read (${e.message}): it plays without the timeline's markers and plots`;
      }
    } else {
      note = "no data track (recorded before tracks were kept): it plays without the timeline's markers and plots";
    }
    if (open.token !== token) return;  // another recording was opened meanwhile
    start({ iframe, track, note, title: r.title || r.name, name: r.name,
            scene: [r.terrain, r.gait, r.planner].filter(Boolean).join(" · ") });
  }

  /** Back to live: remove the panel; the header and progress bar are the live session's again. */
  function close() {
    open.token = null;
    if (!s) return;
    clearInterval(s.timer);
    s.resize.disconnect();
    s.panel.remove();
    s.iframe.parentElement.classList.remove("pb-stage");
    document.body.classList.remove("playback");
    s = null;
  }

  function active() {
    return s !== null;
  }

  /** The one-file player (app/recordings/player.py): viser's client with the recording embedded, in an srcdoc
   *  frame of this page's origin, and the panel. */
  function standalone(config) {
    const bytes = Uint8Array.from(atob(config.client), (c) => c.charCodeAt(0));
    let client = new TextDecoder().decode(bytes);
    const embed = `<script>window.__VISER_EMBED_DATA__="${config.data}";`
      + "window.__VISER_EMBED_CONFIG__={darkMode:false};<" + "/script>"
      + "<style>.mantine-Notifications-root { display: none !important; }</style>";  // viser's toasts hidden, as
    // in the page's 3D view (embed.js: the one-file player has no other script)
    const at = client.indexOf("</head>");
    client = client.slice(0, at) + embed + client.slice(at);
    const iframe = el("viewer");
    iframe.srcdoc = client;
    start({ iframe, track: config.track, note: config.note, title: config.title, name: config.name,
            scene: config.scene });
    document.body.dataset.ready = "true";
  }

  return { open, close, active, standalone, seek, simAt, playerTime };
})();
