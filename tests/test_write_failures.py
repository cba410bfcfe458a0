"""Issue 31, item 7: nothing is lost when a write fails. With the data folder read-only or full, every refused
write is a one-line JSON error (500, or 507 when the disk is full) with no traceback in the log, and a recording
whose save is refused stays open until a later stop saves it; a recording in progress is journaled as it goes
and recovered after a crash (a real SIGKILL); a killed write's temporary file is removed at the next start; a
client that hangs up in the middle of its body logs nothing; names with control characters match nothing.

A read-only folder is made with chmod when the tests do not run as root; root writes through chmod, so there
(and for a full disk, always) the OS refusal is simulated: the write calls of the standard library raise the
OSError the kernel would (EROFS, ENOSPC) for paths inside the folder. Nothing else is replaced."""

from __future__ import annotations

import builtins
import contextlib
import errno
import io
import json
import logging
import os
import re
import signal
import socket
import stat
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from helpers import served_flat_tool, wait_for

from app.live.terrain_files import TerrainLibrary
from app.recordings import journal
from app.recordings.live_recorder import LiveRecorder, RecordingNotSaved
from app.recordings.meta import read_meta
from app.recordings.recorder import quiet_viser_server, read_recording, stop_quietly
from app.recordings.store import RecordingStore
from app.viewer.panels.recording import RecordingPanel
from contactnet.atomic import STALE_TEMPORARY_S, atomic_open, remove_stale_temporaries
from contactnet.terrain import terrains_dir

pytestmark = pytest.mark.app

REPO = Path(__file__).resolve().parent.parent
ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False
WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND


# ---- a folder the OS refuses to change -----------------------------------------------------------------------
@contextlib.contextmanager
def refused_writes(monkeypatch, folder: Path, code: int = errno.EROFS):
    """Inside the block the OS refuses every change in ``folder`` (create, write, rename, delete) with ``code``:
    a read-only folder (EROFS) or a full disk (ENOSPC); reading works. chmod when it binds (not root, EROFS),
    else the standard library's write calls raise that OSError for paths inside ``folder``."""
    folder = Path(folder).resolve()
    if not ROOT and code == errno.EROFS:
        mode = folder.stat().st_mode
        folder.chmod(stat.S_IRUSR | stat.S_IXUSR)
        try:
            yield
        finally:
            folder.chmod(mode)
        return

    def inside(path) -> bool:  # noqa: ANN001
        try:
            text = os.path.abspath(os.fsdecode(path))
        except TypeError:
            return False  # a file descriptor
        return text == str(folder) or text.startswith(str(folder) + os.sep)

    def refuse(path) -> None:  # noqa: ANN001
        raise OSError(code, os.strerror(code), os.fsdecode(path))

    def guard(original, *checked: int):  # noqa: ANN001, ANN202 - checked: positions of the paths
        def call(*args, **kwargs):
            for index in checked:
                if index < len(args) and inside(args[index]):
                    refuse(args[index])
            return original(*args, **kwargs)

        return call

    real_os_open, real_open = os.open, builtins.open

    def os_open(path, flags, *args, **kwargs):  # noqa: ANN001, ANN202
        if flags & WRITE_FLAGS and inside(path):
            refuse(path)
        return real_os_open(path, flags, *args, **kwargs)

    def open_(file, mode="r", *args, **kwargs):  # noqa: ANN001, ANN202
        if any(c in mode for c in "wax+") and inside(file):
            refuse(file)
        return real_open(file, mode, *args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(os, "open", os_open)
        patch.setattr(builtins, "open", open_)
        patch.setattr(io, "open", open_)
        for name in ("replace", "rename"):
            patch.setattr(os, name, guard(getattr(os, name), 0, 1))
        for name in ("unlink", "remove", "mkdir", "rmdir"):
            patch.setattr(os, name, guard(getattr(os, name), 0))
        yield


def one_line(response: httpx.Response) -> str:
    detail = response.json()["detail"]
    assert isinstance(detail, str) and "\n" not in detail and len(response.content) < 2_000, response.text
    assert not re.search(r"(?<![\w.])/(home|root|tmp|work|usr|var)/", detail), detail  # no folder of the machine
    return detail


class LogLines(logging.Handler):
    """Every record of the server's loggers (uvicorn's do not reach the root logger), formatted with tracebacks."""

    def __init__(self):
        super().__init__(logging.DEBUG)
        self.lines: list[str] = []
        self.setFormatter(logging.Formatter("%(name)s %(levelname)s %(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(self.format(record))

    @property
    def text(self) -> str:
        return "\n".join(self.lines)


@pytest.fixture
def server_log():
    handler = LogLines()
    loggers = [logging.getLogger(name) for name in ("", "uvicorn")]  # uvicorn's do not propagate to the root
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.addHandler(handler)
    logging.getLogger("contactnet.app.api").setLevel(logging.DEBUG)
    yield handler
    for logger, level in zip(loggers, levels, strict=True):
        logger.removeHandler(handler)
        logger.setLevel(level)
    logging.getLogger("contactnet.app.api").setLevel(logging.NOTSET)


# ---- the live tool ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def live(tmp_path_factory):
    with served_flat_tool(tmp_path_factory.mktemp("data")) as live:
        yield live


@pytest.fixture(scope="module")
def app(live):
    return live[0]


@pytest.fixture(scope="module")
def client(live):
    with httpx.Client(base_url=f"http://127.0.0.1:{live[1]}", timeout=120) as client:
        yield client


@pytest.fixture
def recordings(app):
    folder = app.recordings.directory
    for path in folder.iterdir():
        path.unlink()
    return folder


def start_recording(client, app, frames: int = 3) -> str:
    response = client.post("/api/recordings/start", json={"label": "refused"})
    assert response.status_code == 200, response.text
    wait_for(lambda: app.recorder.status()["frames"] >= frames, timeout=60, what="frames recorded")
    return response.json()["name"]


@pytest.mark.parametrize("code, status", [(errno.EROFS, 500), (errno.ENOSPC, 507)])
def test_a_refused_stop_keeps_the_recording_and_a_later_stop_saves_it(client, app, recordings, monkeypatch,
                                                                      server_log, code, status):
    name = start_recording(client, app)
    with refused_writes(monkeypatch, recordings, code):
        refused = client.post("/api/recordings/stop")
        if code == errno.EROFS and not ROOT:
            status = 500  # chmod: EACCES, also a 500
        assert refused.status_code == status, refused.text
        detail = one_line(refused)
        assert name in detail and "kept" in detail and "stop again" in detail
        if code == errno.ENOSPC:
            assert "disk is full" in detail
        kept = client.get("/api/recordings/status").json()
        assert kept["recording"] and kept["name"] == name and kept["frames"] >= 3 and kept["save_error"]
        again = client.post("/api/recordings/start", json={})  # the unsaved one first
        assert again.status_code == 409 and name in one_line(again)
        assert client.post("/api/recordings/stop").status_code == status  # still refused, still kept
        assert app.recorder.recording
    saved = client.post("/api/recordings/stop")  # the folder can be written again
    assert saved.status_code == 200, saved.text
    entry = saved.json()
    assert entry["name"] == name and entry["frames"] == kept["frames"]
    assert read_recording((recordings / name).read_bytes()).duration_s > 0.1
    assert not client.get("/api/recordings/status").json()["recording"]
    assert sorted(p.name for p in recordings.iterdir()) == [name, f"{name}.json", f"{name}.track.json"]  # no journal
    assert "Traceback" not in server_log.text


def test_refused_terrain_saves_renames_titles_and_deletions_are_one_line_json(client, app, recordings, monkeypatch,
                                                                             server_log):
    terrains = app.terrains.store.directory
    stones = json.loads((terrains_dir() / "stepping_stones.json").read_bytes())
    (recordings / "a.viser").write_bytes(b"not really a recording")
    before = sorted(p.name for p in recordings.iterdir())
    with refused_writes(monkeypatch, terrains), refused_writes(monkeypatch, recordings):
        put = client.put("/api/terrains/mine", json=stones)
        assert put.status_code == 500 and "mine.json" in one_line(put), put.text
        for response in (
            client.patch("/api/recordings/a.viser", json={"name": "b"}),
            client.patch("/api/recordings/a.viser", json={"title": "A title"}),
            client.delete("/api/recordings/a.viser"),
        ):
            assert response.status_code == 500, response.text
            assert "a.viser" in one_line(response)
    assert sorted(p.name for p in recordings.iterdir()) == before  # nothing changed
    assert not (terrains / "mine.json").exists()
    put = client.put("/api/terrains/mine", json=stones)
    assert put.status_code == 200 and put.json() == {"name": "mine", "path": "mine.json"}  # no machine folder
    assert client.patch("/api/recordings/a.viser", json={"name": "b"}).status_code == 200
    assert client.delete("/api/recordings/b.viser").status_code == 204
    text = server_log.text
    assert "Traceback" not in text and "mine.json" in text  # one warning line per refusal


def test_the_refusals_are_declared(client):
    paths = client.get("/openapi.json").json()["paths"]
    for path, method in (("/api/recordings/stop", "post"), ("/api/recordings/{name}", "patch"),
                         ("/api/recordings/{name}", "delete"), ("/api/terrains/{name}", "put")):
        declared = paths[path][method]["responses"]
        assert {"500", "507"} <= set(declared), (path, method)
        assert declared["507"]["content"]["application/json"]["schema"]["$ref"].endswith("/Problem")


def test_names_with_control_characters_match_nothing(client, app, recordings):
    (recordings / "x.viser").write_bytes(b"0123456789abcdef")
    assert client.get("/api/recordings/x.viser").status_code == 200
    for suffix in ("%0A", "%0D", "%00", "%09", "%0D%0A"):
        for method, path in (("GET", f"/api/recordings/x.viser{suffix}"), ("GET", f"/api/recordings/x.viser/html{suffix}"),
                             ("DELETE", f"/api/recordings/x.viser{suffix}"), ("GET", f"/api/terrains/flat{suffix}"),
                             ("GET", f"/api/state{suffix}")):
            response = client.request(method, path)
            assert response.status_code in (404, 405), (method, path, response.status_code)
            assert response.headers["content-type"] == "application/json"
    assert (recordings / "x.viser").is_file()


def test_a_client_that_hangs_up_mid_body_logs_nothing(live, server_log):
    app, port = live
    hangups = 30
    requests = [
        b"PUT /api/terrains/gone HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
        b"Content-Length: 5000\r\n\r\n{\"name\": \"gone\", ",
        b"POST /api/command HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: application/json\r\n"
        b"Content-Length: 500\r\n\r\n{\"vx\": ",
    ]
    for k in range(hangups):
        with socket.create_connection(("127.0.0.1", port)) as sock:
            sock.sendall(requests[k % 2])
    def handled() -> int:  # the one debug line each, or uvicorn's traceback (before the fix)
        text = server_log.text
        return text.count("hung up") + text.count("Exception in ASGI application")

    wait_for(lambda: handled() >= hangups, timeout=60, what="the hang-ups to be handled")
    lines = server_log.lines
    assert "Traceback" not in server_log.text and "ClientDisconnect" not in server_log.text
    assert not [line for line in lines if " ERROR " in line]
    assert all(len(line) < 200 for line in lines if "hung up" in line)
    assert httpx.get(f"http://127.0.0.1:{port}/api/recordings/status").status_code == 200


# ---- the journal of a recording in progress --------------------------------------------------------------------
def feed_frames(recorder: LiveRecorder, seconds: float) -> int:
    """Feed the recorder views of a plain walking loop for ``seconds`` of simulated time; its frames."""
    from app.live.view import ViewTracker
    from app.recordings.recorder import view_of
    from contactnet.locomotion import Locomotion
    from contactnet.motion.gait import WALK
    from contactnet.planning.heuristic import HeuristicPlanner
    from contactnet.robots import load_robot
    from contactnet.terrain import resolve

    robot, terrain = load_robot("solo12"), resolve("flat")
    with Locomotion(robot, terrain, WALK, HeuristicPlanner(WALK), vel_cmd_xy=(0.1, 0.0)) as loco:
        tracker = ViewTracker(robot, terrain, WALK)
        while loco.t_s < seconds:
            loco.advance(10)
            recorder.feed(view_of(loco, tracker))
    return recorder.status()["frames"]


@pytest.fixture
def every_frame_journaled(monkeypatch):
    monkeypatch.setattr("app.recordings.live_recorder.JOURNAL_PERIOD_S", 0.0)


def test_a_journal_left_by_a_crash_becomes_a_recording_at_the_next_start(tmp_path, every_frame_journaled):
    recorder = LiveRecorder(RecordingStore(tmp_path))
    name = recorder.start("crash", title="Before the crash")
    frames = feed_frames(recorder, 0.6)
    recorder.close()  # what a crash leaves: the journal, closed, and no recording
    path = journal.journal_path(tmp_path, name)
    assert path.is_file() and not (tmp_path / name).exists()
    with path.open("ab") as handle:  # the crash cut the last record short
        handle.write(b"\x00\x10\x00\x00\x12\x34\x56\x78partial record")
    store = RecordingStore(tmp_path)  # the next start
    assert store.recovered == [name] and not path.exists()
    info = store.info(name)
    assert info.meta.title == "Before the crash" and info.meta.result == journal.RECOVERED
    assert info.meta.frames == frames >= 6
    contents = read_recording((tmp_path / name).read_bytes())
    assert contents.duration_s == pytest.approx(info.meta.duration_s, abs=1e-3) and contents.duration_s > 0.4
    assert {"/status/text", "/status/gait"} <= contents.node_names
    assert RecordingStore(tmp_path).recovered == []  # once


def test_a_journal_in_use_or_already_saved_is_not_recovered(tmp_path, every_frame_journaled):
    recorder = LiveRecorder(RecordingStore(tmp_path))
    name = recorder.start()
    feed_frames(recorder, 0.3)
    path = journal.journal_path(tmp_path, name)
    assert RecordingStore(tmp_path).recovered == [] and path.is_file()  # another tool on the folder, recording
    copy = path.read_bytes()
    recorder.stop()
    assert not path.exists()
    path.write_bytes(copy)  # a crash between the save and the journal's removal
    assert RecordingStore(tmp_path).recovered == [] and not path.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [name, f"{name}.json", f"{name}.track.json"]


@pytest.mark.slow
def test_a_killed_tool_keeps_its_recording_but_the_last_seconds(tmp_path):
    script = f"""
import sys, time
sys.path.insert(0, {str(REPO / "tests")!r})
import app.recordings.live_recorder as recorder_module
from app.recordings.live_recorder import LiveRecorder
from app.recordings.recorder import RecordingStore
from test_write_failures import feed_frames
recorder_module.JOURNAL_PERIOD_S = 0.0
recorder = LiveRecorder(RecordingStore(sys.argv[1]))
name = recorder.start("killed", title="Killed")
frames = feed_frames(recorder, 1.0)
print(name, frames, flush=True)
time.sleep(600)
"""
    process = subprocess.Popen([sys.executable, "-c", script, str(tmp_path)], cwd=REPO, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    try:
        line = process.stdout.readline()
        assert line, process.communicate(timeout=60)[1]
        name, frames = line.split()
        process.send_signal(signal.SIGKILL)
        process.wait(60)
    finally:
        if process.poll() is None:
            process.kill()
        process.communicate()
    assert not (tmp_path / name).exists() and journal.journal_path(tmp_path, name).is_file()
    store = RecordingStore(tmp_path)
    assert store.recovered == [name]
    meta = read_meta(tmp_path / name).meta
    assert meta.title == "Killed" and meta.frames == int(frames) and meta.duration_s > 0.8
    assert read_recording((tmp_path / name).read_bytes()).duration_s > 0.8


def test_a_journal_that_cannot_be_written_is_said_and_the_recording_still_saves(tmp_path, monkeypatch,
                                                                                 every_frame_journaled):
    recorder = LiveRecorder(RecordingStore(tmp_path))
    with refused_writes(monkeypatch, tmp_path, errno.ENOSPC):
        name = recorder.start()
        feed_frames(recorder, 0.3)
        status = recorder.status()
        assert status["recording"] and "journal" in status["save_error"] and "crash" in status["save_error"]
        with pytest.raises(RecordingNotSaved, match="disk is full") as refused:
            recorder.stop()
        assert refused.value.errno == errno.ENOSPC and recorder.recording
    assert "disk is full" in recorder.status()["save_error"]
    server = quiet_viser_server()  # the panel's Stop button says so, and stays a Stop button
    try:
        panel = RecordingPanel(server.gui, recorder)
        panel.refresh(None)
        assert panel.record_info.content.startswith(f"**not saved** {name}: ") and "again" in panel.record_info.content
        assert panel.record_button.label == "Stop recording"
    finally:
        stop_quietly(server)
    info = recorder.stop()
    assert info.name == name and sorted(p.name for p in tmp_path.iterdir()) == [
        name, f"{name}.json", f"{name}.track.json"]


def test_at_shut_down_a_refused_recording_goes_elsewhere(tmp_path, monkeypatch):
    folder, elsewhere = tmp_path / "recordings", tmp_path / "elsewhere"
    folder.mkdir()
    recorder = LiveRecorder(RecordingStore(folder))
    with refused_writes(monkeypatch, folder):  # read-only all along: no journal either
        name = recorder.start()
        feed_frames(recorder, 0.3)
        note = recorder.save_in_progress(fallback=elsewhere)
    assert note.startswith(f"saved the recording in progress: {name} in {elsewhere}"), note
    assert "refused" in note and not recorder.recording
    assert read_recording((elsewhere / name).read_bytes()).duration_s > 0.1
    assert list(folder.iterdir()) == []  # its journal gone with it: not recovered twice


def test_at_shut_down_a_recording_refused_everywhere_keeps_its_journal(tmp_path, monkeypatch, every_frame_journaled):
    folder = tmp_path / "recordings"
    folder.mkdir()
    recorder = LiveRecorder(RecordingStore(folder))
    name = recorder.start()
    feed_frames(recorder, 0.3)
    with refused_writes(monkeypatch, tmp_path, errno.ENOSPC):  # the journal's folder too, from now on
        note = recorder.save_in_progress(fallback=tmp_path / "elsewhere")
    recorder.close()
    assert note.startswith(f"could not save the recording in progress {name}") and "next start" in note, note
    assert RecordingStore(folder).recovered == [name]


# ---- temporary files of killed writes ---------------------------------------------------------------------------
def test_a_killed_write_leaves_a_temporary_file_that_the_next_start_removes(tmp_path):
    (tmp_path / "recordings").mkdir()
    (tmp_path / "terrains").mkdir()
    for folder, name in (("recordings", "run.viser"), ("terrains", "mine.json")):
        script = (f"import os, signal\nfrom contactnet.atomic import atomic_open\n"
                  f"with atomic_open({str(tmp_path / folder / name)!r}) as handle:\n"
                  f"    handle.write(b'half a file')\n    handle.flush()\n    os.kill(os.getpid(), signal.SIGKILL)\n")
        assert subprocess.run([sys.executable, "-c", script], cwd=REPO).returncode == -signal.SIGKILL
    left = [p for p in tmp_path.rglob(".*.tmp")]
    assert sorted(p.parent.name for p in left) == ["recordings", "terrains"] and not list(tmp_path.rglob("*.viser"))
    fresh = tmp_path / "recordings" / ".other.viser.abcd1234.tmp"  # a write in progress: left alone
    fresh.write_bytes(b"")
    mine = tmp_path / "recordings" / "notes.tmp"  # not ours
    mine.write_bytes(b"")
    old = time.time() - STALE_TEMPORARY_S - 10
    for path in left:
        os.utime(path, (old, old))
    RecordingStore(tmp_path / "recordings")
    TerrainLibrary(tmp_path / "terrains")
    assert not any(p.exists() for p in left) and fresh.exists() and mine.exists()


def test_remove_stale_temporaries_never_raises(tmp_path):
    assert remove_stale_temporaries(tmp_path / "missing") == []
    with atomic_open(tmp_path / "x.json", "w") as handle:
        handle.write("{}")
    assert remove_stale_temporaries(tmp_path, older_than_s=0.0) == [] and (tmp_path / "x.json").read_text() == "{}"
