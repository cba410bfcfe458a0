// A robot per visitor (app/api/visits.py), on the page: the "Sessions" panel (who else runs a robot here, a
// link to watch each), the watcher's page (/?watch=ID: another visitor's 3D view, read-only, without the
// page's controls) and what happens when this browser's session is gone (the API answers 410: the session was
// reclaimed while the page was away, or the server restarted): the page asks for a new one (POST /api/visits).
"use strict";

const Visits = (() => {
  const $ = (id) => document.getElementById(id);
  let rejoining = null;

  /** The watch id of a watcher's page (?watch=ID), else null. */
  function watchId() {
    const id = new URLSearchParams(location.search).get("watch");
    return id && /^[0-9a-f]{12}$/.test(id) ? id : null;
  }

  /** Is `message` an API error of a session that is gone ("410: ...")? */
  function gone(message) {
    return String(message).startsWith("410");
  }

  /** A new session for this browser after a 410 (`message`): resolves to "restarted" (the server restarted),
   *  "reclaimed" (the session was closed while the page was away), or null when none is free (said on the page). */
  function rejoin(message, api) {
    if (!rejoining) {
      const why = String(message).includes("restarted") ? "restarted" : "reclaimed";
      rejoining = api("/api/visits", { method: "POST" }).then(() => why, (e) => {
        $("status-line").textContent = "no live session free: " + e.message;
        setTimeout(() => location.reload(), 30000);  // the server-full page, with its watch links
        return null;
      }).finally(() => { rejoining = null; });
    }
    return rejoining;
  }

  function item(v) {
    const li = document.createElement("li");
    const label = document.createElement("span");
    label.textContent = `${v.yours ? "yours" : v.watch_id} · ${v.terrain} · ${v.status.split(" · ")[0]}`;
    li.append(label);
    const link = document.createElement("a");
    link.href = v.watch_url;
    link.target = "_blank";
    link.rel = "noopener";
    link.textContent = v.yours ? "watch link" : "watch";
    link.title = v.yours ? "a read-only view of your robot for others (copy this link)"
      : "this visitor's robot, read-only, in a new tab";
    li.append(link);
    return li;
  }

  /** Fill the Sessions panel from GET /api/visits. */
  async function load(api) {
    const list = $("session-list");
    let visits;
    try { visits = await api("/api/visits"); } catch (e) { list.textContent = e.message; return; }
    $("sessions-count").textContent = visits.shared
      ? "one robot shared by every visitor (serve --shared)"
      : `${visits.sessions.length} of at most ${visits.max_sessions} sessions run; each browser drives its own robot. `
        + `A session is closed ${Math.round(visits.idle_timeout_s)} s after its page.`;
    list.replaceChildren(...visits.sessions.map(item));
  }

  function wire(api) {
    $("sessions-toggle").addEventListener("click", (event) => {
      event.preventDefault();
      const aside = $("sessions");
      aside.hidden = !aside.hidden;
      $("sessions-toggle").classList.toggle("active", !aside.hidden);
      if (!aside.hidden) load(api);
    });
    $("sessions-close").addEventListener("click", () => {
      $("sessions").hidden = true;
      $("sessions-toggle").classList.remove("active");
    });
  }

  /** The watcher's page: the watched session's 3D view (no control panel) and its status sentence, nothing else. */
  async function watch(id, api, viewerSrc) {
    document.body.classList.add("watching");
    $("subtitle").textContent = `watching session ${id} (read-only)`;
    let info;
    try {
      info = await api(`/api/visits/${id}/watch`);
    } catch (e) {
      $("status-line").textContent = `no session ${id} to watch: it may have ended (${e.message})`;
      return;
    }
    $("viewer").src = viewerSrc(info);
    $("viewer-full").href = $("viewer").src;
    document.body.dataset.ready = "true";
    const poll = async () => {
      try {
        const visits = await api("/api/visits");
        const v = visits.sessions.find((s) => s.watch_id === id);
        $("status-line").textContent = v ? v.status : "this session has ended";
        $("status-detail").textContent = v ? `watching ${id}: ${v.terrain}` : "";
        if (!v) return;
      } catch (e) {
        $("status-line").textContent = "server unreachable";
      }
      setTimeout(poll, 1000);
    };
    poll();
  }

  return { watchId, gone, rejoin, wire, load, watch };
})();
