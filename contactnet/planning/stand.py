"""The stand choice (issue 14): beside its stepping actions a ranking planner may choose not to step.

Standing (``GaitSpec.stand_index``) keeps all four feet in stance for the next step horizon. A ranking over
choices (the ranking cost's, or a network's with N_a + 1 outputs) holds it like any action; since no foot
moves, standing is always safe, so the planner takes it when it ranks above the best *safe* stepping action
(or when no stepping action is safe at all). See ``contactnet.planning.cost`` for how the cost scores it.

A network ranks less sharply than the cost: its outputs regress the rank targets (1 for the cheapest of the
N_a + 1 choices, 1 - 1/N_a for the next, ...), so near the top of the ranking two choices a rank apart differ
by less than the network's error. A network planner therefore also stands when the network puts standing at the
top rank (its output rounds to it, ``network_stands``), even if a step scores a little higher: standing moves
nothing and is always safe. Without this tie rule a trot model with the stand choice (163 outputs) ranked
standing first in 36 % of its dataset's states where standing is the cheapest choice and never stood with a zero
command; with it 58 % (and stands in 2.9 % of the states where a step is cheaper, against 1.0 %).

The idle rule (``IdleConfig``) stands with any model, one without the stand output as well: with a zero command
and a balanced state, a step whose swinging feet all land within 2 cm of where they are (a useless swing) is
replaced by standing.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning.ranking import OneLevelWalk, PlannedStep
from contactnet.planning.safe_walk import rank_of


def split_stand(gait: GaitSpec, order: np.ndarray) -> tuple[np.ndarray, int | None]:
    """A ranking of choices (best first) as the stepping actions in their order and the position of standing
    (``gait.stand_index``) in it, None when standing is not in the ranking."""
    order = np.asarray(order)
    stand = order == gait.stand_index
    if not stand.any():
        return order, None
    return order[~stand], int(stand.argmax())


def prefer_stand(gait: GaitSpec, step, stand_position: int | None):  # noqa: ANN001, ANN201 - planner.PlannedStep
    """``step`` (a ``PlannedStep``: the first safe stepping action, ``rank`` its position among the stepping
    actions, or a step in place with ``rank`` None) or standing, whichever ranks first. Standing is a step with
    no legs, ranked at ``stand_position`` (every stepping action ranked above it was unsafe)."""
    if stand_position is None or (step.rank is not None and step.rank < stand_position):
        return step
    return dataclasses.replace(step, legs=(), footholds_xy_world=np.zeros((0, 2)), action_index=gait.stand_index,
                               rank=stand_position, discarded=stand_position, safe=True)


#: ``network_stands``: standing's output within this many ranks of the top rank counts as the top rank.
TOP_RANK_TIE = 0.5


def network_stands(costs: np.ndarray, stand_cost: float | None, step_cost: float | None) -> bool:
    """Whether a network planner stands: ``costs`` (N_a,) and ``stand_cost`` are minus the network's outputs,
    ``step_cost`` the first usable stepping action's (None when no step is usable). It stands when standing ranks
    above that step, when no step is usable, or when standing's output rounds to the top rank (at least
    1 - ``TOP_RANK_TIE`` / N_a; see the module doc). Never with ``stand_cost`` None (a model without the output)."""
    if stand_cost is None:
        return False
    return step_cost is None or stand_cost < step_cost or -stand_cost >= 1.0 - TOP_RANK_TIE / len(costs)


def stand_step(gait: GaitSpec, costs: np.ndarray, stand_cost: float) -> PlannedStep:
    """Standing, chosen from a network's costs (lower first; ``costs`` the N_a stepping actions'): its rank is
    how many stepping actions cost no more (they come before it in a stable sort; all of them were unusable)."""
    return idle_stand_step(gait, int(np.count_nonzero(costs <= stand_cost)))


@dataclass(frozen=True)
class IdleConfig:
    """The idle rule: a ranking planner stands instead of a *useless swing* when nothing needs to move.

    The paper's Sec. V: "ContactNet can choose small steps in a row with the same leg ... an energy-based cost term
    could be added to prevent useless swings". The retrained walk model learned that term (its stand output); the
    shipped trot model has none (N_a outputs) and with a zero command on flat put its feet back within 2 cm of
    where they lifted off in 91 of 94 steps. The rule applies the term at plan time, to any model: when the
    command is zero (at most ``max_command_m_s``) and the state balanced (the CoM velocity within
    ``max_velocity_error_m_s`` of it), a chosen step whose swinging feet all land less than ``min_swing_m`` from
    where they are is replaced by standing. A push (a larger velocity error) or any command keeps it stepping.

    With a command that moves, ``step_when_moving`` replaces such a useless swing (the first safe step of the
    ranking) by the first safe step whose swinging feet move (``ContactNetPlanner``): standing still is then no
    answer, and a step that puts its foot back wastes a step horizon. Whether to stand is still decided against the
    useless swing's score, as without the rule. Off by default: measured (docs/results.md, the frontier), it doubled
    the crossings of Go2's walk model on its field at n = 80 and changed which of Solo12's trials fell, not how many.
    """

    max_command_m_s: float = 0.005  # |command| at or below this counts as zero
    max_velocity_error_m_s: float = 0.05  # |CoM velocity (xy) - command| at or below this counts as balanced
    min_swing_m: float = 0.02  # a swing moving every foot less than this is useless (simulate --json's measure)
    step_when_moving: bool = False  # with a moving command, a useless swing gives way to the first step that moves
    #: A stall (``StallWatch``): after this many plans in a row with a moving command and the CoM not following it,
    #: a plan's first step does not stand and goes along the command (``stalled_step``; 0: never)
    stall_plans: int = 3
    stall_speed_share: float = 0.25  # ... not following: less than this share of the command's way since it last did

    def __post_init__(self) -> None:
        for name in ("max_command_m_s", "max_velocity_error_m_s", "min_swing_m", "stall_speed_share"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"IdleConfig.{name} must be a finite number >= 0, got {value!r}")
        if isinstance(self.stall_plans, bool) or not isinstance(self.stall_plans, int) or self.stall_plans < 0:
            raise ValueError(f"IdleConfig.stall_plans must be an integer >= 0, got {self.stall_plans!r}")


#: The planners' default: the idle rule on (``ContactNetPlanner(idle=None)`` turns it off).
DEFAULT_IDLE = IdleConfig()


def is_idle(com_vel_world: np.ndarray, vel_cmd_xy: np.ndarray, config: IdleConfig | None) -> bool:
    """Whether nothing needs to move: a zero command (heading frame; its length does not depend on the heading)
    and a CoM velocity (world, horizontal) within ``config.max_velocity_error_m_s`` of it. False when ``config``
    is None."""
    if config is None:
        return False
    cmd_x, cmd_y = float(vel_cmd_xy[0]), float(vel_cmd_xy[1])
    if not math.hypot(cmd_x, cmd_y) <= config.max_command_m_s:
        return False
    # The command is (almost) zero, so the velocity error is the velocity itself, up to max_command_m_s.
    return math.hypot(float(com_vel_world[0]), float(com_vel_world[1])) <= config.max_velocity_error_m_s


class StallWatch:
    """How long a robot with a moving command has not been following it: the stand choice's dead end.

    A network with the stand output stands when standing ranks above the first safe step. Where every safe step
    ranks low (Go2's trot model on its stepping stones: the first safe step 41st of 163, plan after plan) it stands
    with a moving command, the body comes to rest over its feet, and the next plan, from the same state, stands
    again, to the time limit; a model that swings a leg without moving it (a useless swing) does the same by
    stepping. The loop (``contactnet.locomotion``) counts its plans made with a moving command while the CoM did
    not follow it (since the plan where it last did, it moved along the command less than
    ``IdleConfig.stall_speed_share`` of the way the command asked for) and hands the count to the planner
    (``PlanningContext.still_plans``); after ``IdleConfig.stall_plans`` such plans in a row a ContactNet planner's
    first step does not stand and goes along the command where a safe step does (``stalled_step``; on terrain with
    heights ``stalled_step_on_heights``, a usable one), until the CoM follows again or the command stops. A robot walking as commanded never counts: standing between steps, its CoM
    moves on over the feet."""

    def __init__(self, interval_s: float) -> None:
        self.interval_s = interval_s  # the time between two plans (one step: the loop plans every step)
        self.still_plans = 0  # plans in a row with a moving command and the CoM not following it
        self._anchor_xy: tuple[float, float] | None = None  # the CoM where it last followed (world, m)

    def reset(self) -> None:
        self.still_plans, self._anchor_xy = 0, None

    def count(self, com_pos_world: np.ndarray, vel_cmd_xy: np.ndarray, yaw_rad: float,
              config: IdleConfig | None) -> int:
        """Count a plan's state (the CoM, world; the command, heading frame, horizontal; the heading's yaw) and
        return how many plans in a row, this one included, the CoM has not followed a moving command: since the
        plan where it last did (the anchor) it moved along the command less than ``config.stall_speed_share`` of
        the way the command asked for over those plans (one interval each). Measured from the anchor, so a body that
        sways back and forth with its steps does not count as following. 0 with ``config`` None (the planner's: one
        without the idle rule)."""
        x, y = float(com_pos_world[0]), float(com_pos_world[1])
        anchor = self._anchor_xy
        cmd_x, cmd_y = float(vel_cmd_xy[0]), float(vel_cmd_xy[1])
        speed = math.hypot(cmd_x, cmd_y)
        if config is None or anchor is None or not speed > config.max_command_m_s:
            self.still_plans, self._anchor_xy = 0, (x, y)
            return 0
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)  # the way along the command, the command turned into the world
        along = ((x - anchor[0]) * (c * cmd_x - s * cmd_y) + (y - anchor[1]) * (s * cmd_x + c * cmd_y)) / speed
        plans = self.still_plans + 1  # plans since the anchor
        if along >= config.stall_speed_share * speed * self.interval_s * plans:
            self.still_plans, self._anchor_xy = 0, (x, y)
        else:
            self.still_plans = plans
        return self.still_plans


def stalled(still_plans: int, config: IdleConfig | None) -> bool:
    """Whether a plan's first step must move (``StallWatch``): ``still_plans`` (``PlanningContext.still_plans``)
    beyond ``config.stall_plans``; never with the rule off (``config`` None or ``stall_plans`` 0)."""
    return config is not None and 0 < config.stall_plans < still_plans


def useless_swing(legs: tuple[int, ...], landing_xy_world, feet_xy_world, min_swing_m: float) -> bool:  # noqa: ANN001
    """Whether every swinging foot (``legs``) lands less than ``min_swing_m`` from where it is: ``landing_xy_world``
    one [x, y] per leg of ``legs``, ``feet_xy_world`` one [x, y] per leg (lists or arrays)."""
    if not legs:
        return False
    for leg, (x, y) in zip(legs, landing_xy_world, strict=True):
        foot = feet_xy_world[leg]
        if not math.hypot(x - foot[0], y - foot[1]) < min_swing_m:
            return False
    return True


def moves_forward(legs: tuple[int, ...], landing_xy_world, feet_xy_world, forward_xy: tuple[float, float],  # noqa: ANN001
                  min_swing_m: float) -> bool:
    """Whether the swinging feet (``legs``, landing at ``landing_xy_world``, one [x, y] per leg of ``legs``) move
    ``min_swing_m`` or more along the unit vector ``forward_xy`` (world) on average; standing does not."""
    if not legs:
        return False
    way = sum((x - feet_xy_world[leg][0]) * forward_xy[0] + (y - feet_xy_world[leg][1]) * forward_xy[1]
              for leg, (x, y) in zip(legs, landing_xy_world, strict=True))
    return way >= min_swing_m * len(legs)


def not_forward(cells_world: np.ndarray, feet_xy_world: list[list[float]], forward_xy: tuple[float, float],
                action_flat: np.ndarray, min_swing_m: float) -> np.ndarray:
    """(N_a,) the actions whose swinging feet move less than ``min_swing_m`` along the unit vector ``forward_xy`` on
    average (``moves_forward`` of every action at once): ``cells_world`` (4, cells per leg, 2) the candidate grid,
    ``action_flat`` (N_a, legs per step) each action's grid cells (``ActionCells.flat_array``)."""
    way = (cells_world - np.asarray(feet_xy_world)[:, None, :]) @ np.asarray(forward_xy, dtype=float)
    return way.reshape(-1)[action_flat].mean(axis=1) < min_swing_m


def first_step_that_moves(walk: OneLevelWalk, costs: np.ndarray, span: tuple[int, int],
                          found: tuple[int, int, list[list[float]]], feet_xy_world: list[list[float]],
                          ahead_xy: tuple[float, float] | None, min_swing_m: float, action_flat: np.ndarray,
                          per_group: int,
                          forward_xy: tuple[float, float] | None = None) -> tuple[int, int, list[list[float]]]:
    """``IdleConfig.step_when_moving`` on a plan's first step: the first safe action of ``costs``' ranking over
    ``span`` (with the room for the roll ``ahead_xy`` among those, as for any choice) whose swinging feet do not all
    land within ``min_swing_m`` of where they are (``feet_xy_world``, one [x, y] per leg), as (its rank in the
    ranking, action, landing points); ``found`` (the ranking's first safe action) when no such action is safe.
    ``action_flat`` (N_a, legs per step): each action's grid cells (``ActionCells.flat_array``). With
    ``forward_xy`` (a unit vector, world): the first whose swinging feet move ``min_swing_m`` or more along it on
    average (``moves_forward``; a stalled robot's step, ``StallWatch``)."""
    cells = walk.grid(0)()  # (4, cells per leg, 2), world
    offsets = cells - np.asarray(feet_xy_world)[:, None, :]
    if forward_xy is None:
        near = np.hypot(*offsets.transpose(2, 0, 1)) < min_swing_m
        useless = near.reshape(-1)[action_flat].all(axis=1)
    else:
        useless = not_forward(cells, feet_xy_world, forward_xy, action_flat, min_swing_m)
    masked = costs.copy()
    masked[useless] = np.nan  # ranked after every step that moves
    better = walk.first_safe(0, masked, span)
    if better is None or useless[better[1]]:  # no step that moves is safe
        return found
    if ahead_xy is not None:  # and the room for the roll, among the steps that move
        roomy = walk.first_safe_with_room(0, masked, span, ahead_xy, per_group)
        if roomy is not None and not useless[roomy[1]]:
            better = roomy
    return int(rank_of(costs, span[0], span[1], better[1])), better[1], better[2]


def stalled_step(walk: OneLevelWalk, costs: np.ndarray, span: tuple[int, int], found: tuple[int, int, list[list[float]]],
                 feet_xy_world: list[list[float]], ahead_xy: tuple[float, float] | None, min_swing_m: float,
                 actions, per_group: int, forward_xy: tuple[float, float]) -> tuple[int, int, list[list[float]]]:  # noqa: ANN001
    """A stalled plan's first step (``StallWatch``) on terrain of one level, from ``found`` (the ranking's first safe
    step, as ``first_step_that_moves`` takes it): that step if it goes along the command (``moves_forward``), else
    the first safe step that does, else, if ``found`` is a useless swing, the first safe step that moves the feet at
    all, else ``found`` itself (the same object: nothing better is safe). ``actions``: the planner's
    ``ActionCells`` (``per_group`` actions a swing group); ``forward_xy`` the command's direction (unit, world)."""
    if moves_forward(actions.group[found[1]], found[2], feet_xy_world, forward_xy, min_swing_m):
        return found
    ahead = first_step_that_moves(walk, costs, span, found, feet_xy_world, ahead_xy, min_swing_m, actions.flat_array,
                                  per_group, forward_xy)
    if ahead is found and useless_swing(actions.group[found[1]], found[2], feet_xy_world, min_swing_m):
        return first_step_that_moves(walk, costs, span, found, feet_xy_world, ahead_xy, min_swing_m,
                                     actions.flat_array, per_group)
    return ahead


def stalled_step_on_heights(walk, costs: np.ndarray, span: tuple[int, int],  # noqa: ANN001 - a heights walk
                            found: tuple[int, int, list[list[float]], list[float]], feet_xy_world: list[list[float]],
                            cmd_world: list[float], min_swing_m: float, actions) -> tuple:  # noqa: ANN001
    """``stalled_step`` on terrain with heights (``HeightsWalk``, ``PlainHeightsWalk``: ``first_usable`` with the
    height checks): ``found`` (the ranking's first usable step, (rank, action, landing points, tops)) if it goes along
    the command (``cmd_world``, world XY, moving), else the first usable step that does, its rank in the plain
    ranking, else ``found``. The walk looks for it in the ranking with the other actions ranked last (NaN costs)
    and, when none goes along, is asked for ``found`` again, so that its state is ``found``'s (as
    ``ContactNetPlanner._with_room_on_heights`` does)."""
    speed = math.hypot(cmd_world[0], cmd_world[1])
    forward_xy = (cmd_world[0] / speed, cmd_world[1] / speed)
    if moves_forward(actions.group[found[1]], found[2], feet_xy_world, forward_xy, min_swing_m):
        return found
    first, stop = span
    behind = not_forward(walk.grid(0)(), feet_xy_world, forward_xy, actions.flat_array, min_swing_m)
    if behind[first:stop].all():
        return found
    masked = np.array(costs, dtype=float)
    masked[behind] = np.nan
    better = walk.first_usable(0, masked, span)
    if better is None or behind[better[1]]:  # none that goes along is usable
        walk.first_usable(0, costs, span)
        return found
    return int(rank_of(costs, first, stop, better[1])), better[1], better[2], better[3]


def idle_stand_step(gait: GaitSpec, rank: int) -> PlannedStep:
    """Standing at ``rank`` of the ranking (the actions above it discarded): the idle rule's choice over the useless
    step at ``rank`` (standing takes its place), and ``stand_step``'s."""
    return PlannedStep(legs=(), footholds_xy_world=np.zeros((0, 2)), action_index=gait.stand_index, rank=rank,
                       discarded=rank)


__all__ = ["DEFAULT_IDLE", "TOP_RANK_TIE", "IdleConfig", "StallWatch", "first_step_that_moves", "idle_stand_step",
           "is_idle", "moves_forward", "network_stands", "not_forward", "prefer_stand", "split_stand", "stalled", "stalled_step",
           "stalled_step_on_heights", "stand_step", "useless_swing"]
