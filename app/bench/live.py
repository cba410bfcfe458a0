"""Does the live session keep real time with browsers connected? And how big is a recording?

    contactnet bench live                  (the defaults below)
    python -m app.bench.live [--seconds 60] [--cases 0,1:normal,1:idle,5:idle,1:idle:compare] [--json]
    contactnet bench live --sessions 1,2,3,4   (a robot per visitor: N sessions at once, `run_sessions`)
    python -m app.bench.live --sessions 1,3 --engine local,ray   (the same, the simulations in this process, then
                                                                   in Ray actors: `serve --engine ray`)

Each case starts the whole tool (FastAPI + viser + live session; flat terrain, walk, vx 0.05 m/s,
scene updates at 30 Hz), opens N headless chromium pages of the front page (playwright, Debian
chromium), waits until each 3D view is connected, resets the robot, and measures over `--seconds`
of wall time: the real-time factor (simulated / wall time while running), scene updates per
second and the CPU cost of one (median), the server process's and the browsers' CPU use, and the
browsers' frame rate. The first case with a browser also records the whole window (12 Hz) and
reports the .viser size.

Browser priority: `normal` runs chromium as is (it raises its GPU process to nice -8); `idle` runs
it under SCHED_IDLE (`chrt --idle 0`), so the browsers only take CPU the server leaves. The pages
render with SwiftShader (no GPU): a frame costs about 0.1-0.3 s of CPU, so on this 2-core machine
five pages want more than all of it; `idle` stands for browsers on other machines, which is what
the server-side cost per connected browser is about. Both are reported.

A case ending in `:compare` runs compare mode (two robots: ContactNet and the fixed gait, both simulated and
drawn), the issue-12 target being real time with one browser.
"""

from __future__ import annotations

import argparse
import json
import os
import stat
import sys
import tempfile
import time
from pathlib import Path

from app.bench.headless import CHROMIUM, LAUNCH_ARGS
from contactnet.bench import format_table

FRAME_COUNT_JS = "() => window.__viserTestpoints ? window.__viserTestpoints.rendererInfo.render.frame : 0"


def cpu_seconds(pids: list[int]) -> float:
    total = 0.0
    tick = os.sysconf("SC_CLK_TCK")
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / tick
        except (OSError, IndexError, ValueError):
            pass
    return total


def chromium_pids() -> list[int]:
    pids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if b"chromium" in (entry / "cmdline").read_bytes():
                    pids.append(int(entry.name))
            except OSError:
                pass
    return pids


def idle_wrapper(directory: Path) -> str:
    """A launcher that runs chromium (and everything it starts) under SCHED_IDLE."""
    path = directory / "chromium-idle"
    path.write_text(f'#!/bin/sh\nexec chrt --idle 0 {CHROMIUM} "$@"\n')
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


def viewer_frame(page):
    return next(f for f in page.frames if "/viewer/" in f.url)


def run_case(
    n_browsers: int,
    priority: str,
    seconds: float,
    viewport: tuple[int, int],
    record: bool,
    workdir: Path,
    compare: bool = False,
) -> dict:
    from app.api.server import BackgroundServer, ContactnetApp
    from app.live.commands import Reset, SetCompare
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    app = ContactnetApp(
        ServeSettings(
            terrain="flat",
            gait="walk",
            vx_m_s=0.05,
            wait_for_viewer=False,
            viser_port=free_port(),
            recordings_dir=workdir / "recordings",
            shared=True,  # the N browsers watch one session (its cost per browser); --sessions measures visitors
        )
    )
    port = free_port()
    web = BackgroundServer(app.api, "127.0.0.1", port)
    playwright = browser = None
    pages = []
    connect_s = 0.0
    try:
        if n_browsers:
            from playwright.sync_api import sync_playwright

            playwright = sync_playwright().start()
            executable = idle_wrapper(workdir) if priority == "idle" else CHROMIUM
            browser = playwright.chromium.launch(executable_path=executable, headless=True, args=list(LAUNCH_ARGS))
            t0 = time.monotonic()
            for _ in range(n_browsers):
                page = browser.new_page(viewport={"width": viewport[0], "height": viewport[1]})
                page.goto(f"http://127.0.0.1:{port}/")
                page.frame_locator("#viewer").get_by_text("Connected").wait_for(timeout=600_000)
                pages.append(page)
            connect_s = time.monotonic() - t0
            if len(app.viewer.server.get_clients()) != n_browsers:
                raise RuntimeError(
                    f"expected {n_browsers} viser clients, got {len(app.viewer.server.get_clients())}"
                )
        if compare:
            app.session.call(SetCompare(("contactnet", "fixed")))
        app.session.call(Reset())
        time.sleep(2.0)
        stats, viewer_stats = app.session.stats, app.viewer.stats
        frames0 = [viewer_frame(p).evaluate(FRAME_COUNT_JS) for p in pages]
        fps_t0 = time.monotonic()
        sim0, wall0, resets0 = stats.running_sim_s, stats.running_wall_s, stats.lag_resets
        updates0 = viewer_stats.scene_updates
        if record:
            app.recorder.start("bench")
        server_cpu0, browser_cpu0, t0 = (
            cpu_seconds([os.getpid()]),
            cpu_seconds(chromium_pids()),
            time.monotonic(),
        )
        time.sleep(seconds)
        elapsed = time.monotonic() - t0
        server_cpu = (cpu_seconds([os.getpid()]) - server_cpu0) / elapsed
        browser_cpu = (cpu_seconds(chromium_pids()) - browser_cpu0) / elapsed
        rtf = (stats.running_sim_s - sim0) / max(stats.running_wall_s - wall0, 1e-9)
        updates = (viewer_stats.scene_updates - updates0) / elapsed
        costs = sorted(viewer_stats.scene_cpu_s[-max(viewer_stats.scene_updates - updates0, 1) :] or [0.0])
        fps_elapsed = time.monotonic() - fps_t0
        frames = [viewer_frame(p).evaluate(FRAME_COUNT_JS) for p in pages]
        fps = sum(b - a for a, b in zip(frames0, frames, strict=True)) / fps_elapsed / max(len(pages), 1)
        recording_mb = frames_recorded = None
        if record:
            frames_recorded = app.recorder.status()["frames"]
            recording_mb = app.recorder.stop().size_bytes / 1e6
        state = app.state()
        target = 0.95 if n_browsers <= 1 else 0.9
        return {
            "browsers": n_browsers,
            "priority": priority if n_browsers else "-",
            "robots": 2 if compare else 1,
            "rtf": round(rtf, 3),
            "target": f">= {target}",
            "ok": rtf >= target,
            "sim_s": round(state.t_s, 1),
            "fell": state.fell,
            "scene_hz": round(updates, 1),
            "scene_update_cpu_ms": round(1e3 * costs[len(costs) // 2], 2),
            "server_cpu_cores": round(server_cpu, 2),
            "browser_cpu_cores": round(browser_cpu, 2),
            "browser_fps": round(fps, 1) if pages else "-",
            "lag_resets": stats.lag_resets - resets0,
            "connect_s": round(connect_s, 1),
            "recording_MB": round(recording_mb, 2) if recording_mb is not None else "-",
            "recorded_frames": frames_recorded if frames_recorded is not None else "-",
        }
    finally:
        if browser is not None:
            browser.close()
        if playwright is not None:
            playwright.stop()
        web.stop()
        app.close()


DEFAULT_CASES = "0,1:normal,1:idle,5:idle,1:idle:compare"


def run_sessions(n_sessions: int, seconds: float, workdir: Path, engine: str = "local") -> dict:
    """N visitors at once (a robot each: `app.api.visits`), each through the front page with its own cookie jar,
    all walking; every session's real-time factor over ``seconds``. No browser draws (their CPU is the visitors'
    machines'); each session's scene is still updated at 30 Hz for its viser server. ``engine`` ``ray``: each
    session in a Ray actor (a Ray must be running in this process: `bench_sessions` starts one); the row then
    also gives the actors' CPU and the bytes of the views they sent."""
    from statistics import median

    from fastapi.testclient import TestClient

    from app.api.server import ContactnetApp
    from app.live.commands import Reset
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    app = ContactnetApp(ServeSettings(terrain="flat", gait="walk", vx_m_s=0.05, wait_for_viewer=False,
                                      viser_port=free_port(), recordings_dir=workdir / "recordings",
                                      terrains_dir=workdir / "terrains", max_sessions=n_sessions, engine=engine))
    try:
        t0 = time.monotonic()
        for _ in range(n_sessions):
            page = TestClient(app.api, base_url="http://127.0.0.1:8000").get("/")
            if page.status_code != 200:
                raise RuntimeError(f"visitor {len(app.visits) + 1} of {n_sessions} got {page.status_code}")
        start_s = time.monotonic() - t0
        visits = app.visits.visits()
        for visit in visits:
            visit.session.call(Reset())
        time.sleep(2.0)
        before = [(v.session.stats.running_sim_s, v.session.stats.running_wall_s, v.session.stats.lag_resets)
                  for v in visits]
        actors = [pid for v in visits if (pid := getattr(v.session, "worker_pid", None)) is not None]
        transfers = [v.session.transfer for v in visits if hasattr(v.session, "transfer")]
        views0 = [(t.views, t.bytes_total) for t in transfers]
        cpu0, actors_cpu0, t0 = cpu_seconds([os.getpid()]), cpu_seconds(actors), time.monotonic()
        time.sleep(seconds)
        elapsed = time.monotonic() - t0
        server_cpu = (cpu_seconds([os.getpid()]) - cpu0) / elapsed
        actors_cpu = (cpu_seconds(actors) - actors_cpu0) / elapsed
        rtfs, resets = [], 0
        for visit, (sim0, wall0, resets0) in zip(visits, before, strict=True):
            stats = visit.session.stats
            rtfs.append((stats.running_sim_s - sim0) / max(stats.running_wall_s - wall0, 1e-9))
            resets += stats.lag_resets - resets0
        views = sum(t.views - v0 for t, (v0, _) in zip(transfers, views0, strict=True))
        view_bytes = sum(t.bytes_total - b0 for t, (_, b0) in zip(transfers, views0, strict=True))
        return {
            "engine": engine,
            "sessions": n_sessions,
            "rtf_min": round(min(rtfs), 3),
            "rtf_median": round(median(rtfs), 3),
            "target": ">= 0.95 each",
            "ok": min(rtfs) >= 0.95,
            "server_cpu_cores": round(server_cpu, 2),
            "cpu_per_session": round(server_cpu / n_sessions, 2),
            "actor_cpu_cores": round(actors_cpu, 2) if actors else "-",
            "views_per_s": round(views / elapsed / n_sessions, 1) if transfers else "-",
            "view_bytes_mean": round(view_bytes / views) if views else "-",
            "lag_resets": resets,
            "sessions_start_s": round(start_s, 1),
        }
    finally:
        app.close()


def bench_sessions(counts: str = "1,2,3,4", seconds: float = 30.0, engines: str = "local") -> list[dict]:
    """One row per engine of ``engines`` (comma-separated: local, ray) and session count of ``counts``: can this
    machine keep them all in real time? For ``ray``, a local Ray of this machine's CPUs is started once."""
    import contextlib

    rows = []
    with tempfile.TemporaryDirectory() as tmp, contextlib.ExitStack() as stack:
        for engine in engines.split(","):
            if engine == "ray":
                from contactnet.jobs.ray_engine import session

                stack.enter_context(session())
            for i, count in enumerate(counts.split(",")):
                rows.append(run_sessions(int(count), seconds, Path(tmp) / f"{engine}{i}", engine))
                print(f"done: {rows[-1]}", file=sys.stderr, flush=True)
    return rows


def bench_live(seconds: float = 60.0, cases: str = DEFAULT_CASES, viewport: str = "960x600") -> list[dict]:
    """One row per case of ``cases`` (comma-separated ``N[:normal|idle][:compare]``: browser counts, their
    priority, compare mode)."""
    size = tuple(int(v) for v in viewport.split("x"))
    rows, recorded = [], False
    with tempfile.TemporaryDirectory() as tmp:
        for spec in cases.split(","):
            count, *options = spec.split(":")
            n = int(count)
            compare = "compare" in options
            priority = next((o for o in options if o in ("normal", "idle")), "normal")
            record = n > 0 and not recorded
            recorded |= record
            rows.append(run_case(n, priority, seconds, size, record, Path(tmp), compare))
            print(f"done: {rows[-1]}", file=sys.stderr, flush=True)
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--seconds", type=float, default=60.0, help="measurement window (wall time)")
    parser.add_argument(
        "--cases",
        default=DEFAULT_CASES,
        help="comma-separated N[:normal|idle][:compare] browser counts, priorities, compare mode",
    )
    parser.add_argument("--viewport", default="960x600")
    parser.add_argument("--sessions", help="comma-separated numbers of visitors' sessions at once (instead of --cases)")
    parser.add_argument("--engine", default="local",
                        help="with --sessions: comma-separated engines (local, ray), each a set of rows, same run")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.sessions:
        rows = bench_sessions(args.sessions, args.seconds, args.engine)
    else:
        rows = bench_live(args.seconds, args.cases, args.viewport)
    if args.json:
        print(json.dumps({"benchmark": "live", "rows": rows}, indent=2))
    else:
        print(format_table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
