"""Helpers shared by test modules (fixtures live in conftest.py; no test module imports another)."""

from __future__ import annotations

import contextlib
import time

import numpy as np


def wait_for(predicate, timeout: float = 20.0, what: str = "condition", poll_s: float = 0.02):
    """Poll ``predicate`` until it returns something truthy (returned), else fail naming ``what``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(poll_s)
    raise AssertionError(f"timed out waiting for {what}")


def default_sigint() -> None:
    """``preexec_fn`` of a subprocess a test will Ctrl-C: SIGINT back to its default and unblocked. A shell starts
    background jobs (e.g. ``make test &``) with SIGINT ignored, the children inherit that, and Python then installs
    no KeyboardInterrupt handler; and a thread of the test process that blocks signals (a library's) leaves them
    blocked in the children it forks, across exec: either way the signal the test sends would do nothing (in CI a
    datagen run once finished all its episodes after the Ctrl-C)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def save_random_models(folder, stand: bool = False) -> None:
    """walk.pt and trot.pt with random weights, so the web tests do not depend on the shipped models:
    the ContactNet planner then ranks candidates at random, and still takes the first safe one. ``stand``: with
    N_a + 1 outputs (the stand choice too, `GaitSpec.n_choices`), the stand output biased to rank first, so the
    planner stands at every step horizon (as a trained model should with a zero command on flat ground)."""
    import numpy as np
    import torch

    from contactnet import registry
    from contactnet.planning.network import ContactNet, Normalizer, save_model

    rng = np.random.default_rng(0)
    u = rng.normal(size=(64, 14)) * 0.1 + np.r_[np.zeros(8), 0.22, np.zeros(5)]
    for gait in ("walk", "trot"):
        torch.manual_seed(0)
        spec = registry.gait_by_name(gait)
        net = ContactNet(spec.n_choices if stand else spec.n_actions).eval()
        if stand:
            with torch.no_grad():
                net.layers[-1].bias[spec.stand_index] += 100.0
        save_model(folder / f"{gait}.pt", net, Normalizer.fit(u), {"gait": gait})


# ---- the browser tests (real Debian chromium driven by playwright) ----------------------------------------
def _artifacts():
    import os
    from pathlib import Path

    return Path(os.environ.get("CONTACTNET_ARTIFACTS") or Path(__file__).resolve().parent.parent / "artifacts")


ARTIFACTS = _artifacts()
"""Where browser tests save their screenshots: $CONTACTNET_ARTIFACTS, else artifacts/ (git-ignored)."""


def browser_marks() -> list:
    """The marks of a browser test module: slow, app, browser, and skipped without Debian's chromium."""
    import shutil
    from pathlib import Path

    import pytest

    from app.bench.headless import CHROMIUM

    return [
        pytest.mark.slow,
        pytest.mark.app,
        pytest.mark.browser,
        pytest.mark.skipif(
            shutil.which(CHROMIUM) is None and not Path(CHROMIUM).exists(),
            reason="needs Debian chromium (apt-get install -y chromium)",
        ),
    ]


def chromium():
    """A context manager giving a headless chromium browser (the artifacts folder made)."""
    from contextlib import contextmanager

    from playwright.sync_api import sync_playwright

    from app.bench.headless import CHROMIUM, LAUNCH_ARGS

    @contextmanager
    def launched():
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=list(LAUNCH_ARGS))
            try:
                yield browser
            finally:
                browser.close()

    return launched()


#: How long a page's actions and waits may take (playwright's default is 30 s): a guard against a hang beside the
#: software renderer of a loaded machine (CI runs the browser tests beside another worker), not a speed test. When a
#: session starts, its first frames with the robot and the scene, drawn in software WebGL, held a page's main thread
#: 10-30 s on such a machine (measured: `page.evaluate` answered after 9.8-13 s, and the panel then showed a status up
#: to 25 s old and caught up within a second): a wait of 30 s for the page's text failed about one run in ten there.
BROWSER_TIMEOUT_MS = 90_000


def new_context(browser, width: int = 1400, height: int = 900):  # noqa: ANN001, ANN201 - playwright objects
    """A new browser profile (its own cookies) at ``width`` x ``height`` whose pages' actions wait up to
    `BROWSER_TIMEOUT_MS`."""
    context = browser.new_context(viewport={"width": width, "height": height})
    context.set_default_timeout(BROWSER_TIMEOUT_MS)
    return context


def new_page(browser, width: int = 1400, height: int = 900):  # noqa: ANN001, ANN201 - playwright objects
    """A page in a `new_context` of ``browser``."""
    return new_context(browser, width, height).new_page()


#: The 3D view's pixel ratio in the browser tests (viser's ``fixedDpr``, given in the page's address): a quarter.
#: viser redraws for 250 ms after every change and once a second, and software WebGL (SwiftShader) takes a quarter
#: second a frame, so the 3D view draws without pause: measured on a 2-core machine (a paused session's 3D view, 20 s)
#: chromium's GPU process took 185 % of a core at viser's own ratio, 80 % at 0.5 (the page's own choice without a GPU,
#: static/embed.js) and 45 % at 0.25 (0.1: 44 %). Nothing a test checks depends on it: clicks and the camera's
#: projections are in CSS pixels, and no test reads the 3D view's pixels. The page's own choice is tested by
#: tests/test_browser_page.py, which opens the page without it.
LIGHT_VIEW = "fixedDpr=0.25"


def light(url: str) -> str:
    """``url`` with the browser tests' 3D view resolution (`LIGHT_VIEW`) added to its query."""
    return url + ("&" if "?" in url else "?") + LIGHT_VIEW


def open_viser(browser, port: int):  # noqa: ANN001, ANN201 - playwright objects
    """A 1400 x 900 page of the viser client served at ``port`` (loopback, `light`), once it says "Connected". (Its
    session's first frames may still hold it for a while: `BROWSER_TIMEOUT_MS`.)"""
    page = new_page(browser)
    page.goto(light(f"http://127.0.0.1:{port}/"))
    page.get_by_text("Connected").wait_for(timeout=90_000)
    return page


def screen_xy(camera, point_world, css_size: tuple[int, int]) -> tuple[float, float] | None:  # noqa: ANN001
    """Where a world point is drawn in a browser's 3D view (CSS pixels, the canvas ``css_size`` wide and high), from
    the camera it reported; None behind it. (The camera's image size is in rendered pixels: a quarter of them in the
    tests, `light`, and viser lowers them further on a slow renderer.)"""
    import math

    from viser import transforms

    rotation = transforms.SO3(np.asarray(camera.wxyz)).as_matrix()  # OpenCV: x right, y down, z forward
    p = rotation.T @ (np.asarray(point_world, dtype=float) - np.asarray(camera.position))
    if p[2] <= 1e-3:
        return None
    width, height = css_size
    focal = 0.5 * height / math.tan(0.5 * camera.fov)
    return width / 2 + focal * p[0] / p[2], height / 2 + focal * p[1] / p[2]


def viser_client(app):  # noqa: ANN001, ANN201
    """The first viser client connected to ``app``'s 3D view (waits for one)."""
    return wait_for(lambda: list(app.viewer.server.get_clients().values()), what="the viser client")[0]


def camera_offset(app, client):  # noqa: ANN001, ANN201 - an (3,) array
    """``client``'s camera position - look-at (m), read from one state: viser replaces the state at each report
    of the browser (on its event loop) and our setters change it in place (under the camera control's lock), so
    two separate reads of ``client.camera.position`` and ``.look_at`` can pair poses of different moments (a
    busy-machine failure: an offset 0.58 m off while the camera followed the robot)."""
    with app.viewer.panel.camera._lock:
        state = client.camera._state
        return state.position - state.look_at


def live_app(tmp_path_factory, stand_models: bool = False, **settings):  # noqa: ANN001, ANN201
    """A ContactnetApp (the live session and its 3D view on a free loopback port) with shipped-format random
    models (``stand_models``: that can choose to stand) and its own recordings folder; ``settings`` are
    ServeSettings fields. Close it when done."""
    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    models = tmp_path_factory.mktemp("models")
    save_random_models(models, stand=stand_models)
    return ContactnetApp(ServeSettings(viser_port=free_port(), recordings_dir=tmp_path_factory.mktemp("recordings"),
                                       models_dir=models, **settings))


def short_flat(goal_x: float = 0.06):  # noqa: ANN201 - a Terrain
    """Flat ground with the goal line a few centimetres ahead (a run that ends in about a second)."""
    from contactnet.terrain import Terrain, flat

    data = flat().to_dict()
    data.update(name="short", goal_x=goal_x)
    return Terrain.from_dict(data)


def make_session(tmp_path, terrain, **settings):  # noqa: ANN001, ANN201 - a started LiveSession
    """A started live session on ``terrain`` (heuristic planner, standing command, short count-downs unless
    ``settings``, ServeSettings fields, say otherwise) with its models and robot cache in ``tmp_path``."""
    from functools import partial

    from app.live.planners import default_planner_factory
    from app.live.session import LiveSession
    from app.live.settings import ServeSettings

    values = dict(planner="heuristic", vx_m_s=0.0, viewer_start_delay_s=0.3, loop_delay_s=0.5) | settings
    return LiveSession(
        ServeSettings(**values), terrain, terrain.name,
        planner_factory=partial(default_planner_factory, model_dir=tmp_path), robot_cache_dir=tmp_path,
    ).start()


@contextlib.contextmanager
def served(app):  # noqa: ANN001, ANN201
    """``app``'s HTTP API served on a free loopback port while in the block; yields the port."""
    from app.api.server import BackgroundServer
    from app.recordings.recorder import free_port

    port = free_port()
    web = BackgroundServer(app.api, "127.0.0.1", port)
    try:
        yield port
    finally:
        web.stop()


@contextlib.contextmanager
def serving(app):  # noqa: ANN001, ANN201
    """``app``'s HTTP API served on a free loopback port while in the block, and ``app`` closed after it (also on
    an error); yields (app, its base URL): a module fixture's whole body."""
    try:
        with served(app) as port:
            yield app, f"http://127.0.0.1:{port}"
    finally:
        app.close()


@contextlib.contextmanager
def served_flat_tool(data):  # noqa: ANN001, ANN201 - a Path
    """The tool on flat ground (heuristic planner, standing still, walking at once) with its terrains and recordings
    in ``data``, its API served on a free loopback port while in the block; yields (app, port)."""
    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    (data / "recordings").mkdir(parents=True, exist_ok=True)
    (data / "terrains").mkdir(parents=True, exist_ok=True)
    app = ContactnetApp(
        ServeSettings(terrain="flat", planner="heuristic", vx_m_s=0.0, wait_for_viewer=False, viser_port=free_port(),
                      terrains_dir=data / "terrains", recordings_dir=data / "recordings")
    )
    try:
        with served(app) as port:
            yield app, port
    finally:
        app.close()


class FixedScores:
    """A stand-in network model whose scores do not depend on the state: one random score per stepping action of
    ``gait`` (no stand output), drawn with ``seed``."""

    def __init__(self, gait, seed: int) -> None:  # noqa: ANN001 - a GaitSpec
        self.gait, self.n_actions, self.path = gait.name, gait.n_actions, "<fixed>"
        self._scores = np.random.default_rng(seed).normal(size=gait.n_actions)

    def scores(self, u):  # noqa: ANN001, ANN201
        return self._scores


def slid_back(points_xy_world, terrain, planner, ahead_xy) -> np.ndarray:  # noqa: ANN001
    """The obvious slide of landing points (``contactnet.planning.roll.slide_back``): for each point without the room
    ``ahead_xy``, every point 1 mm apart back along it up to the planner's limit asked of ``Terrain.is_safe`` at once;
    the first with the room among those whose every point so far and the point behind it are safe, else the last of
    those. Returns the (k, 2) points."""
    ahead = np.asarray(ahead_xy, dtype=float)
    radius, roll, margin = planner.robot.foot_radius_m, planner.roll, planner.margin_m
    unit = ahead / np.linalg.norm(ahead)
    count = round(roll.slide_back_radii * radius / 0.001)
    points = np.array(points_xy_world, dtype=float).reshape(-1, 2)
    for k, point in enumerate(points.copy()):
        if terrain.is_safe(point[None] + ahead, margin)[0]:
            continue
        back = np.array([point - i * 0.001 * unit for i in range(1, count + 1)])
        usable = np.logical_and.accumulate(terrain.is_safe(back, margin) & terrain.is_safe(
            back - roll.slide_behind_radii * radius * unit, margin))
        roomy = usable & terrain.is_safe(back + ahead, margin)
        if roomy.any():
            points[k] = back[np.argmax(roomy)]
        elif usable.any():
            points[k] = back[np.flatnonzero(usable)[-1]]
    return points
