"""A recording's data track (app/recordings/track.py): what the player's timeline and plots show, recorded by the
real recorder from short real simulations (the command line's `simulate --record`, a plain loop with a restart and
a fall, the live session with a push from the API); kept next to the recording through renames, deletions and a
crash (the journal); served by GET /api/recordings/NAME/track, and inside the one-file HTML player."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from helpers import wait_for

from app.recordings.live_recorder import LiveRecorder
from app.recordings.meta import read_meta
from app.recordings.recorder import RecordingStore
from app.recordings.track import NO_TRACK, TrackError, check_track, read_track, track_path
from contactnet.cli import main

pytestmark = pytest.mark.app

RATE_S = 1 / 12


@pytest.fixture(scope="module")
def cli_recording(tmp_path_factory):
    """2.5 simulated s of the walk with ContactNet on flat ground, pushed sideways (4 N) at t = 1.0 s for 0.3 s."""
    folder = tmp_path_factory.mktemp("cli")
    path = folder / "pushed.viser"
    assert main(["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "contactnet", "--vx", "0.1",
                 "--duration", "2.5", "--push", "1.0,0.3,0,4", "--record", str(path)]) == 0
    return path


def test_a_cli_recording_keeps_its_track(cli_recording):
    track = read_track(cli_recording)
    assert check_track(json.loads(track_path(cli_recording).read_text())) == track
    frames, plans = track["frames"], track["plans"]
    meta = read_meta(cli_recording).meta
    assert len(frames["rec_t"]) == meta.frames >= 28  # one row per recorded frame (12 per simulated second)
    rec_t, sim_t = np.array(frames["rec_t"]), np.array(frames["sim_t"])
    assert np.all(np.diff(rec_t) > 0) and rec_t[0] == 0.0
    np.testing.assert_allclose(sim_t, rec_t, atol=2e-3)  # one run from t = 0: the clocks agree
    assert track["states"] == ["walking"] and track["scenes"] == ["flat · walk · contactnet"]
    # the push: once, when its force came on (the loop records every 1/12 s)
    (push,) = [e for e in track["events"] if e["kind"] == "push"]
    assert 1.0 <= push["sim_t"] <= 1.0 + RATE_S + 0.01 and push["text"] == "push (+0.0, +4.0) N"
    assert not [e for e in track["events"] if e["kind"] in ("fall", "goal", "restart")]
    # the plans: one per step horizon (walk: 4 steps per second, a stand now and then), with the network's ranks
    assert 8 <= len(plans["rec_t"]) <= 13 and np.all(np.diff(plans["sim_t"]) > 0)
    assert all(ms > 0 for ms in plans["planner_ms"]) and all(ms > 0 for ms in plans["trajopt_ms"])
    ranked = [r for r, stand in zip(plans["rank"], plans["stand"], strict=True) if not stand]
    assert ranked and all(isinstance(r, int) and r >= 0 for r in ranked)
    stands = [e["sim_t"] for e in track["events"] if e["kind"] == "stand"]
    assert stands == [t for t, stand in zip(plans["sim_t"], plans["stand"], strict=True) if stand]
    # velocity: the command, and the base walking at about it
    assert set(frames["vx_cmd"]) == {0.1} and set(frames["vy_cmd"]) == {0.0}
    late = rec_t > 0.5
    assert np.mean(np.array(frames["vx"])[late]) == pytest.approx(0.1, abs=0.03)
    assert frames["x"][-1] - frames["x"][0] > 0.15 and set(frames["run"]) == {1}


def test_a_restart_and_a_fall_are_on_the_track(robot):
    """Two runs in one recording: the clock goes back at the restart (one frame period later in the recording),
    the second run's scheduled push and its fall are marked where they happened."""
    from app.live.view import ViewTracker
    from app.recordings.recorder import SceneRecorder, view_of
    from contactnet.locomotion import Locomotion
    from contactnet.motion.gait import WALK
    from contactnet.planning.heuristic import HeuristicPlanner
    from contactnet.sim.pybullet_world import Push
    from contactnet.terrain import resolve

    terrain = resolve("flat")
    with SceneRecorder() as recorder:
        for run in range(2):
            with Locomotion(robot, terrain, WALK, HeuristicPlanner(WALK), vel_cmd_xy=(0.1, 0.0)) as loco:
                if run == 1:
                    loco.push(Push(0.3, 0.6, (0.0, 30.0, 0.0)))  # far beyond what it withstands
                tracker = ViewTracker(robot, terrain, WALK)
                while loco.t_s < 1.0 + 1.5 * run and not loco.fall_reason:
                    loco.advance(10)
                    recorder.add(view_of(loco, tracker))
                if run == 0:
                    end_of_first = recorder.duration_s
        fell_at = loco.t_s
        recorder.finish()  # draws the fall, which came between two frames, as the last frame
        track = recorder.track_data()
    check_track(track)
    events = [(e["kind"], e["sim_t"]) for e in track["events"] if e["kind"] != "stand"]
    assert [kind for kind, _ in events] == ["restart", "push", "fall"]
    (restart,) = [e for e in track["events"] if e["kind"] == "restart"]
    assert restart["rec_t"] == pytest.approx(end_of_first + RATE_S, abs=1e-3) and restart["sim_t"] < 0.05
    assert events[1][1] == pytest.approx(0.3, abs=RATE_S + 0.01)
    assert events[2][1] == pytest.approx(fell_at, abs=0.011)
    frames = track["frames"]
    back = [i for i in range(1, len(frames["sim_t"])) if frames["sim_t"][i] < frames["sim_t"][i - 1]]
    assert len(back) == 1 and frames["rec_t"][back[0]] == pytest.approx(restart["rec_t"], abs=1e-3)
    assert track["states"][frames["state"][-1]].startswith("FELL")
    assert frames["run"][0] == 1 and frames["run"][-1] == 2 == frames["run"][back[0]]  # counted at the restart
    assert restart["text"] == "restart: run 2"
    assert np.all(np.diff(frames["rec_t"]) > 0)


def test_the_track_moves_and_goes_with_its_recording(cli_recording, tmp_path):
    folder = tmp_path / "recordings"
    folder.mkdir()
    for suffix in ("", ".json", ".track.json"):
        shutil.copy(f"{cli_recording}{suffix}", folder / f"run.viser{suffix}")
    shutil.copy(cli_recording, folder / "old.viser")  # made before tracks were kept
    store = RecordingStore(folder)
    assert {r.name: r.track for r in store.list()} == {"run.viser": True, "old.viser": False}
    store.rename("run.viser", "kept.viser")
    assert sorted(p.name for p in folder.iterdir()) == ["kept.viser", "kept.viser.json", "kept.viser.track.json",
                                                       "old.viser"]
    assert read_track(folder / "kept.viser")["frames"] == read_track(cli_recording)["frames"]
    with pytest.raises(FileNotFoundError, match="no data track"):
        read_track(folder / "old.viser")
    store.delete("kept.viser")
    assert sorted(p.name for p in folder.iterdir()) == ["old.viser"]


def test_a_crash_keeps_the_track_with_the_recording(robot, tmp_path, monkeypatch):
    """The journal carries the track's new rows with every record: the recovered recording has its track."""
    from app.live.view import ViewTracker
    from app.recordings import journal
    from app.recordings.recorder import view_of
    from contactnet.locomotion import Locomotion
    from contactnet.motion.gait import WALK
    from contactnet.planning.heuristic import HeuristicPlanner
    from contactnet.terrain import resolve

    monkeypatch.setattr("app.recordings.live_recorder.JOURNAL_PERIOD_S", 0.0)  # every frame journaled
    recorder = LiveRecorder(RecordingStore(tmp_path), robot=robot)
    name = recorder.start("crash")
    terrain = resolve("flat")
    with Locomotion(robot, terrain, WALK, HeuristicPlanner(WALK), vel_cmd_xy=(0.1, 0.0)) as loco:
        tracker = ViewTracker(robot, terrain, WALK)
        while loco.t_s < 0.8:
            loco.advance(10)
            recorder.feed(view_of(loco, tracker))
    frames = recorder.status()["frames"]
    recorder.close()  # what a crash leaves: the journal
    assert journal.journal_path(tmp_path, name).is_file()
    store = RecordingStore(tmp_path)  # the next start
    assert store.recovered == [name] and store.info(name).track
    track = read_track(tmp_path / name)
    assert len(track["frames"]["rec_t"]) == frames == store.info(name).meta.frames >= 8
    assert np.all(np.diff(track["frames"]["rec_t"]) > 0) and len(track["plans"]["rec_t"]) >= 2


def test_the_route_serves_the_track_and_says_when_there_is_none(cli_recording, tmp_path):
    from fastapi.testclient import TestClient

    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    folder = tmp_path / "recordings"
    folder.mkdir()
    for suffix in ("", ".json", ".track.json"):
        shutil.copy(f"{cli_recording}{suffix}", folder / f"run.viser{suffix}")
    shutil.copy(cli_recording, folder / "old.viser")
    shutil.copy(cli_recording, folder / "garbled.viser")
    (folder / "garbled.viser.track.json").write_text('{"format": "contactnet-track", "version": 1}')
    app = ContactnetApp(ServeSettings(terrain="flat", planner="heuristic", vx_m_s=0.0, paused=True,
                                      viser_port=free_port(), recordings_dir=folder))
    try:
        client = TestClient(app.api, base_url="http://127.0.0.1:8000")
        entries = {e["name"]: e for e in client.get("/api/recordings").json()}
        assert entries["run.viser"]["track_url"] == "/api/recordings/run.viser/track"
        assert entries["old.viser"]["track_url"] is None
        served = client.get("/api/recordings/run.viser/track")
        assert served.status_code == 200 and served.json() == read_track(cli_recording)
        old = client.get("/api/recordings/old.viser/track")
        assert old.status_code == 404 and old.json()["detail"] == f"old.viser: {NO_TRACK}"
        garbled = client.get("/api/recordings/garbled.viser/track")
        assert garbled.status_code == 500 and "duration_s" in garbled.json()["detail"]
        assert "\n" not in garbled.json()["detail"]
        assert client.get("/api/recordings/missing.viser/track").status_code == 404
        # the one-file player carries the track (and says so when there is none)
        page = client.get("/api/recordings/run.viser/html").text
        assert "CONTACTNET_RECORDING" in page and '"kind":"push"' in page and "Playback.standalone" in page
        assert "http://" not in page.split("window.CONTACTNET_RECORDING.client")[0].split("<body")[1]  # offline
        assert NO_TRACK in client.get("/api/recordings/old.viser/html").text
    finally:
        app.close()


def test_check_track_names_what_is_wrong(cli_recording):
    good = read_track(cli_recording)
    for change, message in (
        (lambda t: t.update(format="x"), "format"),
        (lambda t: t["frames"]["x"].pop(), "one length"),
        (lambda t: t["plans"].pop("rank"), "columns"),
        (lambda t: t["frames"]["steps"].__setitem__(0, 1.5), "frames.steps"),
        (lambda t: t["events"].append({"kind": "boom", "rec_t": 0, "sim_t": 0, "text": ""}), "known kind"),
    ):
        bad = json.loads(json.dumps(good))
        change(bad)
        with pytest.raises(TrackError, match=message):
            check_track(bad)


def test_a_push_on_the_live_session_is_on_its_recording(tmp_path):
    """The live recorder (fed by the viewer's loop) with a push sent through the API."""
    from fastapi.testclient import TestClient
    from helpers import served_flat_tool

    with served_flat_tool(tmp_path) as (app, _port):
        client = TestClient(app.api, base_url="http://127.0.0.1:8000")
        assert client.post("/api/command", json={"vx": 0.1, "vy": 0.0}).status_code == 200
        client.post("/api/recordings/start", json={"label": "pushed"})
        wait_for(lambda: app.recorder.status()["frames"] >= 6, what="frames recorded", timeout=120)
        pushed = client.post("/api/push", json={"fx": 0.0, "fy": 3.0, "duration": 0.3})
        assert pushed.status_code == 200, pushed.text
        pushed_at = pushed.json()["t_s"]
        wait_for(lambda: client.get("/api/state").json()["t_s"] > pushed_at + 0.5, what="the run going on", timeout=120)
        entry = client.post("/api/recordings/stop").json()
        track = client.get(entry["track_url"]).json()
    (push,) = [e for e in track["events"] if e["kind"] == "push"]
    assert push["text"] == "push (+0.0, +3.0) N" and push["sim_t"] == pytest.approx(pushed_at, abs=0.2)
    assert len(track["frames"]["rec_t"]) == entry["frames"]
    assert track["scenes"] == ["flat · walk · heuristic"] and all(r is None for r in track["plans"]["rank"])
