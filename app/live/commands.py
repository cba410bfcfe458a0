"""What anyone may ask of the live session: one frozen dataclass per command, and `check_command`.

Commands go through `LiveSession.submit` (a queue read by the session thread); `check_command` rejects
values the simulation must never see before they are queued. The limits are those of `app.live.settings`;
gait and planner names are those of `contactnet.registry`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from app.live.settings import PUSH_DURATION_LIMIT_S, PUSH_FORCE_LIMIT_N, SIM_SPEED_RANGE, VELOCITY_LIMIT_M_S
from contactnet import registry
from contactnet.sim.world import ENGINES
from contactnet.terrain import Terrain


class CommandConflict(RuntimeError):
    """A valid command that cannot act in the session's state now (a push while paused, ...): one line."""


#: The levels of a notice.
NOTICE_LEVELS = ("info", "warning", "error")


@dataclass(frozen=True)
class SetVelocity:
    vx: float  #: m/s, forward
    vy: float  #: m/s, left


@dataclass(frozen=True)
class NudgeVelocity:
    """Add (dvx, dvy) to the commanded velocity, clipped to the limits (keyboard shortcuts: applied in
    order by the session thread, so quick presses add up)."""

    dvx: float
    dvy: float


@dataclass(frozen=True)
class ApplyPush:
    fx: float  #: N, world frame
    fy: float  #: N, world frame
    duration_s: float


@dataclass(frozen=True)
class Reset:
    pass


@dataclass(frozen=True)
class SetPaused:
    paused: bool


@dataclass(frozen=True)
class TogglePause:
    """Pause a running session, run a paused one (the P key). At the end of a run it never starts the next one:
    paused, the loop's count-down holds (the end-of-run card stays); run again, it counts on. A session stopped
    by an error restarts."""


@dataclass(frozen=True)
class SetSpeed:
    speed: float  #: simulated seconds per wall-clock second


@dataclass(frozen=True)
class SetGait:
    gait: str


@dataclass(frozen=True)
class SetPlanner:
    planner: str


@dataclass(frozen=True)
class SetNoise:
    on: bool


@dataclass(frozen=True)
class SetSim:
    """The physics engine (``contactnet.sim.engines``: pybullet or mujoco, one that is installed): the robot restarts
    on the same terrain in it."""

    engine: str


@dataclass(frozen=True)
class SetRetarget:
    """Swing retargeting (`contactnet.planning.retarget`) on or off: a swing's landing may move during the swing when the
    measured velocity is off the command (a push). Applied at once, without a restart."""

    on: bool


@dataclass(frozen=True)
class SetObserver:
    """The disturbance observer (`contactnet.planning.observer`) on or off: a push is estimated from the body's momentum,
    cancelled by the controller and leaned into by the capture step. Applied at once, without a restart."""

    on: bool


@dataclass(frozen=True)
class SetTerrain:
    """Put the robot on a new terrain (back at its start, paused); forgets the edit history."""

    terrain: Terrain
    label: str


@dataclass(frozen=True)
class EditTerrain:
    """Apply ``edit(current terrain dict, *args)`` (an edit of `contactnet.terrain.edits`) to the session's
    terrain, remembering the old one for `UndoTerrainEdit`. The command's result is False when the edit
    changed nothing (then nothing is rebuilt)."""

    edit: Callable[..., dict[str, Any]]
    args: tuple[Any, ...] = ()


@dataclass(frozen=True)
class UndoTerrainEdit:
    """Back to the terrain before the last edit (EditError when there is none)."""


@dataclass(frozen=True)
class RedoTerrainEdit:
    """Apply again the edit the last undo took back (EditError when there is none)."""


@dataclass(frozen=True)
class ViewerConnected:
    """A browser opened the 3D view: a session waiting for its first viewer starts (after a short count-down,
    so the scene is drawn before the robot moves)."""


@dataclass(frozen=True)
class SetLoop:
    """Restart the run a few seconds after the goal or a fall (on), or stay at its end (off)."""

    on: bool


@dataclass(frozen=True)
class SetCompare:
    """Compare mode: ``planners`` = (main, other): two robots on the same terrain with the same command, both
    restarted; () turns it off."""

    planners: tuple[str, ...]


@dataclass(frozen=True)
class Notify:
    """Tell the session's users something once (a notice: the page's toasts), e.g. that a control of the 3D view
    was refused. ``level``: info, warning or error."""

    text: str
    level: str = "error"


@dataclass(frozen=True)
class RenameTerrain:
    """Call the current terrain ``label`` from now on (after it was saved under that name); no rebuild."""

    label: str


Command = (
    SetVelocity
    | NudgeVelocity
    | ApplyPush
    | Reset
    | SetPaused
    | TogglePause
    | SetSpeed
    | SetGait
    | SetPlanner
    | SetNoise
    | SetSim
    | SetRetarget
    | SetObserver
    | SetTerrain
    | EditTerrain
    | UndoTerrainEdit
    | RedoTerrainEdit
    | RenameTerrain
    | Notify
    | ViewerConnected
    | SetLoop
    | SetCompare
)


def check_command(command: Command) -> None:
    """Reject values the simulation must never see (ValueError). The REST layer checks first, with
    field-level messages; this is the last line for every other caller."""

    def finite(*values: float) -> bool:
        return all(isinstance(v, int | float) and math.isfinite(v) for v in values)

    if isinstance(command, SetVelocity):
        if not (
            finite(command.vx, command.vy) and max(abs(command.vx), abs(command.vy)) <= VELOCITY_LIMIT_M_S
        ):
            raise ValueError(f"velocity must be finite with |vx|, |vy| <= {VELOCITY_LIMIT_M_S} m/s")
    elif isinstance(command, NudgeVelocity):
        if not (
            finite(command.dvx, command.dvy)
            and max(abs(command.dvx), abs(command.dvy)) <= 2 * VELOCITY_LIMIT_M_S
        ):
            raise ValueError(
                f"velocity change must be finite with |dvx|, |dvy| <= {2 * VELOCITY_LIMIT_M_S} m/s"
            )
    elif isinstance(command, ApplyPush):
        if not (
            finite(command.fx, command.fy, command.duration_s)
            and 0.0 < math.hypot(command.fx, command.fy) <= PUSH_FORCE_LIMIT_N + 1e-9
            and 0.0 < command.duration_s <= PUSH_DURATION_LIMIT_S
        ):
            raise ValueError(
                f"push needs 0 < |f| <= {PUSH_FORCE_LIMIT_N} N and 0 < duration <= {PUSH_DURATION_LIMIT_S} s"
            )
    elif isinstance(command, SetSpeed):
        low, high = SIM_SPEED_RANGE
        if not (finite(command.speed) and low <= command.speed <= high):
            raise ValueError(f"speed must be in [{low}, {high}]")
    elif isinstance(command, SetGait):
        if command.gait not in registry.gait_names():
            raise ValueError(
                f"unknown gait {command.gait!r}: choose one of {', '.join(registry.gait_names())}"
            )
    elif isinstance(command, SetPlanner):
        if command.planner not in registry.planner_names():
            raise ValueError(
                f"unknown planner {command.planner!r}: choose one of {', '.join(registry.planner_names())}"
            )
    elif isinstance(command, SetSim):
        if command.engine not in ENGINES:
            raise ValueError(f"unknown physics engine {command.engine!r}: choose one of {', '.join(ENGINES)}")
    elif isinstance(command, SetTerrain):
        if not isinstance(command.terrain, Terrain):
            raise ValueError("SetTerrain needs a validated Terrain")
    elif isinstance(command, EditTerrain):
        if not callable(command.edit) or not isinstance(command.args, tuple):
            raise ValueError("EditTerrain needs an edit function and a tuple of arguments")
    elif isinstance(command, Notify):
        if not (isinstance(command.text, str) and 0 < len(command.text) <= 500 and command.level in NOTICE_LEVELS):
            raise ValueError(f"a notice needs a text of 1-500 characters and a level ({', '.join(NOTICE_LEVELS)})")
    elif isinstance(command, RenameTerrain):
        if not isinstance(command.label, str) or not command.label:
            raise ValueError("RenameTerrain needs a label")
    elif isinstance(command, SetCompare):
        planners = command.planners
        if not isinstance(planners, tuple) or len(planners) not in (0, 2):
            raise ValueError("compare needs two planner names (the main robot's first), or none to turn it off")
        unknown = [p for p in planners if p not in registry.planner_names()]
        if unknown:
            raise ValueError(
                f"unknown planner {unknown[0]!r}: choose from {', '.join(registry.planner_names())}"
            )
