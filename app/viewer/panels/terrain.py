"""The "Terrain" folder: put the robot on a terrain file, a shipped terrain or a random field."""

from __future__ import annotations

import viser

from app.live.editing import TerrainService
from app.live.view import LiveView
from app.viewer.panels.common import tell


class TerrainPanel:
    """A terrain picker (the store's files and 'random', with its N and seed) and a Load button."""

    def __init__(self, gui: viser.GuiApi, terrains: TerrainService, order: float = 45.0):
        self.terrains = terrains
        self._label: str | None = None
        with gui.add_folder("Terrain", order=order, expand_by_default=False):
            options = self._options()
            label = terrains.label
            self.terrain_pick = gui.add_dropdown(
                "Terrain",
                options,
                initial_value=label if label in options else options[0],
                hint="Pick, then press Load terrain",
            )
            self.removed = gui.add_number("Random: removed", 80, min=0, max=300, step=1, visible=False)
            self.seed = gui.add_number("Random: seed", 0, min=0, max=2**31 - 1, step=1, visible=False)
            self.load_button = gui.add_button("Load terrain", icon=viser.Icon.UPLOAD)

        @self.terrain_pick.on_update
        def _(event) -> None:
            random = self.terrain_pick.value == "random"
            self.removed.visible = random
            self.seed.visible = random

        @self.load_button.on_click
        def _(event) -> None:
            name = self.terrain_pick.value
            try:
                if name == "random":
                    self.terrains.load("random", removed=int(self.removed.value), seed=int(self.seed.value))
                else:
                    self.terrains.load(name)
            except Exception as exc:  # noqa: BLE001 - shown to the user
                tell(self.terrains.session, "Terrain not loaded", str(exc))

    def _options(self) -> tuple[str, ...]:
        return (*self.terrains.store.names(), "random")

    def refresh(self, view: LiveView) -> None:
        options = self._options()  # new files appear after "Save terrain" or a PUT
        if tuple(self.terrain_pick.options) != options:
            self.terrain_pick.options = options
        label = view.status.terrain  # the picker follows the session's terrain (a load, a save, REST)
        if label != self._label:
            self._label = label
            pick = "random" if label.startswith("random") else label
            if pick in options and self.terrain_pick.value != pick:
                self.terrain_pick.value = pick
