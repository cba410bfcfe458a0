"""Recordings with metadata (issue 12): the sidecar next to each .viser file, the list that shows it, rename,
retitle and delete through the REST API, and what happens to recordings without (or with a broken) sidecar."""

from __future__ import annotations

import json
import logging
import time

import pytest
from fastapi.testclient import TestClient
from helpers import wait_for

from app.api.server import ContactnetApp
from app.live.settings import ServeSettings
from app.recordings.meta import MetaCollector, RecordingMeta, read_meta, sidecar_path, write_meta
from app.recordings.recorder import free_port, read_recording
from app.recordings.store import RecordingStore

pytestmark = pytest.mark.app

FAKE = b"not really a recording"  # the store never reads a file's contents


def meta(**fields) -> RecordingMeta:
    values = dict(title="", robot="solo12", terrain="flat", gait="walk", planner="heuristic", duration_s=2.5,
                  frames=30, result="goal reached", runs=("goal reached",), created=1.7e9)
    values.update(fields)
    return RecordingMeta(**values)


# ---- the sidecar ---------------------------------------------------------------------------------------------
def test_sidecar_round_trip_and_name(tmp_path):
    path = tmp_path / "run.viser"
    assert sidecar_path(path).name == "run.viser.json"
    written = meta(title="Stairs, first try")
    write_meta(path, written)
    assert read_meta(path).meta == written and read_meta(path).note is None
    data = json.loads(sidecar_path(path).read_text())
    assert data["format"] == "contactnet-recording" and data["version"] == 1 and data["terrain"] == "flat"
    assert [p.name for p in tmp_path.iterdir()] == ["run.viser.json"]  # atomic: no temporary file left


@pytest.mark.parametrize(
    "text, why",
    [
        ("{not json", "metadata unreadable"),
        ('{"format": "contactnet-recording", "version": 1, "title": 5}', "title"),
        ('{"format": "contactnet-recording", "version": 1, "frames": -1}', "frames"),
        ('{"format": "contactnet-recording", "version": 1, "duration_s": NaN}', "duration_s"),
        ('{"format": "contactnet-recording", "version": 1, "title": "a", "title": "b"}', "duplicate"),
        ('{"format": "contactnet-recording", "version": 99}', "newer"),
        ('{"format": "something else", "version": 1}', "format"),
        ("[1, 2]", "not a JSON object"),
        ('"' + "x" * 70_000 + '"', "bytes"),
    ],
)
def test_a_bad_sidecar_reads_as_no_metadata_with_the_reason(tmp_path, text, why):
    path = tmp_path / "run.viser"
    sidecar_path(path).write_text(text)
    read = read_meta(path)
    assert read.meta is None and read.note.startswith("metadata unreadable") and why in read.note
    assert "\n" not in read.note and str(tmp_path) not in read.note


def test_collector_reads_the_views_it_records():
    from types import SimpleNamespace as NS

    def view(done=None, gait="walk", runs=0, last=None, compare=None, error=None):
        status = NS(done=done, error=error, robot="solo12", terrain="flat", gait=gait, planner="contactnet",
                    planner_active="contactnet")
        return NS(status=status, run=NS(runs=runs, last_run=last), compare=compare)

    collector = MetaCollector(created=100.0)
    collector.add(view())
    collector.add(view(gait="trot"))
    collector.add(view(gait="trot", done="goal reached"))
    collector.add(view(gait="trot", done="goal reached", runs=1, last=NS(reason="goal reached")))  # same end
    collector.add(view(gait="trot", runs=1))  # the next run (loop)
    collector.add(view(gait="trot", runs=2, last=NS(reason="stopped: the other robot finished")))
    collector.add(view(gait="trot", runs=2, compare=(NS(planner="fixed"),)))
    result = collector.meta(duration_s=4.0, frames=48, title="t")
    assert result.gait == "walk → trot" and result.terrain == "flat" and result.robot == "solo12"
    assert result.planner == "contactnet → contactnet vs fixed"
    assert result.runs == ("goal reached", "stopped: the other robot finished")
    assert result.result == "stopped" and result.created == 100.0 and result.frames == 48
    collector.add(view(done="fell: base touched the ground", runs=2))
    assert collector.meta(4.1, 49).result == "fell: base touched the ground"


# ---- the store -----------------------------------------------------------------------------------------------
def test_store_lists_with_metadata_renames_and_deletes_with_the_sidecar(tmp_path):
    store = RecordingStore(tmp_path)
    store.save(FAKE, "a.viser", meta(title="A"))
    store.save(FAKE, "old.viser")  # made before sidecars: no metadata
    by_name = {r.name: r for r in store.list()}
    assert by_name["a.viser"].meta.title == "A" and by_name["a.viser"].meta_note is None
    assert by_name["old.viser"].meta is None and "no metadata" in by_name["old.viser"].meta_note
    renamed = store.rename("a.viser", "b.viser")
    assert renamed.name == "b.viser" and renamed.meta.title == "A"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.viser", "b.viser.json", "old.viser"]
    with pytest.raises(FileExistsError, match="old.viser"):
        store.rename("b.viser", "old.viser")
    with pytest.raises(FileNotFoundError):
        store.rename("a.viser", "c.viser")
    with pytest.raises(ValueError, match="invalid recording name"):
        store.rename("b.viser", "../c.viser")
    assert store.set_title("old.viser", "Now titled").meta == RecordingMeta(title="Now titled")
    store.delete("b.viser")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.viser", "old.viser.json"]


def test_a_garbled_sidecar_is_logged_once_and_never_fails_the_list(tmp_path, caplog):
    store = RecordingStore(tmp_path)
    store.save(FAKE, "run.viser")
    sidecar_path(tmp_path / "run.viser").write_bytes(b"\xff\xfe garbage")
    with caplog.at_level(logging.WARNING, logger="contactnet.app.recordings"):
        for _ in range(3):
            (info,) = store.list()
    assert info.meta is None and "not UTF-8" in info.meta_note
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "run.viser" in lines[0] and "listed without metadata" in lines[0]


# ---- the REST API --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def app(tmp_path_factory):
    instance = ContactnetApp(
        ServeSettings(terrain="flat", planner="heuristic", vx_m_s=0.05, wait_for_viewer=False,
                      viser_port=free_port(), recordings_dir=tmp_path_factory.mktemp("recordings"))
    )
    yield instance
    instance.close()


@pytest.fixture(scope="module")
def client(app):
    return TestClient(app.api, base_url="http://127.0.0.1:8000")


@pytest.fixture
def folder(app):
    for path in app.recordings.directory.iterdir():
        path.unlink()
    return app.recordings.directory


def record(client, app, title: str = "", label: str = "api", seconds: float = 1.0) -> dict:
    """A recording of the live session made through the API; its list entry."""
    status = client.post("/api/recordings/start", json={"label": label, "title": title}).json()
    wait_for(lambda: app.recorder.status()["frames"] >= 3, what="frames recorded")
    time.sleep(seconds)
    entry = client.post("/api/recordings/stop").json()
    assert entry["name"] == status["name"]
    return entry


def test_a_live_recording_lists_with_its_metadata(client, app, folder):
    started = time.time()
    entry = record(client, app, title="Walking on flat ground")
    assert (folder / f"{entry['name']}.json").is_file()
    (listed,) = client.get("/api/recordings").json()
    assert listed == entry
    assert listed["title"] == "Walking on flat ground" and listed["metadata_note"] is None
    assert (listed["robot"], listed["terrain"], listed["gait"]) == ("solo12", "flat", "walk")
    assert listed["planner"] == "heuristic" and listed["result"] == "stopped"
    assert listed["frames"] >= 3 and listed["duration_s"] > 0.1
    assert started - 1 <= listed["created"] <= time.time()
    contents = read_recording(client.get(listed["download_url"]).content)
    assert {"/status/text", "/status/gait"} <= contents.node_names  # the status plays back with the scene


def test_rename_and_retitle(client, app, folder):
    entry = record(client, app, seconds=0.2)
    name = entry["name"]
    changed = client.patch(f"/api/recordings/{name}", json={"title": "First walk"})
    assert changed.status_code == 200 and changed.json()["title"] == "First walk" and changed.json()["frames"]
    changed = client.patch(f"/api/recordings/{name}", json={"name": "first-walk"})  # .viser added
    assert changed.status_code == 200
    assert changed.json()["name"] == "first-walk.viser" and changed.json()["title"] == "First walk"
    assert changed.json()["download_url"] == "/api/recordings/first-walk.viser"
    assert sorted(p.name for p in folder.iterdir()) == ["first-walk.viser", "first-walk.viser.json",
                                                       "first-walk.viser.track.json"]
    both = client.patch("/api/recordings/first-walk.viser", json={"name": "walk-2.viser", "title": ""})
    assert both.status_code == 200 and both.json()["name"] == "walk-2.viser" and both.json()["title"] == ""
    assert client.get("/api/recordings/first-walk.viser").status_code == 404
    assert client.get("/api/recordings/walk-2.viser").status_code == 200


def test_rename_and_delete_errors(client, app, folder):
    (folder / "a.viser").write_bytes(FAKE)
    (folder / "b.viser").write_bytes(FAKE)
    for body in ({"name": "../escape"}, {"name": "a b"}, {"name": "x.mp4"}, {"name": ""}, {"title": "a\nb"},
                 {"title": "x" * 101}, {}, {"title": None}, {"name": "c", "size": 1}):
        response = client.patch("/api/recordings/a.viser", json=body)
        assert response.status_code == 422, body
    assert "nothing to change" in client.patch("/api/recordings/a.viser", json={}).json()["detail"]
    exists = client.patch("/api/recordings/a.viser", json={"name": "b"})
    assert exists.status_code == 409 and "b.viser" in exists.json()["detail"]
    assert client.patch("/api/recordings/nope.viser", json={"title": "x"}).status_code == 404
    assert client.delete("/api/recordings/nope.viser").status_code == 404
    not_json = client.patch("/api/recordings/a.viser", content=b"title=x", headers={"content-type": "text/plain"})
    assert not_json.status_code == 415
    assert client.request("PATCH", "/api/recordings/a.viser", content=b'{"title": "x", "title": "y"}',
                          headers={"content-type": "application/json"}).status_code == 422
    assert sorted(p.name for p in folder.iterdir()) == ["a.viser", "b.viser"]  # nothing changed


def test_delete_removes_the_file_and_its_sidecar(client, app, folder):
    entry = record(client, app, seconds=0.2)
    (folder / "old.viser").write_bytes(FAKE)  # no sidecar
    assert client.delete(f"/api/recordings/{entry['name']}").status_code == 204
    assert client.delete("/api/recordings/old.viser").status_code == 204
    assert list(folder.iterdir()) == [] and client.get("/api/recordings").json() == []


def test_the_recording_in_progress_cannot_be_changed(client, app, folder):
    status = client.post("/api/recordings/start", json={}).json()
    try:
        name = status["name"]
        (folder / "other.viser").write_bytes(FAKE)
        for response in (
            client.delete(f"/api/recordings/{name}"),
            client.patch(f"/api/recordings/{name}", json={"title": "x"}),
            client.patch("/api/recordings/other.viser", json={"name": name}),
        ):
            assert response.status_code == 409 and "being recorded" in response.json()["detail"]
        # a stop before the first frame is refused ("nothing recorded"): on a loaded machine that takes a while
        wait_for(lambda: app.recorder.status()["frames"] >= 1, what="a frame recorded")
    finally:
        assert client.post("/api/recordings/stop").status_code == 200
    assert client.patch(f"/api/recordings/{name}", json={"title": "x"}).status_code == 200


def test_old_and_garbled_recordings_still_list(client, app, folder, caplog):
    (folder / "old.viser").write_bytes(FAKE)
    (folder / "garbled.viser").write_bytes(FAKE)
    (folder / "garbled.viser.json").write_text('{"format": "contactnet-recording", "version": 1, "frames": "many"}')
    (folder / "orphan.viser.json").write_text("{}")  # a sidecar alone is not a recording
    with caplog.at_level(logging.WARNING, logger="contactnet.app.recordings"):
        listed = {r["name"]: r for r in client.get("/api/recordings").json()}
    assert set(listed) == {"old.viser", "garbled.viser"}
    assert listed["old.viser"]["metadata_note"].startswith("no metadata") and listed["old.viser"]["title"] == ""
    assert "frames" in listed["garbled.viser"]["metadata_note"] and listed["garbled.viser"]["terrain"] is None
    assert any("garbled.viser" in r.getMessage() for r in caplog.records)
    retitled = client.patch("/api/recordings/garbled.viser", json={"title": "fixed"}).json()
    assert retitled["title"] == "fixed" and retitled["metadata_note"] is None  # a new sidecar, title only


def test_the_schema_declares_the_new_routes(client):
    paths = client.get("/openapi.json").json()["paths"]
    item = paths["/api/recordings/{name}"]
    assert {"get", "patch", "delete"} <= set(item)
    assert {"404", "409", "415", "422"} <= set(item["patch"]["responses"])
    assert {"204", "404", "409"} <= set(item["delete"]["responses"])
    entry = client.get("/openapi.json").json()["components"]["schemas"]["RecordingEntry"]["properties"]
    assert all(entry[f].get("description") for f in ("title", "terrain", "duration_s", "result", "created"))


def test_every_refusal_is_declared(client, app, folder):
    (folder / "a.viser").write_bytes(FAKE)
    (folder / "b.viser").write_bytes(FAKE)
    paths = client.get("/openapi.json").json()["paths"]
    for method, path, body, status in (
        ("PATCH", "/api/recordings/a.viser", {"name": "../x"}, 422),
        ("PATCH", "/api/recordings/a.viser", {}, 422),
        ("PATCH", "/api/recordings/a.viser", {"name": "b"}, 409),
        ("PATCH", "/api/recordings/nope.viser", {"title": "x"}, 404),
        ("DELETE", "/api/recordings/nope.viser", None, 404),
    ):
        response = client.request(method, path, json=body)
        assert response.status_code == status, (method, path, body, response.text)
        assert isinstance(response.json()["detail"], str | list)
        assert str(status) in paths["/api/recordings/{name}"][method.lower()]["responses"], (method, status)


# ---- the recorder --------------------------------------------------------------------------------------------
def test_a_run_that_ends_between_two_frames_ends_the_recording():
    """A fall 10 ms after a frame (the next is due 83 ms later) is still the recording's last frame, and its
    result."""
    from dataclasses import replace

    from app.live.view import ViewTracker
    from app.recordings.recorder import SceneRecorder, view_of
    from contactnet.locomotion import Locomotion
    from contactnet.motion.gait import WALK
    from contactnet.planning.heuristic import HeuristicPlanner
    from contactnet.robots import load_robot
    from contactnet.terrain import resolve

    robot, terrain = load_robot("solo12"), resolve("flat")
    with Locomotion(robot, terrain, WALK, HeuristicPlanner(WALK), vel_cmd_xy=(0.1, 0.0)) as loco, \
            SceneRecorder(robot=robot) as recorder:
        tracker = ViewTracker(robot, terrain, WALK)
        while loco.t_s < 0.5:
            loco.advance(10)
            recorder.add(view_of(loco, tracker))
        frames = recorder.frames
        loco.advance(10)
        view = view_of(loco, tracker)
        assert not recorder.add(replace(view, status=replace(view.status, done="fell: test fall", running=False)))
        assert recorder.meta().result == "stopped"  # not drawn yet
        data = recorder.finish()
    result = recorder.meta()
    assert result.result == "fell: test fall" and result.runs == ("fell: test fall",)
    assert result.frames == recorder.frames == frames + 1
    assert read_recording(data).duration_s == pytest.approx(recorder.duration_s + 1 / 12, abs=1e-6)
