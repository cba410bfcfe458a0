"""Contact planners: given the robot's state, decide the next steps (which legs swing, where they land).

Every planner answers `plan(context) -> list[PlannedStep]` with `gait.steps_per_plan` (3) steps: the first is executed
now, the next two complete the optimizer's 960 ms horizon. The loop (`locomotion.py`) treats planners alike.

- `ContactNetPlanner`, `FixedGaitPlanner`: the network's ranking, the first safe action (acyclic), or the
  best safe foothold of the leg whose turn it is (the paper's fixed-gait baseline).

The blind baseline, `HeuristicPlanner` (the fixed cyclic gait, Raibert-style footholds), is in
`contactnet.planning.heuristic`; the exact teacher, `OraclePlanner`, in `contactnet.planning.oracle`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from contactnet.frames import rotate_xy
from contactnet.motion.gait import GaitSpec
from contactnet.planning import cornered
from contactnet.planning.capture import DEFAULT_CAPTURE, CaptureConfig, capture_offset
from contactnet.planning.footholds import FootholdChecker, HeightChecks
from contactnet.planning.heights_tables import CompiledHeights
from contactnet.planning.network import NumpyContactNet
from contactnet.planning.network_input import network_input_one, network_input_values
from contactnet.planning.plain_walk import PlainHeightsWalk
from contactnet.planning.plan_kernel import CompiledOneLevel
from contactnet.planning.ranking import (
    LANDING_MARGIN_RADII,
    SAFETY_CHUNK,
    WHOLE_GRID_MAX_POINTS,
    ActionCells,
    CandidateRanking,
    HeightsWalk,
    LandingCheck,
    OneLevelWalk,
    PlannedStep,
    cell_grid,
    first_safe_step,
    one_level_grid,
    step_in_place,
)
from contactnet.planning.reach import DEFAULT_REACH, ReachConfig, alone_step, first_moving, left_behind
from contactnet.planning.roll import DEFAULT_ROLL, RollConfig, first_step_with_room, roll_ahead_xy
from contactnet.planning.safe_walk import rank_of
from contactnet.planning.stand import (
    DEFAULT_IDLE,
    IdleConfig,
    first_step_that_moves,
    idle_stand_step,
    is_idle,
    network_stands,
    stalled,
    stalled_step,
    stalled_step_on_heights,
    stand_step,
    useless_swing,
)
from contactnet.robots.description import RobotDescription
from contactnet.terrain import Terrain

#: Re-exported: choosing a step from a ranking lives in ``contactnet.planning.ranking``.
__all__ = ["SAFETY_CHUNK", "WHOLE_GRID_MAX_POINTS", "CandidateRanking", "ContactNetPlanner", "FixedGaitPlanner",
           "LandingCheck", "PlannedStep", "Planner", "PlanningContext", "cell_grid", "first_safe_step", "step_in_place",
           "touchdown_times_s"]


@dataclass(frozen=True)
class PlanningContext:
    """What a planner sees when it plans (world frame, SI units)."""

    com_pos_world: np.ndarray  # (3,)
    com_vel_world: np.ndarray  # (3,)
    yaw_rad: float
    foot_pos_world: np.ndarray  # (4, 3) where the feet are now
    hip_ref_xy_base: np.ndarray  # (4, 2) nominal foot XY in the base frame (candidate grid centres)
    base_xy_world: np.ndarray  # (2,) base origin (the hip references move with it)
    vel_cmd_xy: np.ndarray  # (2,) commanded velocity, horizontal body frame
    terrain: Terrain
    gait: GaitSpec
    com_height_ref_m: float  # nominal CoM height above the ground (the robot's)
    rpy: np.ndarray = field(default_factory=lambda: np.zeros(3))  # base roll, pitch, yaw
    ang_vel_world: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # An external horizontal force on the body (N, world; None: none known) the capture step leans into (observer).
    external_force_xy_world: tuple[float, float] | None = None
    # Plans in a row, this one included, with a moving command while the CoM did not follow it (counted by the loop:
    # contactnet.planning.stand.StallWatch); 0 for a state seen on its own.
    still_plans: int = 0

    def vel_cmd_world(self) -> np.ndarray:
        return rotate_xy(self.vel_cmd_xy, self.yaw_rad)

    def hip_ref_world(self, base_xy_world: np.ndarray) -> np.ndarray:
        """(4, 2) hip references (nominal foot XY) when the base origin is at base_xy_world."""
        return base_xy_world + rotate_xy(self.hip_ref_xy_base, self.yaw_rad)


@runtime_checkable
class Planner(Protocol):
    """What the locomotion loop, the CLI and the web app need of a contact planner.

    ``plan`` returns ``ctx.gait.steps_per_plan`` steps (the first is executed now); ``last_candidates`` is
    the ranking the planner saw for that first step (``CandidateRanking``), or None for planners that do
    not rank. Register a new one with ``contactnet.registry.register_planner``.
    """

    name: str
    last_candidates: CandidateRanking | None

    def reset(self) -> None: ...

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]: ...


def touchdown_times_s(gait: GaitSpec) -> np.ndarray:
    """Time of each planned step's touchdown, from the start of the plan, (steps_per_plan,)."""
    touchdown_in_step = (gait.n_stance_pre + gait.n_swing) * gait.node_dt_s
    return np.arange(gait.steps_per_plan) * gait.step_duration_s + touchdown_in_step


class ContactNetPlanner:
    """The paper's planner: the network ranks every candidate action and the best safe one is taken.

    Three successive evaluations per call (``gait.steps_per_plan``): step 1 from the measured state, steps 2
    and 3 from the state predicted at the end of the previous step (the CoM moved by the commanded
    velocity, the chosen footholds fed into the next input: ``contactnet.planning.cost.predicted_state``, as the
    oracle does). Each walks down the network's ranking to the first candidate whose landing points are
    safe (``terrain.is_safe`` with ``margin_m``, default half the foot radius like the oracle). Inference
    is a numpy forward pass (``NumpyContactNet``), no torch on the hot path.

    On terrain with tops at several heights a candidate must also pass the height checks of
    ``contactnet.planning.footholds`` (reach from the predicted hip, a swing the robot can clear, room for the foot
    ball and the shin), and heights are measured from the feet's support (``contactnet.motion.ground``): the CoM
    height the network sees, and the one predicted for steps 2 and 3, follow the tops under the feet. On a
    single-height terrain none of this runs and the plan is today's.

    After a push (the CoM velocity off the command by more than ``capture.velocity_error_m_s``) the first step's
    candidate grid is shifted towards the capture point (``contactnet.planning.capture``) and the robot does not stand;
    ``capture=None`` turns this off. With a zero command and a balanced state it stands instead of a swing that
    barely moves its feet (``contactnet.planning.stand.IdleConfig``, any model); ``idle=None`` turns this off.
    The chosen legs land, where one of their cells allows it, with room ahead for the foot's roll while it stands
    (``contactnet.planning.roll``), else the first step's slide back on their top to it (``roll.slide_back``), and a
    foot rolled to the edge of a top too short for its roll steps back in first (``roll.reseat_step``); ``roll=None``
    turns these off. On terrain with heights, with ``RollConfig(heights=True)`` (off by default), the
    room is asked the same way (the point ahead safe too: with the margin on both sides of a riser it lies on the
    same top), except on a first step that moves a cornered leg
    first, whose order the room would undo. With no safe step at all it steps in place, a foot at an edge put back
    in (``contactnet.planning.ranking.put_back``); ``put_back=False``: where it stands, as the fixed gait does.

    ``model``: a ``contactnet.planning.network.LoadedModel`` of this gait.
    """

    name = "contactnet"

    def __init__(self, gait: GaitSpec, robot: RobotDescription, model,  # noqa: ANN001
                 margin_m: float | None = None, capture: CaptureConfig | None = DEFAULT_CAPTURE,
                 idle: IdleConfig | None = DEFAULT_IDLE, roll: RollConfig | None = DEFAULT_ROLL,
                 reach: ReachConfig | None = DEFAULT_REACH, put_back: bool = True) -> None:
        if model.gait != gait.name or model.n_actions not in (gait.n_actions, gait.n_choices):
            raise ValueError(f"model {model.path} is for {model.gait} ({model.n_actions} outputs), "
                             f"not {gait.name} ({gait.n_choices} choices: {gait.n_actions} actions and standing)")
        self.gait = gait
        self.robot = robot
        self.model = model
        self.hip_ref_xy_base = np.array(robot.foot_nominal_base[:, :2], dtype=float)
        self.margin_m = LANDING_MARGIN_RADII * robot.foot_radius_m if margin_m is None else float(margin_m)
        self.capture, self.idle, self.roll, self.reach = capture, idle, roll, reach
        self._put_back_m = self.margin_m if put_back else 0.0  # a step in place's feet (ranking.put_back)
        self.footholds = FootholdChecker(robot, HeightChecks().scaled(robot.size_scale))
        self._compiled: CompiledHeights | None = None  # the compiled height checks (``_compiled_heights``)
        self._heights_walk: HeightsWalk | PlainHeightsWalk | None = None  # and the walk with them on the last terrain
        self.hip_xy_base = np.array(robot.hip_pos_base[:, :2], dtype=float)
        self.last_candidates: CandidateRanking | None = None
        # The hot path's constants: the network with its scores negated (an ascending sort ranks), when the
        # model is the numpy network; the actions as lists of grid cells; numbers of the gait.
        net = getattr(model, "net", None)
        self._cost_net = net.negated() if isinstance(net, NumpyContactNet) else None
        self._actions = ActionCells.of(gait)
        # the common path of a plan on one level in one compiled call (contactnet.planning.plan_kernel)
        self._one_level = None if self._cost_net is None else CompiledOneLevel(gait, self._cost_net, self._actions)
        self._all_actions = np.array([[0, gait.n_actions]] * gait.steps_per_plan)  # each step ranks all actions
        self._n_actions, self._actions_per_group = gait.n_actions, gait.actions_per_group
        self._steps_per_plan, self._step_duration_s = gait.steps_per_plan, gait.step_duration_s
        self._may_stand = True  # with a model of N_a + 1 outputs (contactnet.planning.stand)
        # The centre of pressure's offset from the CoM per newton of horizontal force at the CoM height (h / (m g)).
        self._lean_m_per_n = robot.com_height_nominal_m / robot.weight_n
        self._touchdown_s = float(touchdown_times_s(gait)[0])  # the first step's touchdown, from the plan's start
        #: the action ranges (first, stop) of the swing groups that move each leg (``contactnet.planning.reach``)
        self._spans_of_leg = [[(g * gait.actions_per_group, (g + 1) * gait.actions_per_group)
                               for g, legs in enumerate(gait.swing_groups) if leg in legs] for leg in range(4)]

    def reset(self) -> None:
        self.last_candidates = None

    def _group_range(self, step_index: int) -> tuple[int, int]:
        """The actions ranked at step ``step_index`` of this plan: ``range(first, stop)`` (all of them)."""
        return 0, self._n_actions

    def _ranking(self, costs: np.ndarray, step_index: int) -> Callable[[], np.ndarray]:
        """A function making the ranking of step ``step_index`` (action indices, best first: lower cost, i.e. higher
        score, first; ties in index order) when called, even after the plan has moved on."""
        first, stop = self._group_range(step_index)
        if first == 0 and stop == self._n_actions:
            return lambda: costs.argsort(kind="stable")
        return lambda: first + costs[first:stop].argsort(kind="stable")

    def _spans(self) -> np.ndarray:
        """(steps, 2) the ``_group_range`` of each step of this plan."""
        return self._all_actions

    def _advance(self) -> None:
        """Called once per plan (the fixed gait moves on to the next group)."""

    def _split_stand(self, costs: np.ndarray) -> tuple[np.ndarray, float | None]:
        """The stepping actions' costs (N_a,) and standing's (None when the model cannot stand, or for the fixed
        gait, which keeps its order)."""
        if len(costs) == self._n_actions or not self._may_stand:
            return costs[:self._n_actions], None
        return costs[:self._n_actions], float(costs[self._n_actions])

    @staticmethod
    def _stands(costs: np.ndarray, stand_cost: float | None, found: tuple | None) -> bool:
        """``contactnet.planning.stand.network_stands`` with ``found`` the first usable step (rank, action, ...) or None."""
        return network_stands(costs, stand_cost, None if found is None else costs[found[1]])

    def _costs(self, u: list[float]) -> np.ndarray:
        """Minus the network's scores (N_a, or N_a + 1 with standing last) of the input u (14 floats)."""
        net = self._cost_net
        if net is not None:
            return net.scores_unchecked(np.array(u, dtype=net.dtype))
        return -np.asarray(self.model.scores(np.array(u)))

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        """Three steps. The state is carried in Python floats rather than ``CostState`` objects (this is the
        hot path); ``tests/test_planner.py`` checks it against ``network_input_of_state`` and ``predicted_state``
        step by step, and ``tests/test_planner_fast.py`` against a plain walk down the ranking, flat and with
        heights."""
        offset = capture_offset(ctx.com_vel_world, ctx.vel_cmd_xy, ctx.yaw_rad, self.capture,
                                ctx.external_force_xy_world, self._lean_m_per_n)
        idle = is_idle(ctx.com_vel_world, ctx.vel_cmd_xy, self.idle)
        must_step = stalled(ctx.still_plans, self.idle)  # a stop with a moving command (StallWatch)
        if self.footholds.applies(ctx.terrain):
            steps = self._plan_with_heights(ctx, offset, idle, must_step)
            walk = self._heights_walk
            if (offset is None and walk.cornered is not None and not self._moves_cornered(ctx, steps[0])
                    and cornered.may_step(walk.cornered, self.gait, self._group_range(0))):
                candidates = self.last_candidates  # no forward step for it: once more a cell further on
                shift_xy = cornered.grid_shift_xy(walk.forward_xy, self.gait.grid_spacing_m)
                shifted = self._plan_with_heights(ctx, shift_xy, idle, must_step)
                if self._moves_cornered(ctx, shifted[0]):
                    steps = shifted
                else:
                    self.last_candidates = candidates
        else:
            steps = self._plan_one_level(ctx, offset, idle, must_step)
            if self.roll is not None:  # the roll's rules: a rolled foot back in, a landing slid back (planning.roll)
                steps[0] = first_step_with_room(steps[0], self.gait, ctx.foot_pos_world, ctx.terrain, ctx.vel_cmd_xy,
                                                ctx.yaw_rad, self.margin_m, self.robot.foot_radius_m, self.roll,
                                                offset is None and self._put_back_m > 0.0)
        if offset is not None:
            steps[0] = dataclasses.replace(steps[0], captured=True)
        self._advance()
        return steps

    def _moves_cornered(self, ctx: PlanningContext, step: PlannedStep) -> bool:
        """Whether ``step`` moves a leg cornered at the last plan forward (``contactnet.planning.cornered``)."""
        walk = self._heights_walk
        return cornered.moves_cornered_leg(step, walk.cornered, np.asarray(ctx.foot_pos_world, dtype=float)[:, :2],
                                           walk.forward_xy, cornered.CORNERED_MIN_PROGRESS_M)

    def _plan_one_level(self, ctx: PlanningContext, capture_xy: tuple[float, float] | None = None,
                        idle: bool = False, must_step: bool = False) -> list[PlannedStep]:
        """``plan`` on a terrain whose tops are all at one height, where a candidate is usable when it is safe:
        ``first_safe_step``'s choice, found faster (``OneLevelWalk``). ``capture_xy``: the first step's grid shift
        (``contactnet.planning.capture``), None for none; ``idle``: a useless swing is replaced by standing (``is_idle``);
        ``must_step``: the first step does not stand (a stall, ``StallWatch``; a pushed robot's as well)."""
        gait, terrain = self.gait, ctx.terrain
        c, s = np.cos(ctx.yaw_rad), np.sin(ctx.yaw_rad)
        to_world = np.array([[c, -s], [s, c]])  # heading frame -> world
        hips_world = self.hip_ref_xy_base @ to_world.T
        offsets_world = gait.cell_offsets_xy @ to_world.T
        feet_xy = np.array(np.asarray(ctx.foot_pos_world, dtype=float)[:, 0:2])  # a copy (the compiled plan moves it)
        base_x, base_y = np.asarray(ctx.base_xy_world, dtype=float).tolist()
        cmd_xy = np.asarray(ctx.vel_cmd_xy, dtype=float)
        cmd = cmd_xy.tolist()
        cmd_world = (to_world @ cmd_xy).tolist()
        shift_x, shift_y = cmd_world[0] * self._step_duration_s, cmd_world[1] * self._step_duration_s
        level_z = terrain.levels[0][0]
        if level_z == terrain.surface_z:  # every foot on a top or over a hole: the same height (ground_z)
            tops = [level_z] * 4
        else:
            tops = terrain.ground_z(feet_xy).tolist()
        ground_z = sum(tops) / len(tops)
        com_z = ground_z + ctx.com_height_ref_m
        cos_yaw, sin_yaw = math.cos(ctx.yaw_rad), math.sin(ctx.yaw_rad)
        bases = [[base_x, base_y]]
        for _ in range(1, self._steps_per_plan):
            base_x += shift_x
            base_y += shift_y
            bases.append([base_x, base_y])
        if capture_xy is not None:
            bases[0] = [bases[0][0] + capture_xy[0], bases[0][1] + capture_xy[1]]
        ahead = roll_ahead_xy(self.robot.foot_radius_m, cmd_world, self.roll)
        # a useless swing gives way to a step that moves (IdleConfig.step_when_moving): its threshold, or None
        # (always when stalled: standing is no answer, nor a step that does not go along the command)
        moving = self.idle.min_swing_m if self.idle is not None and (self.idle.step_when_moving or must_step) else None
        forward = None  # the way a stalled step goes: the command's direction (a stall has a moving command)
        if must_step:
            speed = math.hypot(cmd_world[0], cmd_world[1])
            forward = (cmd_world[0] / speed, cmd_world[1] / speed)
        if self._one_level is not None and not idle and moving is None:  # the common path, compiled
            compiled = self._one_level.plan(
                feet_xy, np.asarray(ctx.com_pos_world, dtype=float), np.asarray(ctx.com_vel_world, dtype=float),
                cmd_xy, cmd_world, cos_yaw, sin_yaw, ground_z, com_z, shift_x, shift_y, bases, self._spans(),
                self._may_stand, capture_xy is None, ahead, terrain.safe_locator(self.margin_m), hips_world,
                offsets_world, self._reach_test(cmd_world) if capture_xy is None else None)
            if compiled is not None:
                steps, costs = compiled
                self.last_candidates = CandidateRanking(gait, self._ranking(costs, 0),
                                                        one_level_grid(bases[0], hips_world, offsets_world), terrain,
                                                        self.margin_m, steps[0].action_index)
                return steps
            feet_xy = np.asarray(ctx.foot_pos_world, dtype=float)[:, 0:2]  # as given (the compiled plan moved the copy)
        feet = feet_xy.tolist()
        com = np.asarray(ctx.com_pos_world, dtype=float).tolist()
        vel = np.asarray(ctx.com_vel_world, dtype=float).tolist()
        # the legs left behind at the plan's start (contactnet.planning.reach); none without a reach config
        behind = left_behind(feet, [[bases[0][0] + x, bases[0][1] + y] for x, y in hips_world.tolist()],
                             *self._reach_test(cmd_world)) if capture_xy is None else []
        walk = OneLevelWalk(self._actions, terrain, self.margin_m, hips_world, offsets_world, bases)
        costs_of, action_group = self._costs, self._actions.group
        steps = []
        for j in range(self._steps_per_plan):
            costs, stand_cost = self._split_stand(costs_of(network_input_values(feet, com, vel, cmd, cos_yaw, sin_yaw,
                                                                                ground_z)))
            if j == 0 and (capture_xy is not None or must_step):
                stand_cost = None  # a pushed robot steps, and so does a stalled one
            order = self._ranking(costs, j)
            span = self._group_range(j)
            # a leg left behind goes first (contactnet.planning.reach); else the first safe action
            found = first_moving(walk, costs, [s for leg in behind for s in self._spans_of_leg[leg]]) if (
                j == 0 and behind) else None
            forced = found is not None
            alone = None
            if j == 0 and behind and not forced and self.reach.step_alone:  # no safe action: a leg steps alone?
                alone = alone_step(walk, costs, behind, self._spans_of_leg, self._actions, terrain, self.margin_m, ahead)
            if not forced and ahead is None:
                found = walk.first_safe(j, costs, span)
            elif not forced:  # with room for the roll (contactnet.planning.roll), in one walk
                found = walk.first_safe_with_room(j, costs, span, ahead, self._actions_per_group)
            elif ahead is not None:  # a leg left behind's step: its swing group's first landing with the room
                group = found[1] // self._actions_per_group
                roomed = walk.first_safe_with_room(j, costs, (max(span[0], group * self._actions_per_group), min(
                    span[1], (group + 1) * self._actions_per_group)), ahead, self._actions_per_group)
                if roomed is not None and roomed[1] != found[1]:
                    found = int(rank_of(costs, span[0], span[1], roomed[1])), roomed[1], roomed[2]
            top = found  # the stand is weighed against the ranking's first safe step
            if j == 0 and must_step and found is not None:  # stalled: a step along the command (StallWatch)
                stuck = found
                found = stalled_step(walk, costs, span, found, feet, ahead, moving, self._actions, self._actions_per_group,
                                     forward)
                forced = forced and found is stuck
            elif (j == 0 and not forced and not idle and found is not None and moving is not None
                    and useless_swing(action_group[found[1]], found[2], feet, moving)):
                found = first_step_that_moves(walk, costs, span, found, feet, ahead, moving, self._actions.flat_array,
                                              self._actions_per_group)
            if alone is not None:  # a leg left behind steps alone (contactnet.planning.reach)
                step, points = alone, alone.footholds_xy_world.tolist()
            elif forced:
                rank, action, points = found
                step = PlannedStep.ranked(action_group[action], np.array(points), action, rank)
            elif self._stands(costs, stand_cost, top):
                step, points = stand_step(gait, costs, stand_cost), []
            elif idle and found is not None and useless_swing(action_group[found[1]], found[2], feet,
                                                              self.idle.min_swing_m):
                step, points = idle_stand_step(gait, found[0]), []
            elif found is None:  # nothing safe: step in place
                step = step_in_place(gait, order(), np.array(feet), terrain, self._put_back_m)
                points = step.footholds_xy_world.tolist()
            else:
                rank, action, points = found
                step = PlannedStep.ranked(action_group[action], np.array(points), action, rank)
            if j == 0:
                self.last_candidates = CandidateRanking(gait, order, walk.grid(0), terrain, self.margin_m,
                                                        step.action_index)
            steps.append(step)
            # The state a step later, as contactnet.planning.cost.predicted_state predicts it.
            for leg, xy in zip(step.legs, points, strict=True):
                feet[leg] = xy
            com = [com[0] + shift_x, com[1] + shift_y, com_z]
            vel = [cmd_world[0], cmd_world[1], 0.0]
        return steps

    def _reach_test(self, cmd_world: list[float]) -> tuple[float, float, float]:
        """``left_behind``'s shift of the hips (world x, y, m) and threshold (m), a threshold 0 without ``reach``."""
        reach = self.reach
        if reach is None:
            return 0.0, 0.0, 0.0
        look_s = reach.lookahead_steps * self._step_duration_s
        threshold = self.robot.kin_threshold_m if reach.threshold_m is None else reach.threshold_m
        return cmd_world[0] * look_s, cmd_world[1] * look_s, threshold

    def _with_room_on_heights(self, walk: HeightsWalk | PlainHeightsWalk, ahead: tuple[float, float], step: int,
                              costs: np.ndarray, span: tuple[int, int],
                              found: tuple[int, int, list[list[float]], list[float]]
                              ) -> tuple[int, int, list[list[float]], list[float]]:
        """``_with_room`` on terrain with heights: the first usable action of ``found``'s swing group whose landing
        points have the room ``ahead`` (world XY, m), else ``found``. The walk looks for it in the ranking with the
        actions lacking the room ranked last (NaN costs); the answer's rank is its place in the plain ranking."""
        ahead_x, ahead_y = ahead
        terrain, margin = walk.terrain, self.margin_m
        covers = terrain.safe_locator(margin).covers_xy
        if all(covers(x + ahead_x, y + ahead_y) for x, y in found[2]):  # it has the room (most plans)
            return found
        group = found[1] // self._actions_per_group
        first = max(span[0], group * self._actions_per_group)
        stop = min(span[1], (group + 1) * self._actions_per_group)
        cells = walk.grid(step)().reshape(-1, 2)
        roomy_cells = terrain.is_safe(cells + (ahead_x, ahead_y), margin)
        roomy = roomy_cells[self._actions.flat_array[first:stop]].all(axis=1)
        if not roomy.any():
            return found
        masked = np.array(costs, dtype=float)
        masked[first:stop][~roomy] = np.nan
        better = walk.first_usable(step, masked, (first, stop))
        if better is None or better[1] == found[1]:
            return found
        if not roomy[better[1] - first]:  # none with the room is usable: the walk's choice back on ``found``
            walk.first_usable(step, costs, span)
            return found
        return int(rank_of(costs, span[0], span[1], better[1])), better[1], better[2], better[3]

    def _plan_with_heights(self, ctx: PlanningContext, capture_xy: tuple[float, float] | None = None,
                           idle: bool = False, must_step: bool = False) -> list[PlannedStep]:
        """``plan`` on a terrain with tops at several heights (see the class doc): ``first_safe_step`` with the
        height checks, the first step's ranking with the actions moving a cornered leg first (see
        ``contactnet.planning.cornered``), found faster (``HeightsWalk``, one per planner and terrain). ``capture_xy``:
        the first step's grid shift (the hips at touchdown, for the reach check, are not shifted), None for none;
        ``idle`` and ``must_step`` as in ``_plan_one_level``."""
        gait, terrain = self.gait, ctx.terrain
        c, s = np.cos(ctx.yaw_rad), np.sin(ctx.yaw_rad)
        to_world = np.array([[c, -s], [s, c]])  # heading frame -> world
        hips_world = self.hip_ref_xy_base @ to_world.T
        offsets_world = gait.cell_offsets_xy @ to_world.T
        feet = np.asarray(ctx.foot_pos_world, dtype=float)[:, 0:2].tolist()
        com = np.asarray(ctx.com_pos_world, dtype=float).tolist()
        vel = np.asarray(ctx.com_vel_world, dtype=float).tolist()
        base_x, base_y = np.asarray(ctx.base_xy_world, dtype=float).tolist()
        cmd_xy = np.asarray(ctx.vel_cmd_xy, dtype=float)
        cmd = cmd_xy.tolist()
        cmd_world = (to_world @ cmd_xy).tolist()
        shift_x, shift_y = cmd_world[0] * self._step_duration_s, cmd_world[1] * self._step_duration_s
        cos_yaw, sin_yaw = math.cos(ctx.yaw_rad), math.sin(ctx.yaw_rad)
        bases = [[base_x, base_y]]
        for _ in range(1, self._steps_per_plan):
            base_x += shift_x
            base_y += shift_y
            bases.append([base_x, base_y])
        grid_bases = bases if capture_xy is None else [
            [bases[0][0] + capture_xy[0], bases[0][1] + capture_xy[1]], *bases[1:]]
        walk = self._heights_walk
        if terrain.sloped:  # no rasters of flat tops for the compiled walk: the plain one (numpy, shapely)
            if not isinstance(walk, PlainHeightsWalk) or walk.terrain is not terrain:
                walk = self._heights_walk = PlainHeightsWalk(
                    self._actions, terrain, self.margin_m, self.footholds, self.hip_xy_base, self._touchdown_s,
                    cornered.CORNERED_LOOKAHEAD_STEPS * self._step_duration_s, cornered.CORNERED_MIN_PROGRESS_M)
        elif walk is None or walk.terrain is not terrain or walk.compiled is not self._compiled_heights():
            walk = self._heights_walk = HeightsWalk(
                self._actions, terrain, self.margin_m, self._compiled_heights(), self.hip_xy_base, self._touchdown_s,
                cornered.CORNERED_LOOKAHEAD_STEPS * self._step_duration_s, cornered.CORNERED_MIN_PROGRESS_M)
        # the tops under the feet: the support (contactnet.motion.ground)
        tops = walk.start(hips_world, offsets_world, grid_bases, ctx.yaw_rad, bases, cmd_world, feet,
                          (float(c), float(s)))
        ground_z = sum(tops) / len(tops)
        ahead = roll_ahead_xy(self.robot.foot_radius_m, cmd_world, self.roll) if (
            self.roll is not None and self.roll.heights) else None
        costs_of, action_group = self._costs, self._actions.group
        steps = []
        for j in range(self._steps_per_plan):
            costs, stand_cost = self._split_stand(costs_of(network_input_values(feet, com, vel, cmd, cos_yaw, sin_yaw,
                                                                                ground_z)))
            span = self._group_range(j)
            found = walk.first_usable(j, costs, span)
            if ahead is not None and found is not None and not (j == 0 and walk.cornered is not None):
                found = self._with_room_on_heights(walk, ahead, j, costs, span, found)
            if j == 0 and must_step and found is not None:  # stalled: a step along the command (StallWatch)
                found = stalled_step_on_heights(walk, costs, span, found, feet, cmd_world, self.idle.min_swing_m, self._actions)
            order = self._ranking(costs, j)
            if j == 0:
                grid = walk.grid(0)
                if capture_xy is not None or walk.cornered is not None or must_step:
                    stand_cost = None  # a pushed robot steps, and so do one with a cornered leg and a stalled one
                    if walk.cornered is not None:
                        order = functools.partial(cornered.urgent_ranking, order, walk.urgent(span, grid), span[0])
            if self._stands(costs, stand_cost, found):
                step, points, landing_tops = stand_step(gait, costs, stand_cost), [], []
            elif idle and found is not None and useless_swing(action_group[found[1]], found[2], feet,
                                                              self.idle.min_swing_m):
                step, points, landing_tops = idle_stand_step(gait, found[0]), [], []
            elif found is None:  # nothing usable: step in place
                step = step_in_place(gait, order(), np.array(feet), terrain, self._put_back_m)
                points, landing_tops = [], []  # (the feet stay where they are)
            else:
                rank, action, points, landing_tops = found
                step = PlannedStep.ranked(action_group[action], np.array(points), action, rank)
                walk.took(action)
            if j == 0:
                self.last_candidates = CandidateRanking(gait, order, grid, terrain, self.margin_m, step.action_index,
                                                        walk.check(0))
            steps.append(step)
            # The state a step later, as contactnet.planning.cost.predicted_state predicts it.
            for leg, point, top in zip(step.legs, points, landing_tops, strict=False):
                feet[leg] = point
                tops[leg] = top
            ground_z = sum(tops) / len(tops)
            com = [com[0] + shift_x, com[1] + shift_y, ground_z + ctx.com_height_ref_m]
            vel = [cmd_world[0], cmd_world[1], 0.0]
        return steps

    def replan_swing(self, ctx: PlanningContext, legs: tuple[int, ...]) -> PlannedStep | None:
        """The best safe landing of the swing group ``legs`` from the state ``ctx`` (their feet where they lifted
        off), the network's ranking restricted to that group's actions: a swing's new target after a disturbance
        (``contactnet.planning.retarget``). None when none of them is safe."""
        gait, terrain = self.gait, ctx.terrain
        c, s = np.cos(ctx.yaw_rad), np.sin(ctx.yaw_rad)
        to_world = np.array([[c, -s], [s, c]])
        feet_xy = np.array(ctx.foot_pos_world, dtype=float)[:, 0:2]
        base_xy = np.array(ctx.base_xy_world, dtype=float)
        tops = terrain.ground_z(feet_xy)
        u = network_input_one(feet_xy, np.asarray(ctx.com_pos_world, dtype=float),
                              np.asarray(ctx.com_vel_world, dtype=float), np.asarray(ctx.vel_cmd_xy, dtype=float),
                              ctx.yaw_rad, sum(tops.tolist()) / len(tops))
        first = gait.swing_groups.index(tuple(legs)) * gait.actions_per_group
        order = first + np.argsort(-self.model.scores(u)[first: first + gait.actions_per_group], kind="stable")
        cells = (base_xy + self.hip_ref_xy_base @ to_world.T)[:, None, :] + (gait.cell_offsets_xy @ to_world.T)[None]
        check = None
        if self.footholds.applies(terrain):
            cells = self.footholds.centred(terrain, cells.reshape(-1, 2)).reshape(cells.shape)
            check = self._height_check(terrain, feet_xy, base_xy + self.hip_xy_base @ to_world.T, tops, ctx.yaw_rad)
        step = first_safe_step(gait, order, cells, feet_xy, terrain, self.margin_m, check)
        return None if step.action_index is None else step

    def _compiled_heights(self) -> CompiledHeights:
        """The height checks compiled for this planner's checker and margin (``contactnet.planning.heights_walk``),
        with the rasters of the last terrain planned on."""
        compiled = self._compiled
        if compiled is None or compiled.checker is not self.footholds or compiled.margin_m != self.margin_m:
            compiled = self._compiled = CompiledHeights(self.footholds, self.margin_m)
        return compiled

    def _height_check(self, terrain: Terrain, feet_xy: np.ndarray, hips_xy_world: np.ndarray, tops_z: np.ndarray,
                      yaw_rad: float) -> LandingCheck:
        """The height checks of landing points from one (measured or predicted) state: each leg lifts off
        where it stands (``feet_xy`` (4, 2), on the tops ``tops_z`` (4,)), its hip at touchdown is at
        ``hips_xy_world`` (4, 2)."""

        def check(legs: np.ndarray, landing_xy: np.ndarray) -> np.ndarray:
            return self.footholds.usable(terrain, legs, landing_xy, feet_xy[legs], hips_xy_world[legs], tops_z,
                                         yaw_rad)

        return check


class FixedGaitPlanner(ContactNetPlanner):
    """The paper's fixed-gait baseline: the same network, restricted to a prescribed cyclic leg order (walk:
    HL, FL, HR, FR; trot: alternating diagonal pairs). Only the footholds are chosen (the best safe cell of
    the leg whose turn it is); with no safe cell that leg swings in place, its foot put back where it stands. The
    baseline as measured: no room for the foot's roll by default (``roll=DEFAULT_ROLL`` gives it; on Table II's
    seeds 0-29 it then crossed 26 / 30, against 27 / 30 without)."""

    name = "fixed"

    def __init__(self, gait: GaitSpec, robot: RobotDescription, model,  # noqa: ANN001
                 margin_m: float | None = None, capture: CaptureConfig | None = DEFAULT_CAPTURE,
                 roll: RollConfig | None = None) -> None:
        super().__init__(gait, robot, model, margin_m, capture, idle=None, roll=roll, reach=None, put_back=False)
        self._next_group = 0
        self._may_stand = False  # the cyclic baseline always steps

    def reset(self) -> None:
        super().reset()
        self._next_group = 0

    def _group_range(self, step_index: int) -> tuple[int, int]:
        cyclic = self.gait.cyclic_order
        first = cyclic[(self._next_group + step_index) % len(cyclic)] * self._actions_per_group
        return first, first + self._actions_per_group

    def _spans(self) -> np.ndarray:
        return np.array([self._group_range(j) for j in range(self._steps_per_plan)])

    def _advance(self) -> None:
        self._next_group = (self._next_group + 1) % len(self.gait.cyclic_order)
