// What the front page draws over and above the 3D view from /api/state: the progress bars (x from the start
// toward the goal, one per robot in compare mode), the start card (waiting for the 3D view, count-down),
// the end-of-run card (result, time, steps, ranks, the next run's count-down), the paused chip and the
// "unreachable" card. Pure rendering: the buttons call the `actions` given to `render`.
"use strict";

const Overlays = (() => {
  const el = (id) => document.getElementById(id);
  let dismissedRun = null;  // index of the run whose card the user closed
  let shownRun = null;  // index of the run the card shows
  let actions = {};

  function fmt(value, digits = 2, unit = "") {
    return value === null || value === undefined || Number.isNaN(value) ? "–" : `${Number(value).toFixed(digits)}${unit}`;
  }

  function clamp01(value) {
    return Math.min(1, Math.max(0, Number.isFinite(value) ? value : 0));
  }

  /** x from the start toward the goal, 0..1 (State.progress for the main robot, computed for the others). */
  function progressOf(x, s) {
    const span = (s.goal_x_m ?? 0) - (s.start_x_m ?? 0);
    return span > 0 ? clamp01((x - s.start_x_m) / span) : 0;
  }

  /** How a robot's run stands: a short word (`text`), the whole reason (`why`) and a class. */
  function resultOf(robot) {
    const why = robot.done || robot.reason || "";
    if (robot.success) return { text: "goal reached", why: "goal reached", cls: "good" };
    if (robot.fell || why.startsWith("fell")) return { text: "fell", why: why || "fell", cls: "bad" };
    if (why.startsWith("stopped")) return { text: "stopped", why, cls: "bad" };
    return { text: "walking", why: "still walking", cls: "" };
  }

  function mainResult(s) {
    if (s.fell) return "fell";
    if (s.reached_goal) return "goal reached";
    if (s.paused || s.waiting_for_viewer) return "paused";
    return "walking";
  }

  // ---- progress bars ----------------------------------------------------------------------------------------
  function tracks(s) {
    const x = s.base_position[0];
    const main = {
      label: s.planner_active,
      progress: s.progress ?? progressOf(x, s),
      text: `x ${fmt(x)} m of ${fmt(s.goal_x_m)} m`,
      cls: s.fell ? "bad" : s.reached_goal ? "good" : "",
      detail: s.compare ? `${mainResult(s)} · steps ${s.steps}` + (s.rank_chosen !== null ? ` · rank ${s.rank_chosen}` : "") : "",
    };
    if (s.goal_x_m === undefined) main.text = `x ${fmt(x)} m`;
    const rows = [main];
    for (const c of s.compare || []) {
      const cx = c.x ?? c.x_m ?? 0;
      const result = resultOf(c);
      rows.push({
        label: c.planner,
        progress: progressOf(cx, s),
        text: `x ${fmt(cx)} m`,
        cls: result.cls,
        detail: `${result.text} · steps ${c.steps}` + (c.rank_mean !== null && c.rank_mean !== undefined ? ` · mean rank ${fmt(c.rank_mean, 1)}` : ""),
      });
    }
    return rows;
  }

  function renderTracks(s) {
    const box = el("tracks");
    const rows = tracks(s);
    el("progress-row").hidden = false;
    el("progress-row").classList.toggle("comparing", rows.length > 1);
    while (box.children.length > rows.length) box.lastElementChild.remove();
    while (box.children.length < rows.length) {
      const track = document.createElement("div");
      track.className = "track";
      track.innerHTML = '<span class="track-label"></span><div class="track-bar" role="progressbar" aria-valuemin="0" '
        + 'aria-valuemax="100"><div class="track-fill"></div></div><span class="track-text"></span>'
        + '<span class="track-detail"></span>';
      box.append(track);
    }
    rows.forEach((row, i) => {
      const track = box.children[i];
      const percent = Math.round(100 * clamp01(row.progress));
      track.className = `track ${row.cls}`;
      track.dataset.planner = row.label;
      track.querySelector(".track-label").textContent = row.label;
      const bar = track.querySelector(".track-bar");
      bar.setAttribute("aria-valuenow", String(percent));
      bar.setAttribute("aria-label", `${row.label}: ${percent} % of the way to the goal`);
      track.querySelector(".track-fill").style.width = `${percent}%`;
      track.querySelector(".track-text").textContent = `${row.text} · ${percent} %`;
      track.querySelector(".track-detail").textContent = row.detail;
    });
  }

  // ---- the cards over the scene -----------------------------------------------------------------------------
  function renderStart(s) {
    const card = el("start-card");
    const waiting = Boolean(s.waiting_for_viewer);
    const counting = s.starts_in_s !== null && s.starts_in_s !== undefined;
    card.hidden = !(waiting || counting);
    if (card.hidden) return;
    if (counting) {
      el("start-title").textContent = `Robot starts in ${Math.max(1, Math.ceil(s.starts_in_s))} s`;
      el("start-text").textContent = `${s.terrain} · ${s.gait} · ${s.planner_active}`;
    } else {
      el("start-title").textContent = "Starting…";
      el("start-text").textContent = "drawing the 3D scene; the robot walks once it is shown";
    }
    el("start-now").hidden = counting;
  }

  function statRow(list, name, value, title = "") {
    const dt = document.createElement("dt");
    dt.textContent = name;
    dt.title = title;
    const dd = document.createElement("dd");
    dd.textContent = value;
    list.append(dt, dd);
  }

  function compareTable(run) {
    const table = el("run-compare");
    table.replaceChildren();
    if (!run.compare || !run.compare.length) {
      table.hidden = true;
      return;
    }
    table.hidden = false;
    const head = table.createTHead().insertRow();
    for (const name of ["planner", "result", "x [m]", "steps", "mean rank"]) {
      const th = document.createElement("th");
      th.textContent = name;
      head.append(th);
    }
    const body = table.createTBody();
    const rows = [{ planner: run.planner, success: run.success, reason: run.reason, fell: run.reason.startsWith("fell"),
                    x: run.x ?? run.reached_x_m, steps: run.steps, rank_mean: run.rank_mean }, ...run.compare];
    for (const robot of rows) {
      let result = resultOf(robot);
      if (result.text === "walking") result = { text: "stopped", why: "still walking when the run ended", cls: "" };
      const tr = body.insertRow();
      tr.className = result.cls;
      tr.dataset.planner = robot.planner;
      for (const value of [robot.planner, result.text, fmt(robot.x ?? robot.x_m), String(robot.steps),
                           fmt(robot.rank_mean, 1)]) {
        tr.insertCell().textContent = value;
      }
      tr.cells[1].title = result.why;
    }
  }

  function renderRunCard(s) {
    const card = el("run-card");
    const run = s.last_run;
    const ended = Boolean(s.done) && Boolean(run);
    card.hidden = !ended || run.index === dismissedRun;
    if (card.hidden) return;
    shownRun = run.index;
    card.classList.toggle("good", run.success);
    card.classList.toggle("bad", !run.success);
    const result = resultOf(run);
    el("run-title").textContent = run.success ? "✓ Goal reached" : result.text === "fell" ? "✗ Fell" : "■ Stopped";
    const why = run.reason.replace(/^(fell|stopped): /, "");
    el("run-reason").textContent = run.success ? "" : why;
    el("run-reason").hidden = run.success;
    el("run-index").textContent = `run ${run.index}`;
    el("run-scenario").textContent = `${run.terrain} · ${run.gait} · ${run.planner}`;
    const stats = el("run-stats");
    stats.replaceChildren();
    statRow(stats, "time", `${fmt(run.t_s, 1)} s`);
    statRow(stats, "steps", String(run.steps));
    statRow(stats, "rank mean / max", run.rank_mean === null ? "– (no ranking)" : `${fmt(run.rank_mean, 2)} / ${run.rank_max}`,
      "ranking position of the chosen steps: 0 = the planner's first choice");
    statRow(stats, "stood / useless", `${run.stand_steps} / ${run.useless_steps}`,
      "step horizons the planner chose to stand (all four feet down) / steps whose feet landed < 2 cm from lift-off");
    statRow(stats, "swing retargets", String(run.swing_retargets),
      "swings whose landing moved during the swing (retargeting on)");
    statRow(stats, "capture steps", String(run.capture_steps ?? 0),
      "steps whose candidates moved towards the capture point after a push");
    statRow(stats, "reached", `${fmt(run.x ?? run.reached_x_m)} of ${fmt(s.goal_x_m)} m`, "x, forward from the start");
    compareTable(run);
    const looping = s.restart_in_s !== null && s.restart_in_s !== undefined;
    const left = Math.max(0, Math.ceil(s.restart_in_s ?? 0));
    el("run-next").textContent = looping
      ? (s.paused ? `paused: the next run comes ${left} s after P (or Run)` : `next run in ${left} s`)
      : s.loop === false ? "loop off: the robot stays here" : "";
    el("run-stay").hidden = !looping;
    el("run-loop").hidden = looping || s.loop !== false;
  }

  function renderPaused(s) {
    const quiet = s.waiting_for_viewer || (s.starts_in_s !== null && s.starts_in_s !== undefined) || s.done;
    el("paused-chip").hidden = !(s.paused && !quiet);
  }

  /** Draw everything from State `s`; `handlers`: {start, restart, stay, loopOn, run, dismiss} (promises). */
  function render(s, handlers) {
    actions = handlers || actions;
    renderTracks(s);
    renderStart(s);
    renderRunCard(s);
    renderPaused(s);
    el("offline-card").hidden = true;
  }

  /** The live session cannot be reached (server stopped or restarting): say so, hide the rest. */
  function unreachable(message) {
    for (const id of ["start-card", "run-card", "paused-chip"]) el(id).hidden = true;
    el("offline-card").hidden = false;
    el("offline-text").textContent = message;
  }

  /** Playing a recording: nothing of the live session over it. */
  function hide() {
    for (const id of ["start-card", "run-card", "paused-chip", "offline-card"]) el(id).hidden = true;
  }

  function wire() {
    const on = (id, name) => el(id).addEventListener("click", () => actions[name] && actions[name]());
    on("start-now", "start");
    on("run-restart", "restart");
    on("run-stay", "stay");
    on("run-loop", "loopOn");
    on("paused-run", "run");
    el("run-close").addEventListener("click", () => {
      dismissedRun = shownRun;
      el("run-card").hidden = true;
    });
  }

  return { render, unreachable, hide, wire };
})();
