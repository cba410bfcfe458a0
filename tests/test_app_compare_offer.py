"""Compare that teaches (issue 31, item 4): on the terrain the session started on, where ContactNet and the fixed
gait are known to do the same, compare mode offers narrow stones (`State.compare_offer`); a terrain the user loaded
is kept, with no offer. Through the REST API of a real live session (no browser)."""

from __future__ import annotations

import shutil

import pytest
from fastapi.testclient import TestClient
from helpers import wait_for

from app.api.server import ContactnetApp
from app.live.compare import SHOWCASE_TERRAIN, compare_offer
from app.live.settings import ServeSettings
from app.recordings.recorder import free_port
from contactnet.terrain import terrains_dir

pytestmark = pytest.mark.app


def test_offer_only_where_the_planners_are_known_to_do_the_same():
    offer = compare_offer("stepping_stones", False, ("contactnet", "fixed"), "solo12")
    assert offer is not None and offer.terrain == SHOWCASE_TERRAIN == "narrow_stones"
    assert offer.planners == ("contactnet", "fixed") and offer.reason.count(".") == 1  # one sentence
    assert "stepping stones" in offer.reason and "falls" in offer.reason
    assert compare_offer("stepping_stones", False, ("fixed", "contactnet"), "solo12").planners == ("fixed", "contactnet")
    assert compare_offer("flat", False, ("contactnet", "fixed"), "solo12") is not None
    for label, chosen, planners, robot in [
        ("stepping_stones", True, ("contactnet", "fixed"), "solo12"),  # the user picked it: kept, no offer
        ("stepping_stones", False, None, "solo12"),  # compare off
        ("stepping_stones", False, ("heuristic", "fixed"), "solo12"),  # a pair not measured
        ("stepping_stones (edited)", False, ("contactnet", "fixed"), "solo12"),
        ("narrow_stones", False, ("contactnet", "fixed"), "solo12"),  # already where they differ
        ("stepping_stones", False, ("contactnet", "fixed"), "go2"),  # measured with Solo12 only
    ]:
        assert compare_offer(label, chosen, planners, robot) is None, (label, chosen, planners, robot)


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    terrains = tmp_path_factory.mktemp("terrains")
    for path in terrains_dir().glob("*.json"):
        shutil.copy(path, terrains / path.name)
    instance = ContactnetApp(
        ServeSettings(  # the defaults a user gets: stepping_stones, walk, ContactNet (the shipped model)
            wait_for_viewer=False,
            viser_port=free_port(),
            terrains_dir=terrains,
            recordings_dir=tmp_path_factory.mktemp("rec"),
        )
    )
    yield instance
    instance.close()


@pytest.fixture(scope="module")
def client(app):
    return TestClient(app.api, base_url="http://127.0.0.1:8000")


def test_compare_on_the_default_terrain_offers_narrow_stones_and_a_chosen_terrain_is_kept(client):
    state = client.get("/api/state").json()
    assert (state["terrain"], state["gait"], state["planner"]) == ("stepping_stones", "walk", "contactnet")
    assert state["compare_offer"] is None  # compare off
    state = client.post("/api/compare", json={"planners": ["contactnet", "fixed"]}).json()
    assert state["terrain"] == "stepping_stones" and [c["planner"] for c in state["compare"]] == ["fixed"]
    offer = state["compare_offer"]
    assert offer["terrain"] == "narrow_stones" and offer["planners"] == ["contactnet", "fixed"]
    assert "narrow stones" in offer["reason"]
    assert client.get("/api/state").json()["compare_offer"] == offer

    # The page's one click: load the offered terrain; compare mode stays on, and the offer is gone.
    state = client.post("/api/session/terrain", json={"name": offer["terrain"]}).json()
    assert state["terrain"] == "narrow_stones" and [c["planner"] for c in state["compare"]] == ["fixed"]
    assert state["compare_offer"] is None and state["scenario"]["compare"] == ["contactnet", "fixed"]

    # A terrain the user picked is kept: back on the stepping stones by choice, compare there makes no offer.
    state = client.post("/api/session/terrain", json={"name": "stepping_stones"}).json()
    assert state["terrain"] == "stepping_stones" and state["compare"] is not None
    assert state["compare_offer"] is None
    client.post("/api/compare", json={"planners": []})
    assert client.post("/api/compare", json={"planners": ["fixed", "contactnet"]}).json()["compare_offer"] is None
    client.post("/api/compare", json={"planners": []})


@pytest.mark.slow
def test_the_offered_scenario_shows_the_difference_live(client):
    """On the live stack (the session's observer on, noise off, as served): on narrow stones the fixed gait falls
    and ContactNet reaches the goal (simulate measured: falls at x 0.48 m, 9.6 s; crosses in 19.3 s)."""
    client.post("/api/session/terrain", json={"name": "narrow_stones"})
    client.post("/api/compare", json={"planners": ["contactnet", "fixed"]})
    state = client.post("/api/settings", json={"speed": 2.0, "loop": False}).json()
    runs = state["runs"]
    client.post("/api/pause", json={"paused": False})
    state = wait_for(lambda: (s := client.get("/api/state").json())["runs"] > runs and s, timeout=240,
                     what="the run on narrow stones to end", poll_s=0.5)
    run = state["last_run"]
    assert run["terrain"] == "narrow_stones" and run["success"], run
    (other,) = run["compare"]
    assert other["planner"] == "fixed" and other["fell"] and not other["success"], other


def test_side_by_side_puts_the_other_robot_on_a_copy_of_the_terrain(client, app):
    """The split view: the 3D view's "Side by side" checkbox moves the other robot onto its own copy of the terrain,
    one lane (the terrain's width + 0.3 m) along +y; off, it is a ghost over the same terrain again."""
    import numpy as np

    from app.scene.live_scene import lane_offset_m

    client.post("/api/compare", json={"planners": ["contactnet", "fixed"]})
    scene = app.viewer.scene
    checkbox = app.viewer.panel.gait_planner.side_by_side
    wait_for(lambda: scene.ghosts.ghosts and scene.ghosts.ghosts[0].visible, what="the ghost drawn")
    dy = lane_offset_m(app.session.view.terrain)
    assert 0.3 < dy < 2.0

    def ghost_y_off() -> float:  # the ghost's y less the other robot's simulated y
        view = app.session.view
        return float(scene.ghosts.ghosts[0].root.position[1]) - float(view.compare[0].snapshot.q[1])

    checkbox.value = True  # as a click in the 3D view's panel
    assert scene.side_by_side
    wait_for(lambda: abs(ghost_y_off() - dy) < 0.02, what="the other robot on its lane")
    assert len(scene._lane_nodes) == 2  # the terrain's copy and its goal line
    assert np.allclose(scene._lane_nodes[0].position, (0.0, dy, 0.0))
    checkbox.value = False
    wait_for(lambda: abs(ghost_y_off()) < 0.02 and not scene._lane_nodes, what="the ghost over the terrain again")
    client.post("/api/compare", json={"planners": []})
