// The 3D view inside the front page: viser's client, served by this server at /viewer/ (the page's own origin:
// only its websocket goes to viser's port), so the page can look into it.
//
// - A loading view covers the 3D view from the moment it is (re)loaded until it has its control panel and has drawn
//   frames after that: a visitor never sees viser's developer panel (websocket address, scene tree, shown while the
//   client has no GUI yet) or a blank area; the loading view says what is happening meanwhile. The scene is drawn
//   opaque at once (viser would fade it in from 5 % once its lighting is ready: a ghost scene for many seconds).
// - One notification channel: the page's toasts. viser's own toasts are hidden in the embedded view (the session's
//   notices reach the page as toasts already; viser's "software WebGL" warning becomes one page toast).
// - `?` and Esc pressed in the 3D view open and close the page's help (Keys.wireViewer).
// - Without a GPU (WebGL drawn by a software renderer: SwiftShader, llvmpipe) the 3D view draws at half resolution
//   (viser's `fixedDpr=0.5`) unless the page's address sets `fixedDpr`: headless chromium on a busy 2-core machine
//   drew the default scene at 2.2 frames a second at full resolution and 7.0 at half (medians, docs/web-tool.md),
//   with the same CPU, so the page (header, stream) keeps up with the 3D view.
// A 3D view from another origin (a proxy that serves it elsewhere) cannot be looked into: the loading view then goes
// once it has loaded and a few seconds passed.
"use strict";

const Embed = (() => {
  const CHECK_MS = 250;
  const FRAMES = 2;  // animation frames after the control panel arrived: the scene is drawn, not only received
  const BLIND_MS = 4000;  // another origin: how long after its load the loading view stays
  const SOFTWARE_DPR = "0.5";  // the 3D view's pixel ratio when WebGL is drawn in software
  const SOFTWARE_RENDERER = /swiftshader|llvmpipe|softpipe|lavapipe|software/i;
  // viser's own toasts go (one channel); its canvas is drawn opaque from the first frame: viser keeps it at 5 %
  // opacity until its environment lighting is decoded, then fades it in frame by frame, which a software renderer
  // on a busy machine stretches to 20 s and more of a ghost scene (the lighting then just brightens a drawn one).
  const EMBED_CSS = ".mantine-Notifications-root { display: none !important; }\n"
    + "canvas[data-engine] { opacity: 1 !important; }";
  const el = (id) => document.getElementById(id);
  let generation = 0;  // one per load of the iframe: a check of an older load stops
  let readyAt = null;  // performance.now() when the 3D view was shown (tests, the loading time)
  let loadingSince = performance.now();
  let toldSoftware = false;
  let needsPanel = true;  // a watcher's 3D view (/?watch=ID) has no control panel: its canvas is enough
  let software = null;  // WebGL drawn by a software renderer (asked once)
  let lightened = false;  // this page chose the half resolution (the address did not set fixedDpr)

  function stage(text) {
    el("loading-step").textContent = text;
  }

  function covering(on) {
    el("loading").hidden = !on;
    document.body.classList.toggle("viewer-loading", on);
  }

  /** What the 3D view's document shows: "connecting", or "panel" (its control panel arrived: the scene, sent
   *  before it, is there to draw). */
  function look(doc) {
    const text = doc.body ? doc.body.textContent : "";
    // Our control panel's status sentence ("walking · t 4.7 s · x ...") is its first element (app/viewer/gui.py).
    const canvas = doc.querySelector("canvas[data-engine]");  // react-three-fiber's (the plots have canvases too)
    const panel = !needsPanel || / · t \d+\.\d s · x /.test(text);
    return panel && canvas !== null ? "panel" : "connecting";
  }

  /** Whether this browser draws WebGL in software (its renderer's name, as the debug extension gives it). */
  function softwareRendering() {
    if (software !== null) return software;
    software = false;
    try {
      const gl = document.createElement("canvas").getContext("webgl2")
        || document.createElement("canvas").getContext("webgl");
      if (gl) {
        const info = gl.getExtension("WEBGL_debug_renderer_info");
        const name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
        software = SOFTWARE_RENDERER.test(name);
        const lose = gl.getExtension("WEBGL_lose_context");
        if (lose) lose.loseContext();  // the probe's context goes at once (browsers cap live contexts)
      }
    } catch (e) {
      software = false;
    }
    return software;
  }

  /** The 3D view's query parameters `query` (URLSearchParams, changed in place) with the half resolution added
   *  when WebGL is drawn in software and the page's address did not choose a pixel ratio. */
  function lighten(query) {
    if (!query.has("fixedDpr") && softwareRendering()) {
      query.set("fixedDpr", SOFTWARE_DPR);
      lightened = true;
    }
    return query;
  }

  function relaySoftwareWarning(doc) {
    if (toldSoftware || !doc.body || !doc.body.textContent.includes("Software WebGL")) return;
    toldSoftware = true;
    Toasts.show(lightened
      ? "No GPU in use: the 3D view draws in software, at half resolution to keep up (?fixedDpr=1 in the page's "
        + "address for full resolution; the panel's Shadows off helps too)"
      : "No GPU in use: the 3D view draws in software and may be slow (the panel's Shadows off helps, "
        + "or add ?fixedDpr=0.5 to the page's address)", "warning", 9000);
  }

  function framesThen(win, n, done) {
    if (n <= 0) { done(); return; }
    win.requestAnimationFrame(() => framesThen(win, n - 1, done));
  }

  /** The iframe has (re)loaded: watch it until it shows the scene. */
  function watch(frame) {
    const mine = ++generation;
    let doc = null;
    try { doc = frame.contentDocument; } catch (e) { doc = null; }
    if (doc) embedStyle(doc);  // a recording played too: viser's toasts would cover its scene
    if (!/[?&]websocket=/.test(frame.getAttribute("src") || "")) {  // a recording played (playback.js): no panel
      if (!el("loading").hidden) shown();
      return;
    }
    if (!doc) {  // another origin: wait a little, then show it
      setTimeout(() => { if (mine === generation) shown(); }, BLIND_MS);
      return;
    }
    Keys.wireViewer(doc);
    const check = () => {
      if (mine !== generation) return;
      relaySoftwareWarning(doc);
      if (look(doc) === "panel") {
        stage("drawing the scene…");
        framesThen(frame.contentWindow, FRAMES, () => { if (mine === generation) shown(); });
        return;
      }
      stage(doc.body && doc.body.textContent.includes("Connected") ? "receiving the scene…"
        : "connecting to the 3D view…");
      setTimeout(check, CHECK_MS);
    };
    check();
  }

  /** The embedded view's style (EMBED_CSS) added to the 3D view's document `doc`. */
  function embedStyle(doc) {
    const style = doc.createElement("style");
    style.textContent = EMBED_CSS;
    (doc.head || doc.documentElement).append(style);
  }

  function shown() {
    readyAt = performance.now();
    document.body.dataset.viewer = "shown";
    covering(false);
  }

  /** Load `url` into the 3D view behind the loading view (`title`: what the loading view says it is waiting for). */
  function load(url, title = "Opening the live session") {
    generation++;
    readyAt = null;
    loadingSince = performance.now();
    document.body.dataset.viewer = "loading";
    el("loading-title").textContent = title;
    stage("loading the 3D view…");
    covering(true);
    el("viewer").src = url;
  }

  /** Watch every load of the 3D view; `options.panel` false: it has no control panel (a watcher's page). */
  function wire(options = {}) {
    needsPanel = options.panel !== false;
    const frame = el("viewer");
    frame.addEventListener("load", () => { if (frame.getAttribute("src")) watch(frame); });
  }

  /** Seconds the last load took to show the scene (null while loading). */
  function loadSeconds() {
    return readyAt === null ? null : (readyAt - loadingSince) / 1000;
  }

  return { wire, load, loadSeconds, lighten, softwareRendering };
})();
