"""The roll allowance (issue 27): a ball foot rolls forward while it stands, so a landing keeps room ahead.

Traced on the walk's falls with a robot that is not the model (random field, 80 squares removed, mass x 1.2 and
friction 0.5: 12 falls in 200 trials, all a front foot in a gap): the foot landed inside its square, closer to the
edge ahead than a foot radius, and stood there for seconds while the body passed over it. A ball under a shin that
turns rolls: its contact point moved 1.3 cm forward over one stance (up to 5 cm with friction 0.5), until the
ball stood beyond the edge, held by it; at lift-off it dropped into the hole. The roll over a stance is about the
foot radius times the shin's turn, (stance travel) / (leg length): for Solo12's walk 16 mm x (20 cm / 32 cm),
1.0 cm; tangential forces stayed at 5 % of the normal ones (rolling, not slip).

So the planner asks for more than the landing point's margin where it can: once the network's ranking has given
the first safe action, the same legs' first cells in the ranking whose point ``allowance_radii`` foot radii
further on along the commanded velocity (world frame) is safe too replace its cells (``Terrain.is_safe`` of both
points with the plain margin; the planner's compiled walk makes the second lookup in the same raster, in the
same call as the first walk, ``ranking.OneLevelWalk.first_safe_with_room``; on terrain with heights the walk with
the height checks is asked again with the actions lacking the room ranked last,
``ContactNetPlanner._with_room_on_heights``; only with ``RollConfig(heights=True)``, off by default). The network's
choice of legs stands: asking every action for the room first (a first version) made the walk move other legs
rather than step onto narrow bars, and `narrow_map` fell from 84 to 57 / 100. Where those legs have no cell with
room (3 cm bars) the plain choice stands. A command below ``min_speed_m_s`` (standing, turning on the spot) has no
direction and no allowance. ``ContactNetPlanner(roll=None)`` turns it off.

Where the chosen cells have no room (a bar narrower than the grid's 5 cm spacing), the first step's landing point
slides back against the command, on its top, to the first point that has it, at most a foot radius
(``slide_back``, ``RollConfig.slide_back_radii``), keeping half a foot radius of safe ground behind it
(``slide_behind_radii``): traced on ``narrow_map`` (bars 3 cm wide, last gap 24 cm, seed 1), a front foot landed
8 mm from the front edge of its bar and rolled forward 9 mm in the 2.5 s it stood while the body went on, into the
gap; a slide with no room behind put a hind foot 10 mm in from the back edge of a 3 cm bar, and it clipped that edge
coming down. The network's choice of legs and cells stands: only the landing point moves, within the cell's top.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning.ranking import LANDING_MARGIN_RADII, PlannedStep, put_back
from contactnet.terrain import Terrain


@dataclass(frozen=True)
class RollConfig:
    """How much room ahead a landing keeps for its foot's roll."""

    allowance_radii: float = 0.75  # the point this many foot radii ahead must be safe (12 mm for Solo12)
    #: a chosen landing point still without the room slides back (against the command) up to this many foot radii,
    #: on safe ground, to the first point with it (``slide_back``); 0: it stays
    slide_back_radii: float = 1.0
    #: ... keeping this many foot radii behind it on safe ground too (a foot landing just past an edge clips it)
    slide_behind_radii: float = 0.5
    min_speed_m_s: float = 0.005  # below this command speed: no direction, no allowance
    #: on terrain with tops at several heights too (off: measured, it helped MuJoCo's walk on the raised stones
    #: and hurt PyBullet's, docs/results.md "The room for the roll on terrain with heights")
    heights: bool = False
    #: a plan that would stand first lifts a foot standing on a top too short for its roll, closer than the landing
    #: margin to the edge ahead, and puts it back in (``reseat_step``)
    reseat: bool = True

    def __post_init__(self) -> None:
        for name in ("allowance_radii", "min_speed_m_s", "slide_back_radii", "slide_behind_radii"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"RollConfig.{name} must be a finite number >= 0, got {value!r}")


#: The planners' default: the allowance on (``ContactNetPlanner(roll=None)`` turns it off).
DEFAULT_ROLL = RollConfig()


def roll_ahead_xy(foot_radius_m: float, cmd_world_xy: tuple[float, float] | list[float],
                  config: RollConfig | None) -> tuple[float, float] | None:
    """The room ahead (world x, y, metres) along the commanded velocity ``cmd_world_xy`` (m/s, world), None when
    there is none to ask for (``config`` None, no allowance, or a command too slow to have a direction). Runs in
    every plan: Python floats."""
    if config is None or config.allowance_radii == 0.0:
        return None
    vx, vy = float(cmd_world_xy[0]), float(cmd_world_xy[1])
    speed = math.hypot(vx, vy)
    if speed < config.min_speed_m_s:
        return None
    ahead = config.allowance_radii * foot_radius_m / speed
    return ahead * vx, ahead * vy


def roll_ahead_heading(foot_radius_m: float, cmd_xy: np.ndarray, yaw_rad: float,
                       config: RollConfig | None) -> tuple[float, float] | None:
    """``roll_ahead_xy`` of a command in the heading frame (``cmd_xy``, m/s) turned into the world by ``yaw_rad`` with
    ``frames.rotate_xy``'s float operations on scalars (the same numbers, bit for bit: ``tests/test_roll.py``),
    without that function's arrays (about 5 us, in every plan)."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    x, y = cmd_xy[0], cmd_xy[1]
    return roll_ahead_xy(foot_radius_m, (c * x - s * y, s * x + c * y), config)


#: The steps (m) in which ``slide_back`` looks for the room, and how far along the command (foot radii) ``lacks_room``
#: looks for a point with it.
SLIDE_STEP_M = 0.001
SHORT_TOP_REACH_RADII = 2.0


def _unit(ahead_xy: tuple[float, float]) -> tuple[float, float]:
    """The direction of ``ahead_xy`` (not zero)."""
    length = math.hypot(*ahead_xy)
    return ahead_xy[0] / length, ahead_xy[1] / length


def slide_back(step: PlannedStep, ahead_xy: tuple[float, float] | None, covers_xy: Callable[[float, float], bool],
               max_slide_m: float, behind_m: float) -> PlannedStep:
    """``step`` with each landing point that lacks the room ``ahead_xy`` (world, metres: the point that far on is not
    covered, ``covers_xy`` the safe region's test with the landing margin) moved back against ``ahead_xy``, in steps
    of ``SLIDE_STEP_M`` up to ``max_slide_m``, as long as the point ``behind_m`` behind it is covered too: to the
    first point with the room, else as far as it went (more room than it had). The ranking chose the cell; this
    only moves its landing point on the top it is on: on a bar narrower than the grid's spacing no cell may have the
    room, and a foot that lands at the margin from the edge ahead rolls over it while it stands; the room behind
    keeps a foot coming from behind from landing just past the edge it passes (it clipped it, traced)."""
    if ahead_xy is None or not step.legs or max_slide_m <= 0.0:
        return step
    ahead_x, ahead_y = ahead_xy
    unit_x, unit_y = _unit(ahead_xy)
    moved = None
    for k, (x, y) in enumerate(step.footholds_xy_world.tolist()):
        if covers_xy(x + ahead_x, y + ahead_y):
            continue
        best = None
        for i in range(1, int(max_slide_m / SLIDE_STEP_M + 1e-9) + 1):
            px, py = x - i * SLIDE_STEP_M * unit_x, y - i * SLIDE_STEP_M * unit_y
            if not (covers_xy(px, py) and covers_xy(px - behind_m * unit_x, py - behind_m * unit_y)):
                break
            best = px, py
            if covers_xy(px + ahead_x, py + ahead_y):
                break
        if best is not None:
            moved = np.array(step.footholds_xy_world, dtype=float) if moved is None else moved
            moved[k] = best
    return step if moved is None else dataclasses.replace(step, footholds_xy_world=moved)


def lacks_room(covers_xy: Callable[[float, float], bool], x: float, y: float, ahead_xy: tuple[float, float],
               behind_m: float, reach_m: float) -> bool:
    """Whether the top at (x, y) is too short along ``ahead_xy`` for the roll: no point within ``reach_m`` of it along
    the command, in steps of ``SLIDE_STEP_M``, is covered with the point ``ahead_xy`` further on and the point
    ``behind_m`` back covered too (``covers_xy``: the safe region's test with the landing margin). A bar narrower
    than the foot ball is such a top; a square of the random field is not, except for a point closer than the margin
    to one of its edges along the command (no point on that line is covered)."""
    ahead_x, ahead_y = ahead_xy
    unit_x, unit_y = _unit(ahead_xy)
    count = int(reach_m / SLIDE_STEP_M + 1e-9)
    for i in range(-count, count + 1):
        px, py = x + i * SLIDE_STEP_M * unit_x, y + i * SLIDE_STEP_M * unit_y
        if (covers_xy(px, py) and covers_xy(px + ahead_x, py + ahead_y)
                and covers_xy(px - behind_m * unit_x, py - behind_m * unit_y)):
            return False
    return True


def short_top_test(terrain: Terrain, cmd_xy: np.ndarray, yaw_rad: float, foot_radius_m: float,
                   config: RollConfig | None = DEFAULT_ROLL) -> Callable[[float, float], bool] | None:
    """``lacks_room`` at a point, with the room of ``config`` along the command (``cmd_xy`` in the heading frame,
    ``yaw_rad``), the planner's default margin (half a foot radius), half a radius behind and a reach of two radii
    (as the re-seat asks it): the test the swing asks of its ends (``motion.swing.swing_past_holes``); None without
    a command or a config."""
    ahead = roll_ahead_heading(foot_radius_m, cmd_xy, yaw_rad, config)
    if ahead is None:
        return None
    covers = terrain.safe_locator(LANDING_MARGIN_RADII * foot_radius_m).covers_xy
    behind_m, reach_m = config.slide_behind_radii * foot_radius_m, SHORT_TOP_REACH_RADII * foot_radius_m
    return lambda x, y: lacks_room(covers, x, y, ahead, behind_m, reach_m)


def reseat_step(gait: GaitSpec, first: PlannedStep, feet_xy_world: np.ndarray, terrain: Terrain, margin_m: float,
                ahead_xy: tuple[float, float] | None, behind_m: float, reach_m: float) -> PlannedStep | None:
    """Instead of ``first``, a plan's first step that stands, the step in place of the swing group of a standing foot
    on a top too short for its roll (``lacks_room``) that has rolled closer than ``margin_m`` to the edge ahead
    (``ahead_xy``: the point that far on is not safe either), put back in (``ranking.put_back``; the slide then moves
    it back further where it can); None: no such foot, no room on its top to put it back (it would move less than a
    quarter of the margin), a first step that moves legs, no direction. Traced on ``narrow_map`` (3 cm bars, last gap
    24 cm): a front foot waiting on its bar for the next one to come in reach rolled over the edge ahead while the
    planner stood five times."""
    if first.legs or ahead_xy is None:
        return None
    covers, on_top = terrain.safe_locator(margin_m).covers_xy, terrain.safe_locator(0.0).covers_xy
    feet = np.asarray(feet_xy_world, dtype=float)[:, :2]
    for leg, (x, y) in enumerate(feet.tolist()):
        if (on_top(x, y) and not covers(x, y) and not covers(x + ahead_xy[0], y + ahead_xy[1])
                and lacks_room(covers, x, y, ahead_xy, behind_m, reach_m)):
            legs = next(group for group in gait.swing_groups if leg in group)
            landing = put_back(terrain, feet[list(legs)], margin_m)
            if math.dist(landing[legs.index(leg)], (x, y)) >= 0.25 * margin_m:
                return PlannedStep(legs=legs, footholds_xy_world=landing)
    return None


def first_step_with_room(step: PlannedStep, gait: GaitSpec, feet_xy_world: np.ndarray, terrain: Terrain,
                         cmd_xy: np.ndarray, yaw_rad: float, margin_m: float, foot_radius_m: float,
                         config: RollConfig | None, may_reseat: bool) -> PlannedStep:
    """A plan's first step on terrain of one level after the roll's rules: a foot rolled to the edge of a top too short
    for it goes first (``reseat_step``, when ``config.reseat`` and ``may_reseat``), and a landing without the room
    slides back (``slide_back``); ``step`` itself when neither applies (``config`` None: no roll rules)."""
    ahead = roll_ahead_heading(foot_radius_m, cmd_xy, yaw_rad, config)
    if ahead is None:
        return step
    behind_m = config.slide_behind_radii * foot_radius_m
    if config.reseat and may_reseat:
        step = reseat_step(gait, step, feet_xy_world, terrain, margin_m, ahead, behind_m,
                           SHORT_TOP_REACH_RADII * foot_radius_m) or step
    if config.slide_back_radii > 0.0:
        step = slide_back(step, ahead, terrain.safe_locator(margin_m).covers_xy,
                          config.slide_back_radii * foot_radius_m, behind_m)
    return step


__all__ = ["DEFAULT_ROLL", "SHORT_TOP_REACH_RADII", "SLIDE_STEP_M", "RollConfig", "first_step_with_room", "lacks_room",
           "reseat_step", "roll_ahead_heading", "roll_ahead_xy", "short_top_test", "slide_back"]
