// contactnet front page: embeds viser's client (served at /viewer/) connected to the viser port,
// shows the session status and the recordings. Everything goes through the REST API.
// The other scripts of the page: toasts.js (Toasts), keys.js (the keys and the help overlay with its glossary),
// embed.js (the loading view over the 3D view, viser's toasts hidden in it), scenario.js (shareable links),
// overlays.js (progress bars and the cards over the 3D view). The page follows the session's state as the server
// sends it (GET /api/state/stream, server-sent events: the header and cards are as fresh as the 3D view, whatever
// the renderer does to the page's timers) and polls /api/state while the stream is down; when the server's
// session_id changes (a restart) or the server comes back after being unreachable, the 3D view is loaded again.
"use strict";

const $ = (id) => document.getElementById(id);
let liveUrl = null;
let sessionId = null;  // the server's session (new on every start): a change means the server restarted
let reachable = true;  // did the last /api/state answer?
let lastNotice = null;  // highest notice seq already shown (null: no state seen yet)
let lastState = null;
const POLL_MS = 1000;
const POLL_BUSY_MS = 500;  // while a count-down runs or the server is away
let stream = null;  // the EventSource of /api/state/stream while it is open
let streamAt = 0;  // performance.now() of its last state
let linkNamedTerrain = false;  // the page's address named a terrain: the user's choice, no compare offer
let dismissedOffer = null;  // the compare offer the user closed (session, terrain, offer)
const STREAM_FRESH_MS = 5000;  // the stream sends a state at least every 2 s: older means it is down

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
    try {
      const body = (await response.json()).detail;
      detail = typeof body === "string" ? body : JSON.stringify(body);
    } catch (e) { /* not JSON */ }
    throw new Error(`${response.status}: ${detail}`);
  }
  return response.json();
}

/** POST `body` (JSON) to `path`. */
function post(path, body) {
  return api(path, { method: "POST", body: body === undefined ? undefined : JSON.stringify(body) });
}

/** Run `request` (a function returning a promise) for the control named `label`; a refusal becomes a toast.
 *  Returns the request's answer, or null when it failed. */
async function act(label, request) {
  try {
    const answer = await request();
    if (answer && answer.status_text !== undefined) handleState(answer);  // the State after the command
    else pollState();
    return answer;
  } catch (e) {
    Toasts.show(`${label}: ${e.message}`, "error");
    return null;
  }
}

function playing() {
  return !$("playback-bar").hidden;
}

/** The embedded viser client's address for this server (`info` from /api/info), with the page's other query
 *  parameters (e.g. ?fixedDpr=0.5 renders at half resolution on slow machines, ?showStats shows the frame rate);
 *  without a GPU, half resolution unless the address says otherwise (Embed.lighten). */
function viewerUrl(info) {
  const extra = Embed.lighten(Scenario.others(location.search));
  extra.delete("websocket");
  extra.delete("playbackPath");
  const suffix = extra.toString() ? "&" + extra.toString() : "";
  return `${info.viewer_url}?websocket=ws://${wsHost()}:${info.viser_port}${suffix}`;
}

function showLive() {
  Playback.close();  // playback.js: the recording's timeline and plots go; the header is the live session's again
  Embed.load(liveUrl);  // behind the loading view until the scene is drawn (embed.js)
  $("playback-bar").hidden = true;
  $("live-link").classList.add("active");
  if (lastState) renderState(lastState);
}

/** The 3D view again, for a server that restarted or came back, or a session that was reclaimed (its viser port
 *  may have changed). */
async function reconnectViewer(restarted, reclaimed = false) {
  let info;
  try { info = await api("/api/info"); } catch (e) { return; }
  liveUrl = viewerUrl(info);
  $("viewer-full").href = liveUrl;
  if (!playing()) Embed.load(liveUrl, reclaimed ? "Opening a new live session" : "Reconnecting the 3D view");
  Toasts.show(reclaimed ? "Your live session had been closed while the page was away: this is a new one"
    : restarted ? "The server restarted: the 3D view reconnected to the new session"
    : "The live session is back: the 3D view reconnected", "info");
}

/** The buttons of the cards over the 3D view (overlays.js). */
const sceneActions = {
  start: () => act("Start", () => post("/api/pause", { paused: false })),
  run: () => act("Run", () => post("/api/pause", { paused: false })),
  restart: () => act("Restart", () => post("/api/reset")),
  stay: () => act("Stay", () => post("/api/settings", { loop: false })),
  loopOn: () => act("Loop", () => post("/api/settings", { loop: true })),
};

/** What the keys do (keys.js): the same as the 3D view's hotkeys (app/viewer/panels/drive.py), through the API. */
const live = (action) => (...args) => (playing() ? null : action(...args));  // not while a recording plays
const keyActions = {
  nudge: live((dvx, dvy) => act("Key", () => post("/api/command/nudge", { dvx, dvy }))),
  stop: live(() => act("Stop (X)", () => post("/api/command", { vx: 0, vy: 0 }))),
  pause: live(() => act("Pause (P)", () => post("/api/pause/toggle"))),
  restart: live(() => act("Restart (R)", () => post("/api/reset"))),
  escape: () => {  // Esc closes the end-of-run card
    if ($("run-card").hidden) return false;
    $("run-close").click();
    return true;
  },
};

/** The colour class of the status sentence's state word: from State.status_kind (a walking robot's stand horizons
 *  keep it "walking": no blinking), else from the flags (an older server). */
function stateClass(s) {
  const KIND = { error: "error", fell: "fell", done: "fell", goal: "goal", waiting: "starting", starting: "starting",
                 paused: "paused", standing: "standing", walking: "running" };
  if (s.status_kind && KIND[s.status_kind]) return `state-${KIND[s.status_kind]}`;
  if (s.error) return "state-error";
  if (s.fell) return "state-fell";
  if (s.reached_goal) return "state-goal";
  if (s.waiting_for_viewer || (s.starts_in_s ?? null) !== null) return "state-starting";
  if (s.paused) return "state-paused";
  if (s.standing) return "state-standing";
  return "state-running";
}

/** The status sentence (State.status_text: the same one the 3D view's panel shows), its state part coloured. */
function statusLine(s) {
  const text = s.status_text
    ?? `${s.error ? "ERROR: " + s.error : s.fell ? "FELL: " + s.fall_reason : s.reached_goal ? "GOAL REACHED"
      : s.paused ? "paused" : "walking"} · t ${s.t_s.toFixed(1)} s · x ${s.base_position[0].toFixed(2)} m`;
  const [state, ...rest] = text.split(" · ");
  const span = document.createElement("span");
  span.className = stateClass(s);
  span.textContent = state;
  span.title = Keys.explain(state);
  return [span, ...termParts(rest, true)];
}

/** The parts of a status sentence as text with each term's explanation as its tooltip (keys.js: the glossary, also
 *  in the help overlay, ?). `leading`: a separator before the first part too. */
function termParts(parts, leading = false) {
  const nodes = [];
  parts.forEach((part, i) => {
    if (leading || i) nodes.push(document.createTextNode(" · "));
    const title = Keys.explain(part);
    if (!title) { nodes.push(document.createTextNode(part)); return; }
    const term = document.createElement("span");
    term.className = "term";
    term.title = title;
    term.textContent = part;
    nodes.push(term);
  });
  return nodes;
}

/** The second line of the header: what runs (terrain, gait, planner) and how. */
function statusDetail(s) {
  const planner = s.planner === s.planner_active ? s.planner : `${s.planner_active} (instead of ${s.planner})`;
  return `${s.terrain} · ${s.gait} · ${planner} · cmd (${s.vel_cmd[0].toFixed(2)}, ${s.vel_cmd[1].toFixed(2)}) m/s`
    + ` · speed ${s.speed}× · RTF ${s.running ? s.real_time_factor.toFixed(2) : "–"} · pushes ${s.pushes}`
    + (s.retarget ? ` · retargeting on (${s.swing_retargets ?? 0})` : "")
    + (s.capture_steps ? ` · capture steps ${s.capture_steps}` : "")
    + (s.loop === false ? " · loop off" : "") + (s.recording ? " · ● recording" : "");
}

function newestNotice(s) {
  return (s.notices || []).reduce((most, notice) => Math.max(most, notice.seq), -1);
}

/** Toast the session's notices that are new since the last poll. */
function showNotices(s) {
  if (lastNotice !== null) {
    for (const notice of s.notices || []) {
      if (notice.seq > lastNotice) Toasts.show(notice.text, notice.level);
    }
  }
  lastNotice = Math.max(lastNotice ?? -1, newestNotice(s));
}

function renderState(s) {
  if (!playing()) {  // while a recording plays, the header shows its frame (playback.js)
    $("status-line").replaceChildren(...statusLine(s));
    $("status-detail").replaceChildren(...termParts(statusDetail(s).split(" · ")));
    $("status").title = [s.status_text, s.planner_note].filter(Boolean).join("\n");
  }
  const button = $("record-button");
  button.textContent = s.recording ? "Stop recording" : "Start recording";
  button.classList.toggle("recording", s.recording);
  const comparing = Array.isArray(s.compare) && s.compare.length > 0;
  const compare = $("compare-toggle");
  compare.setAttribute("aria-pressed", String(comparing));
  compare.textContent = comparing ? "Compare on" : "Compare";
  compare.title = comparing
    ? `${[s.planner_active, ...s.compare.map((c) => c.planner)].join(" vs ")}: press to turn compare mode off`
    : `run a second robot (${s.planner === "fixed" ? "contactnet" : "fixed"} planner) beside this one, same terrain and command`;
  document.body.classList.toggle("comparing", comparing);
  renderCompareOffer(s);
  if (playing()) Overlays.hide();
  else Overlays.render(s, sceneActions);
}

async function pollState() {
  let s;
  try {
    s = await api("/api/state", { signal: AbortSignal.timeout(10000) });
  } catch (e) {
    // No answer at all (fetch's TypeError): the server stopped or is restarting. A slow answer or an error
    // status comes from a server that is there: its 3D view needs no reload.
    if (Visits.gone(e.message)) {  // this browser's session was reclaimed, or the server restarted: a new one
      reachable = true;
      const why = await Visits.rejoin(e.message, api);
      if (why) {
        sessionId = null;  // the next state names the new session: no second "restarted"
        await reconnectViewer(why === "restarted", why === "reclaimed");
      }
      return;
    }
    const down = e instanceof TypeError;
    if (down) reachable = false;
    $("status-line").textContent = down ? "live session unreachable" : "live session not answering";
    $("status-detail").textContent = e.message;
    if (down && !playing()) Overlays.unreachable(e.message);
    return;
  }
  await handleState(s);
}

/** Show State `s` (from a poll, the stream or a command's answer): a new session (server restart) or a server back
 *  reloads the 3D view; new notices become toasts; the header and cards are drawn. */
async function handleState(s) {
  const restarted = Boolean(s.session_id && sessionId && s.session_id !== sessionId);
  const back = !reachable;
  reachable = true;
  if (s.session_id) sessionId = s.session_id;
  if (restarted) lastNotice = newestNotice(s);  // a new session counts its notices afresh
  if (restarted || back) await reconnectViewer(restarted);
  lastState = s;
  showNotices(s);
  renderState(s);
}

/** Follow the session: the state stream when it can (`follow`), else poll /api/state, twice a second while
 *  something counts down or the server is away. */
async function pollForever() {
  try {
    if (!streaming()) await pollState();
  } catch (e) {
    console.error("polling the live session:", e);  // a bug in drawing one state must not stop the polling
  }
  const s = lastState;
  const busy = !reachable || !s || s.waiting_for_viewer || (s.starts_in_s ?? null) !== null
    || (s.restart_in_s ?? null) !== null;
  setTimeout(pollForever, busy ? POLL_BUSY_MS : POLL_MS);
}

function streaming() {
  return stream !== null && performance.now() - streamAt < STREAM_FRESH_MS;
}

/** Open the state stream (server-sent events); when it fails the polls take over, and it is opened again. */
function follow() {
  if (!window.EventSource || stream) return;
  const source = new EventSource("/api/state/stream");
  stream = source;
  source.onmessage = (event) => {
    streamAt = performance.now();
    let s;
    try { s = JSON.parse(event.data); } catch (e) { return; }
    handleState(s).catch((e) => console.error("drawing a state:", e));
  };
  source.addEventListener("end", () => {  // the server ends every stream after a while: the next one at once
    source.close();
    if (stream === source) stream = null;
    follow();
  });
  source.onerror = () => {  // the server away, restarted, or this session gone: the polls say which
    source.close();
    if (stream === source) stream = null;
    setTimeout(follow, reachable ? 1000 : 3000);
  };
}

/** Compare mode on a terrain where its planners are known to do the same (State.compare_offer, set by the server
 *  only for the terrain the session started on): a card offers, in one click, the terrain where they differ and
 *  says why. A terrain the user picked (in the page or in the address) is kept: no offer. */
function renderCompareOffer(s) {
  const card = $("compare-offer");
  const offer = s.compare_offer;
  const key = offer ? [s.session_id, s.terrain, offer.terrain, offer.planners.join(",")].join("|") : null;
  const show = Boolean(offer) && !linkNamedTerrain && key !== dismissedOffer && !playing();
  card.hidden = !show;
  if (!show) return;
  $("compare-offer-text").textContent = offer.reason;
  const go = $("compare-offer-go");
  go.textContent = `Compare on ${offer.terrain.replace(/_/g, " ")}`;
  go.title = `load ${offer.terrain} with ${offer.planners.join(" vs ")} (both robots restart from its start)`;
  go.dataset.terrain = offer.terrain;
  card.dataset.key = key;
}

async function takeCompareOffer() {
  const terrain = $("compare-offer-go").dataset.terrain;
  if (!terrain) return;
  $("compare-offer").hidden = true;
  await act("Compare", () => post("/api/session/terrain", { name: terrain }));
}

async function toggleCompare() {
  const s = lastState;
  if (!s) {
    Toasts.show("Compare: the live session has not answered yet; try again in a moment", "warning");
    return;
  }
  const comparing = Array.isArray(s.compare) && s.compare.length > 0;
  const other = s.planner === "fixed" ? "contactnet" : "fixed";
  await act("Compare", () => post("/api/compare", { planners: comparing ? [] : [s.planner, other] }));
}

async function share() {
  let s = lastState;
  try { s = await api("/api/state"); } catch (e) { /* the last state polled */ }  // the scenario as of now
  if (!s || !s.scenario) {
    Toasts.show("Share: the live session is not reachable (or does not report its scenario)", "error");
    return;
  }
  const url = Scenario.link(s.scenario, location.origin);
  if (!url) {
    Toasts.show("Save the edited terrain to share it (terrain editor: Save): a link can only name a saved terrain",
      "warning");
    return;
  }
  $("share-button").dataset.url = url;
  try {
    await navigator.clipboard.writeText(url);
    Toasts.show(`Link copied: ${url}`, "success", 8000);
  } catch (e) {
    Toasts.show(`Copy this link: ${url}`, "info", 20000);  // no clipboard (e.g. plain http beyond localhost)
  }
}

/** A request to a recording that may answer without a body (DELETE: 204). Throws like `api`. */
async function recordingRequest(path, method, body) {
  if (method !== "DELETE") return api(path, { method, body: JSON.stringify(body) });
  const response = await fetch(path, { method });
  if (!response.ok) {
    let detail = response.statusText;
    try { detail = (await response.json()).detail; } catch (e) { /* not JSON */ }
    throw new Error(`${response.status}: ${typeof detail === "string" ? detail : JSON.stringify(detail)}`);
  }
  return null;
}

/** "12.3 s", "2 min 05 s". */
function recordingDuration(seconds) {
  if (seconds == null) return null;
  if (seconds < 60) return `${seconds.toFixed(1)} s`;
  const s = Math.round(seconds);
  return `${Math.floor(s / 60)} min ${String(s % 60).padStart(2, "0")} s`;
}

/** The class of a run's result: goal, fell or stopped. */
function recordingResultClass(result) {
  if (!result) return "result-none";
  if (result === "goal reached") return "result-goal";
  if (result.startsWith("fell") || result.startsWith("error")) return "result-fell";
  return "result-stopped";
}

function recordingElement(tag, className, text) {
  const element = document.createElement(tag);
  if (className) element.className = className;
  if (text != null) element.textContent = text;
  return element;
}

/** Play recording `r` in the page's 3D view. */
function playRecording(r) {
  $("viewer").src = r.play_url;
  $("playback-name").textContent = r.title || r.name;
  $("playback-bar").hidden = false;
  $("live-link").classList.remove("active");
  Overlays.hide();
  Playback.open(r, $("viewer"));  // playback.js: timeline in simulated time, markers, plots; header and progress
}

/** The inline form that renames recording `r` (title and file name) in its list item `li`. */
function editRecording(li, r) {
  const form = recordingElement("form", "rec-edit");
  const title = recordingElement("input");
  title.name = "title";
  title.value = r.title;
  title.placeholder = "title";
  title.maxLength = 100;
  title.setAttribute("aria-label", "title");
  const name = recordingElement("input");
  name.name = "name";
  name.value = r.name.replace(/\.viser$/, "");
  name.pattern = "[A-Za-z0-9][A-Za-z0-9_\\-]{0,99}";
  name.title = "file name: letters, digits, '_' and '-'";
  name.setAttribute("aria-label", "file name");
  const fileRow = recordingElement("label", "rec-file", "file ");
  fileRow.append(name, document.createTextNode(".viser"));
  const save = recordingElement("button", "primary", "Save");
  save.type = "submit";
  const cancel = recordingElement("button", null, "Cancel");
  cancel.type = "button";
  const buttons = recordingElement("div", "rec-buttons");
  buttons.append(save, cancel);
  form.append(title, fileRow, buttons);
  cancel.addEventListener("click", () => loadRecordings());
  form.addEventListener("keydown", (event) => { if (event.key === "Escape") loadRecordings(); });
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    const change = {};
    if (title.value !== r.title) change.title = title.value.trim();
    if (name.value + ".viser" !== r.name) change.name = name.value;
    if (!Object.keys(change).length) { loadRecordings(); return; }
    save.disabled = true;
    try {
      await recordingRequest(r.download_url, "PATCH", change);
      Toasts.show(change.name ? `Renamed to ${change.name}.viser` : "Title saved", "success");
      loadRecordings();
    } catch (e) {
      Toasts.show(`Rename: ${e.message}`, "error");
      save.disabled = false;
    }
  });
  li.replaceChildren(form);
  title.focus();
  title.select();
}

async function deleteRecording(r) {
  const label = r.title ? `"${r.title}" (${r.name})` : r.name;
  if (!confirm(`Delete the recording ${label}? This cannot be undone.`)) return;
  try {
    await recordingRequest(r.download_url, "DELETE");
    Toasts.show(`Deleted ${r.name}`, "success");
    if (playing() && $("viewer").src.endsWith(r.play_url)) showLive();
  } catch (e) {
    Toasts.show(`Delete: ${e.message}`, "error");
  }
  loadRecordings();
}

/** One list item: title (or file name), what it shows, how the run ended, and its actions. */
function recordingItem(r) {
  const li = recordingElement("li");
  li.dataset.name = r.name;
  const head = recordingElement("div", "rec-head");
  head.append(recordingElement("span", "rec-title", r.title || r.name));
  if (r.result) head.append(recordingElement("span", `rec-result ${recordingResultClass(r.result)}`, r.result));
  li.append(head);
  if (r.title) li.append(recordingElement("div", "name", r.name));
  const shows = [r.terrain, r.gait, r.planner].filter((v) => v);
  if (shows.length) li.append(recordingElement("div", "rec-shows", shows.join(" · ")));
  const facts = [recordingDuration(r.duration_s), `${(r.size_bytes / 1e6).toFixed(2)} MB`,
    new Date((r.created ?? r.modified) * 1000).toLocaleString()].filter((v) => v);
  if (r.runs && r.runs.length > 1) facts.splice(1, 0, `${r.runs.length} runs`);
  li.append(recordingElement("div", "meta", facts.join(" · ")));
  if (r.metadata_note) li.append(recordingElement("div", "rec-note", r.metadata_note));
  const actions = recordingElement("div", "actions");
  const play = recordingElement("a", null, "Play");
  play.href = "#";
  play.addEventListener("click", (event) => { event.preventDefault(); playRecording(r); });
  const viser = recordingElement("a", null, ".viser");
  viser.href = r.download_url;
  viser.setAttribute("download", r.name);
  const html = recordingElement("a", null, "HTML");
  html.href = r.html_url;
  const rename = recordingElement("button", "rec-rename", "Rename");
  rename.type = "button";
  rename.addEventListener("click", () => editRecording(li, r));
  const remove = recordingElement("button", "rec-delete", "Delete");
  remove.type = "button";
  remove.addEventListener("click", () => deleteRecording(r));
  actions.append(play, viser, html, rename, remove);
  li.append(actions);
  return li;
}

async function loadRecordings() {
  const list = $("recording-list");
  let recordings = [];
  try { recordings = await api("/api/recordings"); } catch (e) { list.textContent = e.message; return; }
  list.replaceChildren();
  if (!recordings.length) {
    list.append(recordingElement("li", "empty", "no recordings yet"));
    return;
  }
  for (const r of recordings) list.append(recordingItem(r));
}

async function toggleRecording() {
  const button = $("record-button");
  button.disabled = true;
  try {
    const status = await api("/api/recordings/status");
    await api(status.recording ? "/api/recordings/stop" : "/api/recordings/start", { method: "POST" });
  } catch (e) {
    Toasts.show("Recording: " + e.message, "error");
  }
  button.disabled = false;
  await pollState();
  await loadRecordings();
}

/** The header and panel controls: they need nothing from the server to be wired. */
function wireControls() {
  $("recordings-toggle").addEventListener("click", (event) => {
    event.preventDefault();
    const aside = $("recordings");
    aside.hidden = !aside.hidden;
    $("recordings-toggle").classList.toggle("active", !aside.hidden);
    if (!aside.hidden) loadRecordings();
  });
  $("recordings-close").addEventListener("click", () => {
    $("recordings").hidden = true;
    $("recordings-toggle").classList.remove("active");
  });
  $("record-button").addEventListener("click", toggleRecording);
  $("compare-toggle").addEventListener("click", toggleCompare);
  $("compare-offer-go").addEventListener("click", takeCompareOffer);
  $("compare-offer-close").addEventListener("click", () => {
    dismissedOffer = $("compare-offer").dataset.key || null;
    $("compare-offer").hidden = true;
  });
  $("share-button").addEventListener("click", share);
  $("menu-toggle").addEventListener("click", () => {
    const open = document.body.classList.toggle("menu-open");
    $("menu-toggle").setAttribute("aria-expanded", String(open));
  });
  $("nav").addEventListener("click", () => {
    document.body.classList.remove("menu-open");
    $("menu-toggle").setAttribute("aria-expanded", "false");
  });
}

async function main() {
  const watching = Visits.watchId();
  if (watching) {
    Embed.wire({ panel: false });  // the loading view until the watched scene is drawn
    Keys.wire(null);  // ? and its glossary; no key drives a watched robot
    await Visits.watch(watching, api, viewerUrl);
    return;
  }
  Overlays.wire();
  Embed.wire();
  Keys.wire(keyActions);  // the keys work as soon as the page has focus (keys.js)
  wireControls();  // before the first request: a click while the page loads already works
  Visits.wire(api);
  const info = await api("/api/info");
  if (info.robot) $("subtitle").textContent = `acyclic contact planning for ${info.robot}`;
  sessionId = info.session_id || null;
  liveUrl = viewerUrl(info);
  $("viewer-full").href = liveUrl;
  const wanted = Scenario.fromQuery(location.search);
  linkNamedTerrain = Boolean(wanted && wanted.terrain);
  try {
    const first = await api("/api/state");
    if (first.session_id) sessionId = first.session_id;
    lastNotice = newestNotice(first);  // notices from before the page opened are not toasted
    if (wanted) {
      // A shared link: the scenario first, then the 3D view, so the scene is drawn with it.
      $("status-line").textContent = "opening the shared scenario…";
      await Scenario.apply(wanted, first, api, Toasts.show);
    }
  } catch (e) {
    Toasts.show("The live session did not answer: " + e.message, "error");
  }
  if (wanted) {  // out of the address bar: reloading the page must not apply it again
    const rest = Scenario.others(location.search).toString();
    history.replaceState(null, "", location.pathname + (rest ? "?" + rest : "") + location.hash);
  }
  showLive();
  $("live-link").addEventListener("click", (event) => { event.preventDefault(); showLive(); });
  $("back-to-live").addEventListener("click", showLive);
  document.body.dataset.ready = "true";  // wired and showing the live session (tests wait for it)
  follow();
  pollForever();
}

main().catch((e) => { $("status-line").textContent = "could not start: " + e.message; });
