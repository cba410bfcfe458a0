"""The terrain editor edits heights in a real headless browser (Debian chromium, software WebGL), on the
viser page itself: a click on a raised stone selects it, the typed field and the slider set its height
(each change one edit of the session's terrain, the two widgets in sync, a height beyond the schema's
bound refused with the field named), undo takes it back; on the paper's random field a click with the
"raise cell" tool lifts one grid cell by the typed cell step; a height map chosen in the file dialog is previewed
(what was kept as steppable, the ramp shaded) and walked only once "Use imported terrain" is pressed. Screenshots
go to artifacts/."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from helpers import (
    ARTIFACTS,
    browser_marks,
    chromium,
    live_app,
    open_viser,
    screen_xy,
    viser_client,
    wait_for,
)

from contactnet.terrain import Terrain

pytestmark = browser_marks()

STONE = 4  # raised_stones: the 5-point star at (0.62, -0.095), top +4.3 cm


@pytest.fixture(scope="module")
def live(tmp_path_factory):
    app = live_app(tmp_path_factory, terrain="raised_stones", planner="heuristic", vx_m_s=0.0, paused=True)
    yield app
    app.close()


@pytest.fixture(scope="module")
def page(live):
    with chromium() as browser:
        page = open_viser(browser, live.viser_port)
        page.get_by_text("Terrain editor").first.click()  # the folder starts closed
        yield page


def settled_camera(app):
    """The camera the browser reports once it stopped moving (a follow or mode change glides)."""
    camera = viser_client(app).camera
    seen = [np.r_[camera.position, camera.wxyz]]

    def still() -> bool:
        time.sleep(0.5)
        seen.append(np.r_[camera.position, camera.wxyz])
        return np.abs(seen[-1] - seen[-2]).max() < 1e-5

    wait_for(still, timeout=30, what="the camera to settle")
    return camera


def click_world(page, app, point_world) -> None:  # noqa: ANN001
    """A real mouse click in the 3D view on a world point (left of the control panel)."""
    size = page.viewport_size
    xy = screen_xy(settled_camera(app), point_world, (size["width"], size["height"]))
    assert xy is not None and 20 < xy[0] < 950 and 20 < xy[1] < 880, f"{point_world} is off screen: {xy}"
    page.mouse.click(*xy)


def look_closely(page, app, at) -> None:  # noqa: ANN001
    """The browser's camera in free mode, 60 cm from ``at`` (behind, right, above), once the browser reports it
    (a pose we set reaches the browser late; clicks before that would go through the old camera)."""
    from app.scene.camera import place_camera

    client = viser_client(app)
    app.viewer.panel.camera.set_mode(client, "free")
    at = np.asarray(at, dtype=float)
    position = at + np.array([-0.3, -0.4, 0.3])
    reports: list[np.ndarray] = []

    @client.camera.on_update
    async def _(camera) -> None:  # noqa: ANN001 - async: run on viser's event loop, in arrival order
        reports.append(np.r_[camera.position, camera.look_at])

    place_camera(client, position, at, force=True)
    wait_for(lambda: reports and np.allclose(reports[-1], np.r_[position, at], atol=1e-4), timeout=60,
             what="the browser to report the close-up camera")
    time.sleep(2.0)  # the renderer draws it


def top_z(app, index: int) -> float:
    data = app.terrains.current
    return float(data["regions"][index].get("z", data.get("surface_z", 0.0)))


def test_select_a_raised_stone_and_set_its_height(live, page):
    app = live
    panel = app.viewer.panel.editor
    wait_for(lambda: app.session.view is not None and app.terrains.label == "raised_stones", what="the session")
    regions = app.terrains.current["regions"]
    assert regions[STONE]["shape"] == "star" and regions[STONE]["z"] == pytest.approx(0.043)
    panel.tool.value = "select stone"
    star = np.array([*regions[STONE]["center"], regions[STONE]["z"]])
    look_closely(page, app, star)  # a click is worked out from the camera the browser reported it draws with
    click_world(page, app, star + [0.03, 0.0, 0.0])  # on the star's top, right of its centre
    wait_for(lambda: panel._selected == STONE and panel._gizmo is not None, timeout=30, what="the star selected")
    typed = page.get_by_label("Typed height (cm)")
    typed.wait_for(timeout=30_000)  # shown with the selection
    assert panel.height_number.value == pytest.approx(4.3) and panel.height_slider.value == pytest.approx(4.3)
    time.sleep(1.0)
    assert not app.terrains.can_undo  # showing the height (4.3 is off the slider's 0.5 steps) edits nothing

    typed.fill("9.5")  # the typed field, as a user types in it
    typed.press("Enter")
    wait_for(lambda: top_z(app, STONE) == pytest.approx(0.095), timeout=30, what="the star at +9.5 cm")
    wait_for(lambda: panel.height_slider.value == pytest.approx(9.5), what="the slider to follow")
    page.get_by_text("Region 4 (star) top set to +9.5 cm").wait_for(timeout=30_000)  # the info line says it
    assert app.terrains.label == "raised_stones (edited)"
    terrain = Terrain.from_dict(app.terrains.current)
    assert float(terrain.height_at(star[:2])) == pytest.approx(0.095)
    assert panel._selected == STONE and panel._gizmo.position[2] == pytest.approx(0.105)  # still selected, on top
    others = [r for i, r in enumerate(app.terrains.current["regions"]) if i != STONE]
    assert others == [r for i, r in enumerate(regions) if i != STONE]  # every other region as it was

    slider_id = page.locator("label", has_text="Stone height (cm)").first.get_attribute("for")
    thumb = page.locator(f"[id='{slider_id}'] [role=slider]")
    thumb.focus()
    thumb.press("ArrowRight")  # one slider step: +0.5 cm
    wait_for(lambda: top_z(app, STONE) == pytest.approx(0.10), timeout=30, what="the star at +10 cm")
    wait_for(lambda: typed.input_value() == "10", timeout=30, what="the typed field to follow the slider")
    page.locator("label", has_text="Typed height (cm)").first.scroll_into_view_if_needed()
    look_closely(page, app, star + [0.1, 0.0, 0.0])
    page.screenshot(path=str(ARTIFACTS / "viser_stone_height.png"), timeout=120_000)
    app.viewer.panel.camera.set_mode(viser_client(app), "follow")

    typed.fill("60")  # beyond the schema's bound (50 cm): refused, said, and the field shows the height again
    typed.press("Enter")
    page.get_by_text("regions[4].z").first.wait_for(timeout=30_000)
    assert top_z(app, STONE) == pytest.approx(0.10)
    wait_for(lambda: typed.input_value() == "10", timeout=30, what="the field back at the stone's height")

    page.get_by_role("button", name="Undo").dispatch_event("click")
    wait_for(lambda: top_z(app, STONE) == pytest.approx(0.095), timeout=30, what="undo of the slider step")


def test_raise_a_grid_cell_with_the_click_tool(live, page):
    app = live
    panel = app.viewer.panel.editor
    app.terrains.load("random_80_0")  # the paper's random field: one grid of 5 cm cells
    grid_index, grid = next((i, r) for i, r in enumerate(app.terrains.current["regions"]) if r["shape"] == "grid")
    n = len(app.terrains.current["regions"])
    panel.tool.value = "raise cell"
    step = page.get_by_label("Cell step (cm)")
    step.wait_for(timeout=30_000)  # shown with the cell tools
    step.fill("2")
    step.press("Enter")
    wait_for(lambda: panel.cell_step.value == 2.0, timeout=30, what="the typed cell step")
    removed = {tuple(c) for c in grid["removed"]}
    col, row = next((c, r) for c in range(6, grid["cols"]) for r in range(3, 7) if (c, r) not in removed)
    cell = grid["cell"]
    centre = (grid["origin"][0] + (col + 0.5) * cell, grid["origin"][1] + (row + 0.5) * cell)
    look_closely(page, app, (*centre, 0.0))
    click_world(page, app, (*centre, 0.0))
    wait_for(lambda: len(app.terrains.current["regions"]) == n + 1, timeout=30, what="the cell cut out")
    regions = app.terrains.current["regions"]
    assert [col, row] in regions[grid_index]["removed"]
    assert regions[-1]["z"] == pytest.approx(0.02) and regions[-1]["center"] == pytest.approx(centre)
    said = wait_for(lambda: "raised to" in panel.info.content and panel.info.content.split(" · ")[0],
                    what="the info line")
    x_said, y_said = (float(v) for v in said.removeprefix("Cell (").split(")")[0].split(","))
    assert said.endswith("raised to +2.0 cm") and (x_said, y_said) == pytest.approx(centre, abs=0.006)
    page.get_by_text(said).wait_for(timeout=30_000)  # in the browser's panel

    time.sleep(1.0)
    click_world(page, app, (*centre, 0.02))  # again, on its new top: now a rect of its own
    wait_for(lambda: app.terrains.current["regions"][-1]["z"] == pytest.approx(0.04), timeout=30,
             what="the cell at +4 cm")
    assert len(app.terrains.current["regions"]) == n + 1
    time.sleep(2.0)  # the renderer draws the raised cell
    page.screenshot(path=str(ARTIFACTS / "viser_raised_cell.png"), timeout=120_000)
    app.viewer.panel.camera.set_mode(viser_client(app), "follow")


def test_upload_a_height_map_see_what_was_kept_then_walk_it(live, page, tmp_path):
    """A height map with a 10 degree ramp and a gap, chosen in the browser's file dialog: the panel previews
    what was kept (the top view with the ramp shaded, the report) and the robot moves only when "Use
    imported terrain" is pressed (issue 30, item 4)."""
    app = live
    imports = app.viewer.panel.editor.imports
    heights = np.zeros((50, 300))  # 1 cm per pixel: 3 m x 0.5 m
    x = np.arange(300) * 0.01
    ramp = (x >= 1.0) & (x < 1.5)
    heights[:, ramp] = np.tan(np.radians(10.0)) * (x[ramp] - 1.0)
    heights[:, x >= 1.5] = np.tan(np.radians(10.0)) * 0.5
    heights[:, (x >= 2.2) & (x < 2.28)] = np.nan  # an 8 cm gap
    path = tmp_path / "ramp_and_gap.npy"
    np.save(path, heights)
    before = app.terrains.label
    with page.expect_file_chooser() as chooser:
        page.get_by_role("button", name="Upload height map or mesh").click()
    chooser.value.set_files(str(path))
    use = page.get_by_role("button", name="Use imported terrain")
    use.wait_for(timeout=60_000)
    page.get_by_text("ramp_and_gap.npy:", exact=False).first.wait_for(timeout=30_000)  # the report, in the browser's panel
    assert "1 sloped" in imports.report.content
    assert app.terrains.label == before  # previewed, not used
    preview = page.locator("img[src^='data:image'], img[src^='blob:']").last
    preview.wait_for(timeout=30_000)
    assert preview.evaluate("image => image.naturalWidth") > 200  # the top view, drawn
    preview.scroll_into_view_if_needed()
    page.screenshot(path=str(ARTIFACTS / "viser_import_preview.png"), timeout=120_000)
    use.click()
    wait_for(lambda: app.terrains.label == "ramp_and_gap (imported)", timeout=60, what="the imported terrain in use")
    terrain = app.session.view.terrain
    assert terrain.sloped
    assert terrain.height_at(np.array([[1.25, 0.25]]))[0] == pytest.approx(0.25 * math.tan(math.radians(10)), abs=0.01)
    assert not terrain.is_safe(np.array([[2.24, 0.25]]))[0]
    use.wait_for(state="hidden", timeout=30_000)
    time.sleep(2.0)  # the renderer draws the ramp
    page.screenshot(path=str(ARTIFACTS / "viser_imported_ramp.png"), timeout=120_000)
