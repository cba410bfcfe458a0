"""A height map or mesh uploaded in the browser: previewed, then used or discarded (issue 30, item 4).

The upload is segmented off the event loop (`app.live.terrain_files.import_upload`: the defaults of
`contactnet terrain import`) and nothing changes on the robot yet: the panel shows what was kept as steppable
(the top view of `contactnet terrain render`, sloped tops shaded by their height) and the import's report
(tops, how many sloped, the steppable area, every dropped part as a line). "Use imported terrain" puts the
robot on it; "Discard" forgets it. A second upload replaces a preview not yet used.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import viser

from app.live.editing import TerrainService
from app.live.terrain_files import import_upload
from contactnet.terrain import Terrain
from contactnet.terrain.render import render_rgb

#: The preview's resolution (dots per inch of the top view's figure): about 600 px across for a 4 m terrain.
PREVIEW_DPI = 60
#: An empty image for the preview's slot before the first upload (viser needs one to create it).
_BLANK = np.full((4, 4, 3), 255, dtype=np.uint8)


class ImportPreview:
    """The "Upload height map or mesh" button, its preview (image and report) and the Use / Discard buttons."""

    def __init__(self, gui: viser.GuiApi, terrains: TerrainService, run: Callable[[Any, str, Callable], Any],
                 say: Callable[[str], None]):
        self.terrains = terrains
        self._run = run  # the editor's error handling: a refused file is one line in a toast
        self._say = say
        self._pending: tuple[Terrain, str] | None = None  # the terrain previewed and the file it came from
        self.upload = gui.add_upload_button(
            "Upload height map or mesh", icon=viser.Icon.UPLOAD, mime_type=".npy,.png,.stl,.obj,.ply",
            hint="a height map (.npy in metres, 1 cm per pixel; .png) or a mesh (.stl, .obj, .ply, metres, z up): "
                 "its steppable tops (flat and sloped up to 21.8 degrees) are previewed before you use them "
                 "(contactnet terrain import for other settings)",
        )
        self.report = gui.add_markdown("", visible=False)
        self.image = gui.add_image(_BLANK, label="Kept as steppable", visible=False)
        self.use_button = gui.add_button("Use imported terrain", icon=viser.Icon.CHECK, visible=False,
                                         hint="put the robot on the previewed terrain (it restarts)")
        self.discard_button = gui.add_button("Discard import", icon=viser.Icon.X, visible=False)
        self.upload.on_upload(self._on_upload)
        self.use_button.on_click(self._on_use)
        self.discard_button.on_click(lambda event: self._show(None))

    @property
    def pending(self) -> Terrain | None:
        """The terrain previewed and not yet used or discarded."""
        return self._pending[0] if self._pending else None

    def _show(self, preview: tuple[Terrain, str, list[str], np.ndarray] | None) -> None:
        """Show a preview (or close it); ``pending`` changes last, once the panel shows what it says."""
        if preview is not None:
            terrain, filename, lines, image = preview
            self.image.image = image
            self.report.content = f"**{filename}**: " + "  \n".join(lines)
        for handle in (self.report, self.image, self.use_button, self.discard_button):
            handle.visible = preview is not None
        self._pending = None if preview is None else (terrain, filename)

    def _on_upload(self, event) -> None:  # noqa: ANN001 - a viser GuiEvent
        uploaded = self.upload.value

        def preview() -> None:
            terrain, report = import_upload(uploaded.content, uploaded.name)
            self._show((terrain, uploaded.name, report.lines(), render_rgb(terrain, dpi=PREVIEW_DPI)))
            self._say(f"Previewing **{uploaded.name}**: press Use imported terrain to walk it.")

        self._run(event.client, "Import terrain", preview)

    def _on_use(self, event) -> None:  # noqa: ANN001 - a viser GuiEvent
        if self._pending is None:
            return
        terrain, filename = self._pending

        def use() -> None:
            self.terrains.load_terrain(terrain, label=f"{terrain.name} (imported)")
            self._show(None)
            self._say(f"Walking **{terrain.name}**, imported from {filename}.")

        self._run(event.client, "Use imported terrain", use)
