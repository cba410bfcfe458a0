"""The one-file player of a recording (``GET /api/recordings/NAME/html``): one HTML page that plays a .viser
recording anywhere, offline, with what the front page shows while it plays one: the header and progress bar of
the recording (not of a live session), the timeline in simulated seconds with its markers (pushes, stands, falls,
goal, restarts) and the plots (rank chosen, commanded and measured velocity, planner time per plan) in step with
the scrubber.

The page is the front page's playback (``static/playback.js``, ``static/playback.css`` and the header styles of
``static/app.css``, inlined) around viser's own client, which plays the recording in an ``iframe`` whose document
(``srcdoc``) is built in the browser from the client's HTML and the recording's bytes (both base64 in the page):
an ``srcdoc`` document shares the page's origin, so the player reads the scrubber's time as the front page does,
from a ``file://`` page too. Nothing is fetched: no network, no CDN.
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path
from typing import Any

import viser

from app.recordings.meta import RecordingMeta
from app.recordings.track import NO_TRACK

STATIC_DIR = Path(__file__).resolve().parents[2] / "static"
VISER_CLIENT = Path(viser.__file__).parent / "client" / "build" / "index.html"


def _script_json(value: Any) -> str:
    """JSON safe inside a <script> element (no ``</`` to end it early)."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")


def player_html(data: bytes, track: dict | None, title: str = "", meta: RecordingMeta | None = None,
                name: str = "") -> str:
    """The one-file player of the .viser bytes ``data`` with its data track (None: the player says it has none)."""
    client = base64.b64encode(VISER_CLIENT.read_bytes()).decode("ascii")
    recording = base64.b64encode(data).decode("ascii")
    scene = " · ".join(v for v in ((meta.terrain, meta.gait, meta.planner) if meta else ()) if v)
    config = {
        "title": title or name or "recording",
        "name": name,
        "scene": scene,
        "result": meta.result if meta else None,
        "track": track,
        "note": None if track is not None else NO_TRACK,
    }
    styles = (STATIC_DIR / "app.css").read_text() + "\n" + (STATIC_DIR / "playback.css").read_text()
    script = (STATIC_DIR / "playback.js").read_text()
    heading = html.escape(config["title"])
    return f"""<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{heading} · contactnet recording</title>
<style>{styles}</style>
</head>
<body class="standalone-player">
<header>
  <div class="brand"><strong>contactnet</strong><span class="subtitle">recording: {heading}</span></div>
  <div id="status" class="status" aria-live="polite">
    <div id="status-line" class="status-line">loading the recording…</div>
    <div id="status-detail" class="status-detail"></div>
  </div>
</header>
<div id="progress-row" hidden><div id="tracks" aria-label="progress from the start toward the goal"></div></div>
<main><div id="stage"><iframe id="viewer" title="3D view of the recording"></iframe></div></main>
<script>window.CONTACTNET_RECORDING={_script_json(config)};
window.CONTACTNET_RECORDING.client="{client}";
window.CONTACTNET_RECORDING.data="{recording}";</script>
<script>{script}</script>
<script>Playback.standalone(window.CONTACTNET_RECORDING);</script>
</body>
</html>
"""
