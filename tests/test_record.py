"""`contactnet simulate --record FILE.viser`: the headless simulation's scene over time, as the web
tool draws it, in a file the web tool's recordings page plays back."""

from __future__ import annotations

import base64
import json
import os
from pathlib import Path

import numpy as np
import pytest

from app.recordings.meta import read_meta
from app.recordings.recorder import RecordingStore, read_recording
from contactnet.cli import EXIT_USER_ERROR, main

pytestmark = pytest.mark.app  # the web tool: `pytest -m "not app"` skips these

SIMULATE = ["simulate", "--terrain", "flat", "--gait", "walk", "--planner", "heuristic", "--vx", "0.1"]


def robot_x(data: bytes) -> list[float]:
    """The robot's base x in every frame of a recording (its SetPositionMessage on /robot)."""
    import msgspec
    import zstandard

    inner = zstandard.ZstdDecompressor().decompress(data[8:], max_output_size=int.from_bytes(data[:8], "little"))
    header = msgspec.msgpack.decode(inner[8 : 8 + int.from_bytes(inner[:8], "little")])
    return [
        m["position"][0]
        for _, m in header["messages"]
        if m["type"] == "SetPositionMessage" and m["name"] == "/robot"
    ]


def status_texts(data: bytes) -> list[str]:
    """The status label's text in every frame of a recording."""
    import msgspec
    import zstandard

    inner = zstandard.ZstdDecompressor().decompress(data[8:], max_output_size=int.from_bytes(data[:8], "little"))
    header = msgspec.msgpack.decode(inner[8 : 8 + int.from_bytes(inner[:8], "little")])
    texts = []
    for _, m in header["messages"]:
        if m.get("name") == "/status/text":
            text = m.get("props", {}).get("text") if m["type"] == "LabelMessage" else m.get("updates", {}).get("text")
            if text:
                texts.append(text)
    return texts


def test_record_writes_a_viser_recording(tmp_path, capsys):
    path = tmp_path / "walk.viser"
    assert main([*SIMULATE, "--duration", "1.5", "--record", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"recording: {path}" in out and "frames" in out
    data = path.read_bytes()
    assert len(data) > 10_000
    contents = read_recording(data)
    assert contents.duration_s == pytest.approx(1.5, abs=0.12)
    # the web tool's scene: robot, terrain, candidate disks, planned steps, CoM paths, forces
    assert {"/robot", "/terrain/mesh", "/plan/candidates", "/plan/steps", "/plan/com", "/forces/feet"} <= (
        contents.node_names
    )
    assert "SetCameraPositionMessage" in contents.message_types  # playback starts with a useful view
    x = robot_x(data)
    assert len(x) >= 15  # one pose per frame, 12 frames per simulated second
    assert x[-1] - x[0] > 0.05 and np.all(np.diff(x) > -0.01)  # it walks forward over time
    # no temporary file; the metadata and the data track (app.recordings.track) next to the recording
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.viser", "walk.viser.json", "walk.viser.track.json"]
    assert oct(path.stat().st_mode & 0o777) == oct(0o666 & ~_umask())
    # the metadata the recordings list shows, next to the file (app.recordings.meta)
    meta = read_meta(path).meta
    assert (meta.robot, meta.terrain, meta.gait, meta.planner) == ("solo12", "flat", "walk", "heuristic")
    assert meta.frames == len(x) and meta.duration_s == pytest.approx(contents.duration_s, abs=0.1)
    assert meta.result == "stopped" and meta.title == "" and meta.runs == ()
    # the status plays back with the scene: a label following the robot, and the gait schedule
    assert {"/status/text", "/status/gait"} <= contents.node_names
    texts = status_texts(data)
    assert len(texts) >= 15 and texts[0].startswith("walking · t 0.0 s · x 0.00 m (0 %)")
    assert texts[-1].startswith("walking · t 1.5 s") and "steps" in texts[-1]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_record_with_json_keeps_stdout_one_object(tmp_path, capsys):
    path = tmp_path / "trot.viser"
    path.write_bytes(b"old")  # replaced
    argv = [*SIMULATE, "--duration", "1.0", "--record", str(path), "--json"]
    assert main([a if a != "walk" else "trot" for a in argv]) == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)  # exactly one JSON object
    assert result["sim_time_s"] == pytest.approx(1.0, abs=0.01)
    assert f"recording: {path}" in captured.err
    assert read_recording(path.read_bytes()).duration_s == pytest.approx(1.0, abs=0.12)


def test_the_web_tool_lists_and_plays_a_cli_recording(tmp_path):
    """The recordings page lists *.viser files of its folder and plays them with the viser client
    (`/viewer/?playbackPath=...`); a CLI recording saved there is served like a live one."""
    from fastapi.testclient import TestClient

    from app.api.server import ContactnetApp
    from app.live.settings import ServeSettings
    from app.recordings.recorder import free_port

    folder = tmp_path / "recordings"
    folder.mkdir()
    assert main([*SIMULATE, "--duration", "0.5", "--record", str(folder / "cli-demo.viser")]) == 0
    assert [r.name for r in RecordingStore(folder).list()] == ["cli-demo.viser"]
    app = ContactnetApp(
        ServeSettings(terrain="flat", planner="heuristic", vx_m_s=0.0, paused=True, viser_port=free_port(),
                  recordings_dir=folder)
    )
    try:
        client = TestClient(app.api, base_url="http://127.0.0.1:8000")  # a Host the tool answers to
        (entry,) = client.get("/api/recordings").json()
        assert entry["name"] == "cli-demo.viser"
        assert entry["play_url"] == "/viewer/?playbackPath=/api/recordings/cli-demo.viser"
        download = client.get(entry["download_url"])
        assert download.content == (folder / "cli-demo.viser").read_bytes()
        html = client.get(entry["html_url"]).text
        # the one-file player: viser's client with the recording, and the timeline and plots of its track
        assert base64.b64encode(download.content).decode() in html and "CONTACTNET_RECORDING" in html
        assert client.get(entry["track_url"]).json()["frames"]["sim_t"][-1] == pytest.approx(0.5, abs=0.1)
    finally:
        app.close()


@pytest.mark.parametrize(
    "where, message",
    [
        ("missing/sub/run.viser", "does not exist"),
        ("a_file.txt/run.viser", "is not a folder"),
        ("run.mp4", "must end in .viser"),
        (".", "must end in .viser"),
        ("a_folder.viser", "is a folder"),
    ],
)
def test_bad_record_paths_are_one_line_errors(tmp_path, capsys, where, message):
    (tmp_path / "a_file.txt").write_text("x")
    (tmp_path / "a_folder.viser").mkdir()
    before = sorted(p.name for p in tmp_path.rglob("*"))
    code = main([*SIMULATE, "--duration", "0.2", "--record", str(tmp_path / where)])
    captured = capsys.readouterr()
    assert code == EXIT_USER_ERROR
    assert captured.err.startswith("contactnet: error: recording file") and message in captured.err
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err
    assert captured.out == ""  # failed before simulating
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


def test_unwritable_folder_is_a_one_line_error(tmp_path, capsys):
    if os.geteuid() == 0:  # root writes through permission bits: use sysfs, which refuses new files
        folder = "/sys"
        try:
            Path(folder, ".contactnet-probe").touch()
        except OSError:
            pass
        else:
            Path(folder, ".contactnet-probe").unlink()
            pytest.skip("no unwritable folder to test with")
    else:
        folder = tmp_path / "locked"
        folder.mkdir()
        folder.chmod(0o500)
    code = main([*SIMULATE, "--duration", "0.2", "--record", f"{folder}/run.viser"])
    err = capsys.readouterr().err
    assert code == EXIT_USER_ERROR
    assert f"cannot write in {folder}" in err and err.count("\n") == 1 and "Traceback" not in err


def test_read_recording_refuses_other_bytes(tmp_path):
    for data in (b"", b"not a recording at all", (100).to_bytes(8, "little") + b"\x00" * 50):
        with pytest.raises(ValueError, match="not a .viser recording"):
            read_recording(data)
