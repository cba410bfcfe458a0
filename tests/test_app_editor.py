"""The terrain editor's app side (app/live/editor.py): terrain files in a folder and uploads.

The pure edit operations it re-exports are tested in test_terrain_edits.py.
"""

from __future__ import annotations

import json

import pytest

from app.live import editor
from app.live.editor import EditError, ShippedTerrainError, TerrainStore
from contactnet.terrain import Terrain, edits, stepping_stones

pytestmark = pytest.mark.app  # the web tool: `pytest -m "not app"` skips these


@pytest.fixture
def stones() -> dict:
    return stepping_stones().to_dict()


def area(data: dict) -> float:
    return Terrain.from_dict(data).steppable.area


def test_the_app_re_exports_the_pure_edits():
    """app/live/editing.py, app/viewer/gui.py and app/api/server.py use these through app.live.editor."""
    for name in edits.__all__:
        assert getattr(editor, name) is getattr(edits, name), name


def test_store_round_trip_and_shipped_files(tmp_path, stones):
    store = TerrainStore(tmp_path)
    punched = editor.punch_hole(stones, (0.12, 0.12))
    path = store.save(punched, "holey")
    assert path == tmp_path / "holey.json" and store.names() == ["holey"]
    loaded = store.load("holey")
    assert loaded.name == "holey"
    assert loaded.steppable.symmetric_difference(Terrain.from_dict(punched).steppable).area < 1e-12
    store.save(stones, "holey")  # a user's own file is replaced
    assert store.load("holey").steppable.area == pytest.approx(area(stones))
    store.save(stones, "stepping_stones")  # a shipped name may be written when absent ...
    with pytest.raises(ShippedTerrainError, match="confirm"):  # ... but never overwritten unasked
        store.save(punched, "stepping_stones")
    store.save(punched, "stepping_stones", overwrite=True)
    with pytest.raises(EditError):
        store.save(stones, "../outside")
    assert not (tmp_path.parent / "outside.json").exists()
    with pytest.raises(FileNotFoundError):
        store.load("missing")


@pytest.mark.parametrize(
    "content, message",
    [
        (b"{", "not valid JSON"),
        (b"\xff\xfe", "not UTF-8"),
        (b"[1, 2]", "JSON object"),
        (b'{"name": "x", "start": [0, 0], "goal_x": 1, "regions": []}', "regions"),
        (
            b'{"name": "x", "start": [0, 0], "goal_x": 1, "regions": [{"shape": "circle", "center": [0, 0], '
            b'"radius": NaN}]}',
            "radius",
        ),
        (b" " * (editor.MAX_UPLOAD_BYTES + 1), "limit"),
    ],
)
def test_bad_uploads_are_refused_with_a_message(content, message):
    with pytest.raises(EditError, match=message):
        editor.parse_upload(content, source="upload.json")


def test_good_upload(stones):
    assert editor.parse_upload(json.dumps(stones).encode()) == stones


def test_the_service_says_what_a_save_would_replace(tmp_path, stones):
    """The editor asks before a save that replaces something: the user's own file, or a shipped name."""
    from app.live.editing import TerrainService
    from app.live.terrain_files import TerrainLibrary

    library = TerrainLibrary(tmp_path / "user", shipped_dir=tmp_path / "shipped")
    TerrainStore(tmp_path / "shipped").save(stones, "stepping_stones")
    service = TerrainService(session=None, store=library)
    assert service.exists("brand_new") is None
    assert service.exists("stepping_stones") == "shipped"
    library.save(stones, "mine")
    assert service.exists("mine") == "yours"
    with pytest.raises(EditError):
        service.exists("../outside")


def test_a_bigger_robot_gets_the_shipped_scenes_at_its_size_and_your_files_as_they_are(tmp_path, stones):
    """serve --robot go2: the shipped stones, the random field and the generators at Go2's size (1.313 x Solo12's
    lengths), a file of the user's own unscaled, stone_grid (absolute sizes) unscaled."""
    from app.live.commands import SetTerrain
    from app.live.editing import TerrainService
    from app.live.terrain_files import TerrainLibrary
    from contactnet.robots import load_robot
    from contactnet.terrain import by_name, random_field, terrains_dir

    class Session:  # the live session's side of a load: the SetTerrain command it is given
        view = None

        def __init__(self):
            self.terrains = []

        def call(self, command, timeout=None):  # noqa: ANN001, ANN202
            assert isinstance(command, SetTerrain)
            self.terrains.append(command.terrain)

    scale = load_robot("go2").description.size_scale
    assert scale == pytest.approx(1.313, abs=0.002)
    session = Session()
    service = TerrainService(session, TerrainLibrary(tmp_path / "user"), scale=scale)
    service.load("stepping_stones")
    solo = Terrain.load(terrains_dir() / "stepping_stones.json")
    assert session.terrains[-1].goal_x == pytest.approx(scale * solo.goal_x)
    service.load("random", removed=80, seed=3)
    assert session.terrains[-1].goal_x == pytest.approx(scale * random_field(80, 3).goal_x)
    service.load("stone_grid")
    assert session.terrains[-1].goal_x == pytest.approx(by_name("stone_grid").goal_x)
    TerrainLibrary(tmp_path / "user").save(stones, "mine")
    service.load("mine")
    assert session.terrains[-1].goal_x == pytest.approx(stones["goal_x"])


def test_an_imported_upload_names_the_file_on_a_bad_one(monkeypatch):
    import io

    import numpy as np

    from app.live import terrain_files

    buffer = io.BytesIO()
    np.save(buffer, np.zeros((30, 100)))
    terrain, report = terrain_files.import_upload(buffer.getvalue(), "my field.npy")
    assert terrain.name == "imported" and report.tops == 1  # "my field" is not a terrain name: a safe default
    with pytest.raises(EditError, match=r"rocks.tif: a height map \(.npy, .png\) or a mesh"):
        terrain_files.import_upload(b"", "rocks.tif")
    with pytest.raises(EditError, match="^broken.npy: not a numpy array file"):
        terrain_files.import_upload(b"garbage", "broken.npy")
    monkeypatch.setattr(terrain_files, "MAX_IMPORT_BYTES", 10)
    with pytest.raises(EditError, match="at most 0 MB"):
        terrain_files.import_upload(buffer.getvalue(), "big.npy")
