"""Contact planners: given the robot's state, decide the next steps (which legs swing, where they land).

Every planner answers `plan(context) -> list[PlannedStep]` with `gait.steps_per_plan` (3) steps: the
first is executed now, the next two complete the optimizer's 960 ms horizon. Planners differ only
in how they choose; the loop (`locomotion.py`) treats them alike.

- `HeuristicPlanner`: the fixed cyclic gait (walk: HL, FL, HR, FR; trot: alternating diagonal
  pairs) with Raibert-style footholds. Blind to holes. The baseline, and the loop's planner until
  ContactNet is trained.
- `ContactNetPlanner`, `FixedGaitPlanner`: the network's ranking, the first safe action (acyclic), or the
  best safe foothold of the leg whose turn it is (the paper's fixed-gait baseline).

The exact teacher, `OraclePlanner`, lives in `contactnet.planning.oracle`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from contactnet.frames import rotate_xy
from contactnet.motion.gait import GaitSpec
from contactnet.planning.capture import DEFAULT_CAPTURE, CaptureConfig, capture_offset
from contactnet.planning.footholds import FootholdChecker
from contactnet.planning.network import NumpyContactNet
from contactnet.planning.network_input import network_input_one, network_input_values
from contactnet.planning.ranking import (
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
    step_in_place,
)
from contactnet.planning.stand import (
    DEFAULT_IDLE,
    IdleConfig,
    idle_stand_step,
    is_idle,
    network_stands,
    stand_step,
    useless_swing,
)
from contactnet.robots.description import RobotDescription
from contactnet.terrain import Terrain

#: Re-exported: choosing a step from a ranking lives in ``contactnet.planning.ranking``.
__all__ = [
    "CORNERED_BACKSTEP_M", "CORNERED_LOOKAHEAD_STEPS", "SAFETY_CHUNK", "WHOLE_GRID_MAX_POINTS", "CandidateRanking",
    "ContactNetPlanner", "FixedGaitPlanner", "HeuristicPlanner", "LandingCheck", "PlannedStep",
    "Planner", "PlanningContext", "cell_grid", "first_safe_step", "step_in_place", "touchdown_times_s",
]


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
    # An external horizontal force on the body (N, world) the capture step leans into (contactnet.planning.observer);
    # None: none known.
    external_force_xy_world: tuple[float, float] | None = None

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


@dataclass
class HeuristicPlanner:
    """Fixed cyclic gait with Raibert footholds: land under the hip's mid-stance position plus a
    velocity-error correction. It never looks at the terrain (the baseline the paper beats)."""

    gait: GaitSpec
    raibert_gain: float = 0.15  # s: extra step per m/s of velocity error (about sqrt(h / g))
    max_offset_m: float = 0.12  # clamp of the foothold around the hip reference
    _next_group: int = field(default=0, init=False)
    last_candidates: None = field(default=None, init=False)  # it does not rank

    name = "heuristic"

    def reset(self) -> None:
        self._next_group = 0

    def stance_duration_s(self) -> float:
        """How long a leg stays down in the cyclic gait (one cycle minus its swing)."""
        cycle = len(self.gait.cyclic_order) * self.gait.step_duration_s
        return cycle - self.gait.swing_duration_s

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        gait = self.gait
        vel_cmd = ctx.vel_cmd_world()
        vel_err = ctx.com_vel_world[:2] - vel_cmd
        half_stance = 0.5 * self.stance_duration_s()
        steps = []
        for j, t_td in enumerate(touchdown_times_s(gait)):
            group = gait.cyclic_order[(self._next_group + j) % len(gait.cyclic_order)]
            legs = gait.swing_groups[group]
            base_td = ctx.base_xy_world + vel_cmd * t_td
            hip_td = ctx.hip_ref_world(base_td)[list(legs)]
            offset = vel_cmd * half_stance + (self.raibert_gain * vel_err if j == 0 else 0.0)
            offset = np.clip(offset, -self.max_offset_m, self.max_offset_m)
            steps.append(PlannedStep(legs=legs, footholds_xy_world=hip_td + offset))
        self._next_group = (self._next_group + 1) % len(gait.cyclic_order)
        return steps


#: A cornered leg's step (``ContactNetPlanner``) is promoted only if it lands no further back than this (m).
CORNERED_BACKSTEP_M = 0.01
#: ... and a leg is cornered when its lower leg would reach the terrain this many steps of motion ahead.
CORNERED_LOOKAHEAD_STEPS = 3.0

# ----------------------------------------------------------------------------------------------------
# ContactNet
# ----------------------------------------------------------------------------------------------------


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

    ``model``: a ``contactnet.planning.network.LoadedModel`` of this gait.
    """

    name = "contactnet"

    def __init__(self, gait: GaitSpec, robot: RobotDescription, model,  # noqa: ANN001
                 margin_m: float | None = None, capture: CaptureConfig | None = DEFAULT_CAPTURE,
                 idle: IdleConfig | None = DEFAULT_IDLE) -> None:
        if model.gait != gait.name or model.n_actions not in (gait.n_actions, gait.n_choices):
            raise ValueError(f"model {model.path} is for {model.gait} ({model.n_actions} outputs), "
                             f"not {gait.name} ({gait.n_choices} choices: {gait.n_actions} actions and standing)")
        self.gait = gait
        self.robot = robot
        self.model = model
        self.hip_ref_xy_base = np.array(robot.foot_nominal_base[:, :2], dtype=float)
        self.margin_m = 0.5 * robot.foot_radius_m if margin_m is None else float(margin_m)
        self.capture, self.idle = capture, idle
        self.footholds = FootholdChecker(robot)
        self.hip_xy_base = np.array(robot.hip_pos_base[:, :2], dtype=float)
        self.last_candidates: CandidateRanking | None = None
        # The hot path's constants: the network with its scores negated (an ascending sort ranks), when the
        # model is the numpy network; the actions as lists of grid cells; numbers of the gait.
        net = getattr(model, "net", None)
        self._cost_net = net.negated() if isinstance(net, NumpyContactNet) else None
        self._actions = ActionCells.of(gait)
        self._n_actions, self._actions_per_group = gait.n_actions, gait.actions_per_group
        self._steps_per_plan, self._step_duration_s = gait.steps_per_plan, gait.step_duration_s
        self._may_stand = True  # with a model of N_a + 1 outputs (contactnet.planning.stand)
        # The centre of pressure's offset from the CoM per newton of horizontal force at the CoM height (h / (m g)).
        self._lean_m_per_n = robot.com_height_nominal_m / robot.weight_n

    def reset(self) -> None:
        self.last_candidates = None

    def _group_range(self, step_index: int) -> tuple[int, int]:
        """The actions ranked at step ``step_index`` of this plan: ``range(first, stop)`` (all of them)."""
        return 0, self._n_actions

    def _order(self, costs: np.ndarray, step_index: int) -> np.ndarray:
        """Action indices best first (lower cost, i.e. higher score, first; ties in index order)."""
        return self._ranking(costs, step_index)()

    def _ranking(self, costs: np.ndarray, step_index: int) -> Callable[[], np.ndarray]:
        """A function making ``_order(costs, step_index)`` when called, even after the plan has moved on."""
        first, stop = self._group_range(step_index)
        if first == 0 and stop == self._n_actions:
            return lambda: costs.argsort(kind="stable")
        return lambda: first + costs[first:stop].argsort(kind="stable")

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
        if self.footholds.applies(ctx.terrain):
            steps = self._plan_with_heights(ctx, offset, idle)
        else:
            steps = self._plan_one_level(ctx, offset, idle)
        if offset is not None:
            steps[0] = dataclasses.replace(steps[0], captured=True)
        self._advance()
        return steps

    def _plan_one_level(self, ctx: PlanningContext, capture_xy: tuple[float, float] | None = None,
                        idle: bool = False) -> list[PlannedStep]:
        """``plan`` on a terrain whose tops are all at one height, where a candidate is usable when it is safe:
        ``first_safe_step``'s choice, found faster (``OneLevelWalk``). ``capture_xy``: the first step's grid shift
        (``contactnet.planning.capture``), None for none; ``idle``: a useless swing is replaced by standing (``is_idle``)."""
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
        level_z = terrain.levels[0][0]
        if level_z == terrain.surface_z:  # every foot on a top or over a hole: the same height (ground_z)
            tops = [level_z] * 4
        else:
            tops = terrain.ground_z(np.array(feet)).tolist()
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
        walk = OneLevelWalk(self._actions, terrain, self.margin_m, hips_world, offsets_world, bases)
        costs_of, action_group = self._costs, self._actions.group
        steps = []
        for j in range(self._steps_per_plan):
            costs, stand_cost = self._split_stand(costs_of(network_input_values(feet, com, vel, cmd, cos_yaw, sin_yaw,
                                                                                ground_z)))
            if j == 0 and capture_xy is not None:
                stand_cost = None  # a pushed robot steps
            order = self._ranking(costs, j)
            found = walk.first_safe(j, costs, self._group_range(j))
            if self._stands(costs, stand_cost, found):
                step, points = stand_step(gait, costs, stand_cost), []
            elif idle and found is not None and useless_swing(action_group[found[1]], found[2], feet,
                                                              self.idle.min_swing_m):
                step, points = idle_stand_step(gait, found[0]), []
            elif found is None:  # nothing safe: step in place
                step = step_in_place(gait, order(), np.array(feet), terrain)
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

    def _plan_with_heights(self, ctx: PlanningContext, capture_xy: tuple[float, float] | None = None,
                           idle: bool = False) -> list[PlannedStep]:
        """``plan`` on a terrain with tops at several heights (see the class doc): ``first_safe_step`` with the
        height checks, found faster (``HeightsWalk``). ``capture_xy``: the first step's grid shift (the hips at
        touchdown, for the reach check, are not shifted), None for none; ``idle`` as in ``_plan_one_level``."""
        gait = self.gait
        c, s = np.cos(ctx.yaw_rad), np.sin(ctx.yaw_rad)
        to_world = np.array([[c, -s], [s, c]])  # heading frame -> world
        hips_world = self.hip_ref_xy_base @ to_world.T
        offsets_world = gait.cell_offsets_xy @ to_world.T
        feet_xy = np.array(ctx.foot_pos_world, dtype=float)[:, 0:2]
        com = np.asarray(ctx.com_pos_world, dtype=float).tolist()
        vel = np.asarray(ctx.com_vel_world, dtype=float).tolist()
        base_xy = np.array(ctx.base_xy_world, dtype=float)
        cmd_xy = np.asarray(ctx.vel_cmd_xy, dtype=float)
        cmd = cmd_xy.tolist()
        cmd_world = to_world @ cmd_xy
        shift = cmd_world * gait.step_duration_s
        shift_x, shift_y = shift.tolist()
        terrain = ctx.terrain
        ground_xy = _ground_xy(terrain)
        tops = np.array([ground_xy(x, y) for x, y in feet_xy.tolist()])  # (4,) the support (contactnet.motion.ground)
        ground_z = sum(tops.tolist()) / len(tops)
        # each leg's hip (flexion joint) at touchdown, from the base at the start of the step
        hips_touchdown = self.hip_xy_base @ to_world.T + cmd_world * touchdown_times_s(gait)[0]
        cos_yaw, sin_yaw = math.cos(ctx.yaw_rad), math.sin(ctx.yaw_rad)
        bases = [base_xy.tolist()]
        for _ in range(1, self._steps_per_plan):
            bases.append((np.array(bases[-1]) + shift).tolist())
        grid_bases = bases if capture_xy is None else [
            [bases[0][0] + capture_xy[0], bases[0][1] + capture_xy[1]], *bases[1:]]
        walk = HeightsWalk(self._actions, terrain, self.margin_m, self.footholds, hips_world, offsets_world,
                           grid_bases, ctx.yaw_rad)
        steps = []
        for j in range(self._steps_per_plan):
            costs, stand_cost = self._split_stand(self._costs(network_input_values(
                feet_xy.tolist(), com, vel, cmd, cos_yaw, sin_yaw, ground_z)))
            if j == 0 and capture_xy is not None:
                stand_cost = None  # a pushed robot steps
            order = self._order(costs, j)
            hips_xy = np.array(bases[j]) + hips_touchdown
            if j == 0:
                promoted = self._swing_cornered_legs_first(order, walk.grid(0), terrain, feet_xy, tops, base_xy,
                                                           to_world, cmd_world, ctx.yaw_rad)
                if promoted is not order:  # a leg is cornered: it steps, the robot does not stand
                    order, stand_cost = promoted, None
            found = walk.first_usable(j, order, feet_xy, tops, hips_xy)
            if self._stands(costs, stand_cost, found):
                step, points = stand_step(gait, costs, stand_cost), []
            elif idle and found is not None and useless_swing(self._actions.group[found[1]], found[2], feet_xy,
                                                              self.idle.min_swing_m):
                step, points = idle_stand_step(gait, found[0]), []
            elif found is None:  # nothing usable: step in place
                step = step_in_place(gait, order, feet_xy, terrain)
                points = step.footholds_xy_world.tolist()
            else:
                rank, action, points = found
                step = PlannedStep.ranked(self._actions.group[action], np.array(points), action, rank)
            if j == 0:
                self.last_candidates = CandidateRanking(
                    gait, order, walk.grid(0), terrain, self.margin_m, step.action_index,
                    self._height_check(terrain, feet_xy.copy(), hips_xy, tops.copy(), ctx.yaw_rad))
            steps.append(step)
            # The state a step later, as contactnet.planning.cost.predicted_state predicts it.
            for leg, (x, y) in zip(step.legs, points, strict=True):
                feet_xy[leg] = x, y
                tops[leg] = ground_xy(x, y)
            ground_z = sum(tops.tolist()) / len(tops)
            com = [com[0] + shift_x, com[1] + shift_y, ground_z + ctx.com_height_ref_m]
            vel = [*cmd_world.tolist(), 0.0]
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

    def _swing_cornered_legs_first(self, order: np.ndarray, grid: Callable[[], np.ndarray], terrain: Terrain,
                                   feet_xy: np.ndarray, tops: np.ndarray, base_xy: np.ndarray, to_world: np.ndarray,
                                   cmd_world: np.ndarray, yaw_rad: float) -> np.ndarray:
        """The ranking with the actions that move a *cornered* leg forward first (each part in its own order):
        a leg whose shank, knee or thigh would reach the terrain if it stood where it is for
        ``CORNERED_LOOKAHEAD_STEPS`` more steps of the commanded motion (a hind foot behind a higher top, the
        body moving on over it). The network knows nothing of heights and may keep such a leg down until it
        touches. Actions that put a cornered leg further back are not promoted (that would corner it more).
        ``grid()`` makes the (4, cells_per_leg, 2) candidate grid (only needed when a leg is cornered)."""
        lookahead_s = CORNERED_LOOKAHEAD_STEPS * self.gait.step_duration_s
        ahead = base_xy + self.hip_xy_base @ to_world.T + cmd_world * lookahead_s
        clear = self.footholds.stance_clear(terrain, feet_xy, tops, ahead, yaw_rad)
        if clear.all():
            return order
        # Per grid cell (leg * cells_per_leg + cell): a cornered leg's cell no further back than the backstep.
        cells = grid()  # (4, cells_per_leg, 2)
        forward_x, forward_y = to_world[:, 0].tolist()
        progress = (cells[:, :, 0] - feet_xy[:, 0, None]) * forward_x + (cells[:, :, 1] - feet_xy[:, 1, None]) * forward_y
        promote = ((progress >= -CORNERED_BACKSTEP_M) & ~clear[:, None]).ravel()
        landing = promote[self._actions.flat_array[order]]  # (K, legs per step)
        urgent = landing[:, 0] if landing.shape[1] == 1 else np.logical_or.reduce(landing, axis=1)
        return np.concatenate([order[urgent], order[~urgent]])

    def _height_check(self, terrain: Terrain, feet_xy: np.ndarray, hips_xy_world: np.ndarray, tops_z: np.ndarray,
                      yaw_rad: float) -> LandingCheck:
        """The height checks of landing points from one (measured or predicted) state: each leg lifts off
        where it stands (``feet_xy`` (4, 2), on the tops ``tops_z`` (4,)), its hip at touchdown is at
        ``hips_xy_world`` (4, 2)."""

        def check(legs: np.ndarray, landing_xy: np.ndarray) -> np.ndarray:
            return self.footholds.usable(terrain, legs, landing_xy, feet_xy[legs], hips_xy_world[legs], tops_z,
                                         yaw_rad)

        return check


def _ground_xy(terrain: Terrain) -> Callable[[float, float], float]:
    """``terrain.ground_z`` of one point (x, y) in Python floats, on a terrain with several levels: the same answer."""
    height_xy, surface_z = terrain.height_locator().height_xy, terrain.surface_z

    def ground_xy(x: float, y: float) -> float:
        z = height_xy(x, y)
        return surface_z if z != z else z  # (NaN: no top)

    return ground_xy


class FixedGaitPlanner(ContactNetPlanner):
    """The paper's fixed-gait baseline: the same network, restricted to a prescribed cyclic leg order (walk:
    HL, FL, HR, FR; trot: alternating diagonal pairs). Only the footholds are chosen (the best safe cell of
    the leg whose turn it is); with no safe cell that leg swings in place."""

    name = "fixed"

    def __init__(self, gait: GaitSpec, robot: RobotDescription, model,  # noqa: ANN001
                 margin_m: float | None = None, capture: CaptureConfig | None = DEFAULT_CAPTURE) -> None:
        super().__init__(gait, robot, model, margin_m, capture, idle=None)
        self._next_group = 0
        self._may_stand = False  # the cyclic baseline always steps

    def reset(self) -> None:
        super().reset()
        self._next_group = 0

    def _group_range(self, step_index: int) -> tuple[int, int]:
        cyclic = self.gait.cyclic_order
        first = cyclic[(self._next_group + step_index) % len(cyclic)] * self._actions_per_group
        return first, first + self._actions_per_group

    def _advance(self) -> None:
        self._next_group = (self._next_group + 1) % len(self.gait.cyclic_order)
