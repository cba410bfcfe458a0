// contactnet front page: embeds viser's client (served at /viewer/) connected to the viser port,
// shows the session status and the recordings. Everything goes through the REST API.
"use strict";

const $ = (id) => document.getElementById(id);
let liveUrl = null;

function wsHost() {
  const h = location.hostname;
  return h.includes(":") ? `[${h}]` : h;
}

async function api(path, options) {
  // State-changing requests carry JSON (the server refuses other bodies: app/security.py).
  const init = Object.assign({}, options);
  if (init.method && init.method !== "GET") {
    init.headers = Object.assign({ "Content-Type": "application/json" }, init.headers);
  }
  const response = await fetch(path, init);
  if (!response.ok) {
    let detail = response.statusText;
    try { detail = JSON.stringify((await response.json()).detail); } catch (e) { /* not JSON */ }
    throw new Error(`${response.status}: ${detail}`);
  }
  return response.json();
}

function showLive() {
  $("viewer").src = liveUrl;
  $("playback-bar").hidden = true;
  $("live-link").classList.add("active");
}

function stateText(s) {
  let state = "running", cls = "state-running";
  if (s.error) { state = "ERROR: " + s.error; cls = "state-error"; }
  else if (s.fell) { state = "FELL: " + s.fall_reason; cls = "state-fell"; }
  else if (s.reached_goal) { state = "GOAL REACHED"; cls = "state-goal"; }
  else if (s.paused) { state = "paused"; cls = "state-paused"; }
  const planner = s.planner === s.planner_active ? s.planner : `${s.planner_active} (instead of ${s.planner})`;
  const span = document.createElement("span");
  span.className = cls;
  span.textContent = state;
  $("status").title = s.planner_note || "";
  const rest = document.createTextNode(
    ` · t ${s.t_s.toFixed(2)} s · RTF ${s.real_time_factor.toFixed(2)} · ${s.terrain} · ${s.gait} · ${planner}` +
    ` · x ${s.base_position[0].toFixed(2)} m · cmd (${s.vel_cmd[0].toFixed(2)}, ${s.vel_cmd[1].toFixed(2)}) m/s` +
    ` · pushes ${s.pushes}` + (s.recording ? " · ● recording" : ""));
  return [span, rest];
}

async function pollState() {
  try {
    const s = await api("/api/state");
    $("status").replaceChildren(...stateText(s));
    const button = $("record-button");
    button.textContent = s.recording ? "Stop recording" : "Start recording";
    button.classList.toggle("recording", s.recording);
  } catch (e) {
    $("status").textContent = "live session unreachable (" + e.message + ")";
  }
}

async function loadRecordings() {
  const list = $("recording-list");
  let recordings = [];
  try { recordings = await api("/api/recordings"); } catch (e) { list.textContent = e.message; return; }
  list.replaceChildren();
  if (!recordings.length) {
    const li = document.createElement("li");
    li.className = "empty";
    li.textContent = "no recordings yet";
    list.append(li);
    return;
  }
  for (const r of recordings) {
    const li = document.createElement("li");
    const name = document.createElement("div");
    name.className = "name";
    name.textContent = r.name;
    const meta = document.createElement("div");
    meta.className = "meta";
    meta.textContent = `${(r.size_bytes / 1e6).toFixed(2)} MB · ${new Date(r.modified * 1000).toLocaleString()}`;
    const actions = document.createElement("div");
    actions.className = "actions";
    const play = document.createElement("a");
    play.href = "#";
    play.textContent = "Play";
    play.addEventListener("click", (event) => {
      event.preventDefault();
      $("viewer").src = r.play_url;
      $("playback-name").textContent = r.name;
      $("playback-bar").hidden = false;
      $("live-link").classList.remove("active");
    });
    const viser = document.createElement("a");
    viser.href = r.download_url;
    viser.textContent = ".viser";
    viser.setAttribute("download", r.name);
    const html = document.createElement("a");
    html.href = r.html_url;
    html.textContent = "HTML";
    actions.append(play, viser, html);
    li.append(name, meta, actions);
    list.append(li);
  }
}

async function toggleRecording() {
  const button = $("record-button");
  button.disabled = true;
  try {
    const status = await api("/api/recordings/status");
    await api(status.recording ? "/api/recordings/stop" : "/api/recordings/start", { method: "POST" });
  } catch (e) {
    alert("Recording: " + e.message);
  }
  button.disabled = false;
  await pollState();
  await loadRecordings();
}

async function main() {
  const info = await api("/api/info");
  if (info.robot) $("subtitle").textContent = `acyclic contact planning for ${info.robot}`;
  // Extra query parameters of this page go to the viewer (e.g. ?fixedDpr=0.5 renders at half
  // resolution on slow machines, ?showStats shows the frame rate).
  const extra = new URLSearchParams(location.search);
  extra.delete("websocket");
  extra.delete("playbackPath");
  const suffix = extra.toString() ? "&" + extra.toString() : "";
  liveUrl = `${info.viewer_url}?websocket=ws://${wsHost()}:${info.viser_port}${suffix}`;
  $("viewer-full").href = liveUrl;
  showLive();
  $("live-link").addEventListener("click", (event) => { event.preventDefault(); showLive(); });
  $("back-to-live").addEventListener("click", showLive);
  $("recordings-toggle").addEventListener("click", (event) => {
    event.preventDefault();
    const aside = $("recordings");
    aside.hidden = !aside.hidden;
    $("recordings-toggle").classList.toggle("active", !aside.hidden);
    if (!aside.hidden) loadRecordings();
  });
  $("record-button").addEventListener("click", toggleRecording);
  pollState();
  setInterval(pollState, 1000);
}

main().catch((e) => { $("status").textContent = "could not start: " + e.message; });
