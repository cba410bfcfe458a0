"""The walk down the ranking with the height checks, the plain way (numpy and shapely), for sloped tops.

The compiled walk (``contactnet.planning.heights_walk``, ``HeightsWalk``) reads rasters of flat tops: a top is one
height per raster code. A terrain with a sloped top (``Terrain.sloped``) has none of those rasters
(``Terrain.height_locator`` is None), so the planner walks its ranking here instead: the candidate grid made at once
(small tops' cells centred, ``FootholdChecker.centred``), the cells of the best few actions, then if none of them
passes of every action, asked once each of ``Terrain.is_safe`` and of ``FootholdChecker.usable`` (whose lookups
follow the planes), and the first action of the stable ascending order of
the costs whose cells all pass, with the first step's actions moving a cornered leg first
(``FootholdChecker.stance_clear``). The same definition as the compiled walk and ``tests/test_planner_fast.py``'s
reference; a few hundred microseconds to a few milliseconds a step rather than the compiled walk's tens.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from contactnet.planning.footholds import FootholdChecker
from contactnet.planning.ranking import ActionCells, LandingCheck
from contactnet.terrain import Terrain

_HEAD = 8  # actions whose cells are checked first


class PlainHeightsWalk:
    """``HeightsWalk``'s interface (``start``, ``first_usable``, ``took``, ``grid``, ``check``, ``urgent``,
    ``cornered``) computed with numpy and shapely: the planner's walk on terrain with sloped tops."""

    def __init__(self, actions: ActionCells, terrain: Terrain, margin_m: float, checker: FootholdChecker,
                 hip_xy_base: np.ndarray, touchdown_s: float, lookahead_s: float = 0.0,
                 min_progress_m: float = 0.0) -> None:
        self.actions, self.terrain, self.margin_m, self.checker = actions, terrain, margin_m, checker
        self.hip_xy_base, self.touchdown_s, self.lookahead_s, self.min_progress_m = (
            np.asarray(hip_xy_base, dtype=float), touchdown_s, lookahead_s, min_progress_m)
        self.compiled = None
        self.cornered: np.ndarray | None = None
        self._feet = np.zeros((4, 2))
        self._tops = np.zeros(4)
        self._pending: tuple[int, list[list[float]], list[float]] | None = None
        self._urgent: np.ndarray | None = None

    def start(self, hips_world: np.ndarray, offsets_world: np.ndarray, bases: list[list[float]], yaw_rad: float,
              hip_bases: list[list[float]], cmd_world: list[float], feet: list[list[float]],
              forward_xy: tuple[float, float]) -> list[float]:
        """Begin a plan (``HeightsWalk.start``); the tops under the feet (``Terrain.ground_z``)."""
        self.hips_world, self.offsets_world = np.asarray(hips_world, float), np.asarray(offsets_world, float)
        self.bases, self.yaw_rad, self.hip_bases = bases, yaw_rad, hip_bases
        self.cmd_world, self.forward_xy = np.asarray(cmd_world, dtype=float), forward_xy
        self._feet = np.array(feet, dtype=float).reshape(4, 2)
        self._tops = self.terrain.ground_z(self._feet)
        self.cornered, self._pending, self._urgent = None, None, None
        return self._tops.tolist()

    def took(self, action: int | None) -> None:
        """The last step took ``action`` (the one ``first_usable`` found), None for a step that moved no foot."""
        if action is not None and self._pending is not None and self._pending[0] == action:
            _, points, tops = self._pending
            for leg, point, top in zip(self.actions.group[action], points, tops, strict=True):
                self._feet[leg] = point
                self._tops[leg] = top
        self._pending = None

    def feet_xy(self) -> np.ndarray:
        return self._feet.copy()

    def tops(self) -> np.ndarray:
        return self._tops.copy()

    def hips_at(self, step: int, after_s: float | None = None) -> Callable[[], np.ndarray]:
        """A function making the (4, 2) hips at step ``step``'s touchdown (or ``after_s`` after its start)."""
        c, s = self.forward_xy
        hips_base = self.hip_xy_base @ np.array([[c, -s], [s, c]]).T
        hip_base, cmd = np.array(self.hip_bases[step]), self.cmd_world
        after = self.touchdown_s if after_s is None else after_s
        return lambda: hip_base + (hips_base + cmd * after)

    def grid(self, step: int) -> Callable[[], np.ndarray]:
        """A function making step ``step``'s (4, cells_per_leg, 2) candidate grid, small tops' cells centred."""
        base = np.array(self.bases[step])
        checker, terrain, hips, offsets = self.checker, self.terrain, self.hips_world, self.offsets_world

        def make() -> np.ndarray:
            cells = (base + hips)[:, None, :] + offsets[None]
            return checker.centred(terrain, cells.reshape(-1, 2)).reshape(cells.shape)

        return make

    def check(self, step: int) -> LandingCheck:
        """The height checks of landing points from the state now (``FootholdChecker.usable``)."""
        feet, tops, hips, checker, terrain, yaw = self._feet.copy(), self._tops.copy(), self.hips_at(step)(), \
            self.checker, self.terrain, self.yaw_rad

        def usable(legs: np.ndarray, landing_xy: np.ndarray) -> np.ndarray:
            return checker.usable(terrain, legs, landing_xy, feet[legs], hips[legs], tops, yaw)

        return usable

    def first_usable(self, step: int, costs: np.ndarray,
                     span: tuple[int, int]) -> tuple[int, int, list[list[float]], list[float]] | None:
        """(rank, action, its landing points, the tops under them) of the first action of the stable ascending
        order of ``costs[first:stop]`` whose landing points are all safe and usable (``HeightsWalk.first_usable``)."""
        first, stop = span
        actions = self.actions
        cells = self.grid(step)().reshape(-1, 2)
        legs = actions.leg_cell_array[:, 0]
        usable = np.zeros(len(cells), dtype=bool)
        known = np.zeros(len(cells), dtype=bool)
        check = self.check(step)

        def ask(which: np.ndarray) -> None:  # the cells not asked yet: safe, then the height checks
            which = which[~known[which]]
            safe = self.terrain.is_safe(cells[which], self.margin_m)
            if safe.any():
                safe[safe] = check(legs[which[safe]], cells[which[safe]])
            usable[which], known[which] = safe, True

        order = first + np.argsort(np.asarray(costs)[first:stop], kind="stable")
        flat = actions.flat_array[order]
        if step == 0:
            self._urgent = None
            clear = self.checker.stance_clear(self.terrain, self._feet, self._tops,
                                              self.hips_at(0, self.lookahead_s)(), self.yaw_rad)
            if not clear.all():
                self.cornered = ~clear
                forward_x, forward_y = self.forward_xy
                feet = self._feet[legs]
                progress = (cells[:, 0] - feet[:, 0]) * forward_x + (cells[:, 1] - feet[:, 1]) * forward_y
                promote = (progress >= self.min_progress_m) & self.cornered[legs]
                urgent = np.logical_or.reduce(promote[flat], axis=1)
                self._urgent = np.zeros(stop - first, dtype=bool)
                self._urgent[order - first] = urgent
                order = np.concatenate([order[urgent], order[~urgent]])
                flat = actions.flat_array[order]
        ask(np.unique(flat[:_HEAD]))  # the best few actions first: usually one of them is usable
        good = usable[flat].all(axis=1)
        if not good.any():
            ask(np.unique(flat))
            good = usable[flat].all(axis=1)
            if not good.any():
                return None
        rank = int(good.argmax())
        action = int(order[rank])
        points = cells[actions.flat_array[action]]
        tops = self.terrain.height_at(points)
        self._pending = (action, points.tolist(), tops.tolist())
        return rank, action, points.tolist(), tops.tolist()

    def urgent(self, span: tuple[int, int], grid: Callable[[], np.ndarray]) -> Callable[[], np.ndarray]:
        """A function making step 0's urgent actions (bool per action of ``span``): those landing a cornered leg at
        least the least progress ahead (``HeightsWalk.urgent``)."""
        known = self._urgent
        return lambda: known if known is not None else np.zeros(span[1] - span[0], dtype=bool)


__all__ = ["PlainHeightsWalk"]
