// The keyboard of the front page and its help: the driving keys work as soon as the page has focus (no click into
// the 3D view first), through the REST API, with the same meaning as the 3D view's own hotkeys
// (app/viewer/panels/drive.py); the camera keys are handed to the 3D view; `?` opens the help overlay (every key,
// and a glossary of the words the status uses), Escape closes it. No key acts while the user types in a field or
// holds Ctrl, Alt or Cmd (the browser's and viser's own shortcuts, e.g. Ctrl+K, stay theirs).
"use strict";

const Keys = (() => {
  const STEP = 0.05;  // m/s per press of I/K/J/L (VELOCITY_STEP_M_S in drive.py)

  /** The driving keys: key -> [label, what it does (a function of the `actions` given to `wire`)]. */
  const DRIVE = {
    i: ["faster forward (+0.05 m/s)", (a) => a.nudge(STEP, 0)],
    k: ["slower / backward (-0.05 m/s)", (a) => a.nudge(-STEP, 0)],
    j: ["more to the left (+0.05 m/s)", (a) => a.nudge(0, STEP)],
    l: ["more to the right (-0.05 m/s)", (a) => a.nudge(0, -STEP)],
    x: ["stop (command 0, 0)", (a) => a.stop()],
    p: ["pause / run; at the end of a run: stay on its card (P again lets the next run come)", (a) => a.pause()],
    r: ["restart the run from the start", (a) => a.restart()],
  };
  /** The 3D view's camera keys (viser's), handed to it while the page has focus. */
  const CAMERA = ["KeyW", "KeyA", "KeyS", "KeyD", "KeyQ", "KeyE", "ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight"];
  const CAMERA_HELP = [
    ["W / S", "camera forward / back"], ["A / D", "camera left / right"], ["Q / E", "camera down / up"],
    ["arrows", "turn the camera"], ["drag, wheel", "orbit, zoom (in the 3D view)"],
  ];
  const OTHER_HELP = [["?", "this help"], ["Esc", "close this help or the end-of-run card"],
    ["Ctrl+K", "the 3D view's command list (once the 3D view has focus)"]];

  /** The words of the status line, the header's second line and the end-of-run card. */
  const GLOSSARY = {
    walking: "the robot follows the commanded velocity; a step horizon the planner stands is still walking (see stood)",
    "standing (planner's choice)": "told to stay (command 0, 0), the planner keeps all four feet down: a choice, not a pause",
    paused: "the simulation clock stands still (P, or Run, runs it)",
    "waiting for a browser": "the robot waits at the start until a browser shows the 3D view (or Run is pressed)",
    "starting in": "a short count-down before the robot moves, so the 3D view has drawn the scene",
    "GOAL REACHED": "the base crossed the goal line; the end-of-run card sums the run up",
    FELL: "the run ended in a fall: the base too low or tilted, or a body other than a foot touching something",
    t: "simulated time since this run started, in seconds",
    x: "forward position of the base, in metres, and how far it is from the start to the goal line",
    steps: "step horizons in which legs swung (stands are not steps)",
    stood: "step horizons in which the planner chose to stand (all four feet down), counted once each; "
      + "a walking robot may stand a horizon where no step is safe or useful",
    useless: "steps whose swinging feet landed less than 2 cm from where they lifted off",
    rank: "ranking position of the step being taken among the safe candidates: 0 = the network's first choice "
      + "(ranking planners only)",
    run: "the run number since the session started (the loop starts a new run after each goal or fall)",
    cmd: "commanded velocity (forward, left) in m/s, in the robot's heading frame: I/K and J/L change it",
    speed: "simulation speed asked for: simulated seconds per wall-clock second",
    RTF: "real-time factor: simulated seconds per wall-clock second over the last 2 s (1.00 = real time; "
      + "below the speed asked: the machine cannot keep up)",
    pushes: "pushes applied to the base in this run",
    retargeting: "swing retargeting: a swing whose landing became unsafe (e.g. after a push) lands elsewhere",
    "swing retargets": "swings whose landing moved during the swing (retargeting on)",
    "capture steps": "steps whose candidates moved towards the capture point after a push",
    "loop off": "the robot stays at the end of a run (Restart or R starts the next)",
    recording: "the session is being recorded (Recordings)",
    walk: "gait: one leg swings at a time", trot: "gait: diagonal pairs of legs swing together",
    contactnet: "planner: the network ranks the candidate footholds, the first safe one is taken",
    fixed: "planner: the fixed gait's nominal footholds, no ranking", heuristic: "planner: the safe candidate "
      + "nearest the nominal foothold", oracle: "planner: every candidate scored by the trajectory optimizer (slow)",
  };

  let actions = null;
  let lastFocus = null;
  const held = new Set();  // camera keys handed down and not released yet
  const el = (id) => document.getElementById(id);

  /** The glossary's entry for one part of a status sentence ("stood 3", "t 4.1 s", "cmd (0.05, 0.00) m/s"). */
  function explain(part) {
    const text = part.trim();
    if (GLOSSARY[text]) return GLOSSARY[text];
    const words = Object.keys(GLOSSARY).sort((a, b) => b.length - a.length);  // "swing retargets" before "run"
    const word = words.find((w) => text === w || [" ", ":", ";"].some((end) => text.startsWith(w + end)));
    return word ? GLOSSARY[word] : "";
  }

  function typing(target) {
    if (!target || !target.tagName) return false;
    return ["INPUT", "TEXTAREA", "SELECT"].includes(target.tagName) || target.isContentEditable;
  }

  function open() { return !el("help").hidden; }

  function show() {
    lastFocus = document.activeElement;
    el("help").hidden = false;
    el("help-close").focus();
  }

  function hide() {
    el("help").hidden = true;
    if (lastFocus && lastFocus.focus) lastFocus.focus();
  }

  /** Hand a camera key down to the 3D view (same origin: its document hears it as viser's camera does). */
  function toViewer(type, event) {
    let doc = null;
    try { doc = el("viewer").contentDocument; } catch (e) { return false; }  // another origin: its own keys only
    if (!doc) return false;
    const View = el("viewer").contentWindow.KeyboardEvent;
    doc.dispatchEvent(new View(type, { key: event.key, code: event.code, bubbles: true }));
    return true;
  }

  function releaseAll() {
    for (const code of held) toViewer("keyup", { key: "", code });
    held.clear();
  }

  /** Handle a keydown of the page (or of the 3D view's document, `inViewer`: only ? and Esc there, viser has the
   *  rest). Returns true when the key was used. */
  function onKey(event, inViewer = false) {
    if (event.defaultPrevented || event.ctrlKey || event.metaKey || event.altKey || typing(event.target)) return false;
    if (event.key === "?") {
      open() ? hide() : show();
      return true;
    }
    if (event.key === "Escape") {
      if (open()) { hide(); return true; }
      if (actions && actions.escape) return actions.escape();
      return false;
    }
    if (inViewer || open() || !actions) return false;
    const key = event.key.length === 1 ? event.key.toLowerCase() : "";
    if (DRIVE[key]) {
      if (!event.repeat) DRIVE[key][1](actions);  // a held key is one press (the robot is not a keyboard repeater)
      return true;
    }
    if (CAMERA.includes(event.code)) {
      if (!held.has(event.code) && toViewer("keydown", event)) held.add(event.code);
      return held.has(event.code);
    }
    return false;
  }

  function row(key, text) {
    const tr = document.createElement("tr");
    const th = document.createElement("th");
    for (const part of key.split(" / ")) {
      if (th.childNodes.length) th.append(" / ");
      const kbd = document.createElement("kbd");
      kbd.textContent = part;
      th.append(kbd);
    }
    const td = document.createElement("td");
    td.textContent = text;
    tr.append(th, td);
    return tr;
  }

  /** Fill the help overlay: the keys, then the glossary. */
  function build() {
    const keys = el("help-keys");
    keys.replaceChildren(...Object.entries(DRIVE).map(([k, [label]]) => row(k.toUpperCase(), label)),
      ...CAMERA_HELP.map(([k, label]) => row(k, label)), ...OTHER_HELP.map(([k, label]) => row(k, label)));
    const terms = el("help-terms");
    terms.replaceChildren();
    for (const [word, text] of Object.entries(GLOSSARY)) {
      const dt = document.createElement("dt");
      dt.textContent = word;
      const dd = document.createElement("dd");
      dd.textContent = text;
      terms.append(dt, dd);
    }
  }

  /** Listen on the page; `handlers`: {nudge(dvx, dvy), stop, pause, restart, escape} (escape returns
   *  whether it closed something), or null: only ? and Esc (a watcher's page). */
  function wire(handlers) {
    actions = handlers;
    build();
    document.addEventListener("keydown", (event) => { if (onKey(event)) event.preventDefault(); });
    document.addEventListener("keyup", (event) => {
      if (held.delete(event.code)) toViewer("keyup", event);
    });
    window.addEventListener("blur", releaseAll);  // a keyup the page will never hear
    el("help-close").addEventListener("click", hide);
    el("help-button").addEventListener("click", () => (open() ? hide() : show()));
    el("help").addEventListener("click", (event) => { if (event.target === el("help")) hide(); });
  }

  /** The 3D view's document (same origin) was loaded: ? and Esc work there too. */
  function wireViewer(doc) {
    doc.addEventListener("keydown", (event) => { if (onKey(event, true)) event.preventDefault(); });
  }

  return { wire, wireViewer, explain, onKey, GLOSSARY, DRIVE };
})();
