"""Contact planners: given the robot's state, decide the next steps (which legs swing, where they land).

Every planner answers `plan(context) -> list[PlannedStep]` with `gait.steps_per_plan` (3) steps: the
first is executed now, the next two complete the optimizer's 960 ms horizon. Planners differ only
in how they choose; the loop (`locomotion.py`) treats them alike.

- `HeuristicPlanner`: the fixed cyclic gait (walk: HL, FL, HR, FR; trot: alternating diagonal
  pairs) with Raibert-style footholds. Blind to holes. The baseline, and the loop's planner until
  ContactNet is trained.
- `OraclePlanner`: evaluates the ranking cost V of every action online and takes the cheapest safe
  one (exact and slow: the teacher of data generation, and a baseline).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from contactnet.footholds import FootholdChecker
from contactnet.frames import rotate_xy
from contactnet.gait import GaitSpec
from contactnet.network_input import network_input_one
from contactnet.robots.description import RobotDescription
from contactnet.stand import prefer_stand, split_stand
from contactnet.terrain import Terrain


@dataclass(frozen=True)
class PlannedStep:
    """One step: the legs that swing and where each lands (world XY), plus how it was chosen."""

    legs: tuple[int, ...]
    footholds_xy_world: np.ndarray  # (len(legs), 2)
    action_index: int | None = None  # index in the gait's action set, when the planner uses it
    rank: int | None = None  # position of the chosen action in the planner's ranking (0 = best)
    discarded: int = 0  # candidates ranked better but rejected as unsafe
    safe: bool = True  # False when the planner knowingly steps where the terrain is unsafe


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


class OraclePlanner:
    """The exact teacher: evaluate the ranking cost V of every action online and take the cheapest safe one.

    Slow (one batched optimization of all N_a candidates per planned step) but exact: the teacher of data
    generation and a baseline. Each of the ``gait.steps_per_plan`` steps is chosen from a state: step 1
    from the measured one, steps 2 and 3 from the state predicted at the end of the previous step horizon
    (``contactnet.cost.predicted_state``: the CoM moved by the commanded velocity, level, no angular
    velocity, the previous step's legs on their footholds; the paper's procedure).

    Safe = every swinging leg's landing point inside the steppable terrain shrunk by ``margin_m``. The
    default, half the foot-ball radius (8 mm), covers the swing controller's touchdown error (a few mm)
    while keeping the contact point, which is the bottom of the ball, on the surface; a larger margin
    throws away too many footholds on stepping stones. ``rank`` is the chosen action's position in the
    ascending-V order (0 = cheapest) and ``discarded`` how many cheaper actions were unsafe (the same
    number for this planner).

    No safe action at all: the robot steps in place. Swing groups are tried in the order of their
    cheapest action; the first group whose legs stand on safe ground (margin 0: they already stand
    there) lifts those legs and puts them back where they are (``action_index=None``, ``rank=None``,
    ``discarded=N_a``, ``safe=True``): the body keeps moving, so the next plan sees new candidates. Only
    when no group stands on safe ground does it step in place with the cheapest group and ``safe=False``.

    ``evaluated_steps`` (default all): how many of the plan's steps are chosen by V; later ones only fill
    the optimizer's horizon (``continue_cyclically``). Data generation evaluates step 1 only, the one
    it records and executes, which makes it three times cheaper; the next plan starts afresh anyway.

    ``last_costs`` is the ``CostBreakdown`` of step 1 and ``last_state`` its ``CostState``, so data
    generation can record (u_r, V) without evaluating again.
    """

    name = "oracle"

    def __init__(
        self,
        gait: GaitSpec,
        robot: RobotDescription,
        weights=None,  # noqa: ANN001 - contactnet.cost_weights.CostWeights (default: the gait's)
        margin_m: float | None = None,
        model=None,  # noqa: ANN001 - contactnet.trajopt.SrbdModel (default: the robot's)
        evaluated_steps: int | None = None,
    ) -> None:
        from contactnet.cost import RankingCost

        self.gait = gait
        self.robot = robot
        self.weights = weights if weights is not None else gait.cost_weights
        self.margin_m = 0.5 * robot.foot_radius_m if margin_m is None else float(margin_m)
        self.cost = RankingCost(gait, robot, self.weights, model=model)
        self.evaluated_steps = gait.steps_per_plan if evaluated_steps is None else int(evaluated_steps)
        if not 1 <= self.evaluated_steps <= gait.steps_per_plan:
            raise ValueError(f"evaluated_steps must be in 1..{gait.steps_per_plan}, got {evaluated_steps}")
        self.hip_ref_xy_base = np.array(robot.foot_nominal_base[:, :2], dtype=float)
        self.last_costs = None
        self.last_state = None
        self.last_candidates: CandidateRanking | None = None

    def reset(self) -> None:
        self.last_costs = None
        self.last_state = None
        self.last_candidates = None

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        from contactnet.cost import CostState, predicted_state

        state = CostState.from_context(ctx, self.robot.foot_radius_m)
        steps = []
        for j in range(self.gait.steps_per_plan):
            if j >= self.evaluated_steps:
                step = self.continue_cyclically(state, steps[-1].legs)
                steps.append(step)
                state = predicted_state(state, step.footholds_xy_world, step.legs, self.gait.step_duration_s)
                continue
            costs = self.cost.evaluate(state)
            if j == 0:
                self.last_costs, self.last_state = costs, state
            candidates = self.last_candidates
            step = self.choose(costs, state, ctx.terrain)
            if j > 0:
                self.last_candidates = candidates  # the viewer shows the step executed now
            steps.append(step)
            state = predicted_state(state, step.footholds_xy_world, step.legs, self.gait.step_duration_s)
        return steps

    def continue_cyclically(self, state, previous_legs: tuple[int, ...]) -> PlannedStep:  # noqa: ANN001
        """A step past ``evaluated_steps``: the group after ``previous_legs`` in the gait's cyclic order,
        landing at its hip reference shifted by the commanded velocity over half a stance (the Raibert
        nominal). It only fills the optimizer's horizon; the next plan re-evaluates from the new state."""
        gait = self.gait
        cyclic = gait.cyclic_order
        if previous_legs:
            group = gait.swing_groups.index(tuple(previous_legs))
            legs = gait.swing_groups[cyclic[(cyclic.index(group) + 1) % len(cyclic)]]
        else:  # after standing: the order's first group
            legs = gait.swing_groups[cyclic[0]]
        vel = np.asarray(state.vel_cmd_world, dtype=float)
        half_stance = 0.5 * (len(cyclic) * gait.step_duration_s - gait.swing_duration_s)
        touchdown_s = (gait.n_stance_pre + gait.n_swing) * gait.node_dt_s
        base = np.asarray(state.base_xy_world, dtype=float) + vel * touchdown_s
        hips = base + rotate_xy(self.hip_ref_xy_base, state.yaw_rad)
        return PlannedStep(legs=legs, footholds_xy_world=hips[list(legs)] + vel * half_stance)

    def choose(self, costs, state, terrain: Terrain) -> PlannedStep:  # noqa: ANN001 - cost types
        """The cheapest safe action of one evaluated state (or the step in place, see the class doc)."""
        order, stand_position = split_stand(self.gait, costs.ranking())
        cells = cell_grid(self.gait, costs.footholds_xy_world)
        step = first_safe_step(self.gait, order, cells, state.foot_pos_world, terrain, self.margin_m)
        step = prefer_stand(self.gait, step, stand_position)
        self.last_candidates = CandidateRanking(self.gait, order, cells, terrain, self.margin_m,
                                                step.action_index)
        return step


# ----------------------------------------------------------------------------------------------------
# Choosing from a ranking: shared by the oracle, ContactNet and the fixed gait
# ----------------------------------------------------------------------------------------------------

SAFETY_CHUNK = 8  # the best actions checked on their own before the whole candidate grid ...
WHOLE_GRID_MAX_POINTS = 48  # ... unless the grid is this small (trot: 36 cells): then the grid at once

#: A cornered leg's step (``ContactNetPlanner``) is promoted only if it lands no further back than this (m).
CORNERED_BACKSTEP_M = 0.01
#: ... and a leg is cornered when its lower leg would reach the terrain this many steps of motion ahead.
CORNERED_LOOKAHEAD_STEPS = 3.0

#: A further test of landing points besides ``terrain.is_safe``: ``(legs (M,), landing_xy_world (M, 2)) ->
#: usable (M,) bool`` (the height checks of ``contactnet.footholds`` on terrain with heights).
LandingCheck = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _usable(terrain: Terrain, margin_m: float, legs: np.ndarray | None, xy: np.ndarray,
            check: LandingCheck | None) -> np.ndarray:
    """(M,) bool: landing points ``xy`` (M, 2) of ``legs`` (M,) that are safe and pass ``check``."""
    safe = terrain.is_safe(xy, margin_m)
    if check is not None and safe.any():
        where = safe.nonzero()[0]
        safe[where] = check(legs[where], xy[where])
    return safe


def first_safe_step(
    gait: GaitSpec,
    order: np.ndarray,
    cell_xy_world: np.ndarray,
    foot_pos_world: np.ndarray,
    terrain: Terrain,
    margin_m: float,
    check: LandingCheck | None = None,
) -> PlannedStep:
    """Walk down ``order`` (action indices, best first) to the first action whose swinging legs all land on
    safe ground (``terrain.is_safe`` with ``margin_m``, and ``check`` when given). ``cell_xy_world`` (4,
    cells_per_leg, 2) is every leg's candidate grid; an action lands its legs on the cells ``gait.action_cells``
    names.

    The terrain is queried for all 4 x cells_per_leg cells at once, then every action is looked up in
    ranking order, so the cost does not depend on how deep into the ranking the holes push the choice.
    A large grid (walk: 100 cells, 1 leg per action) first tries the landing points of the best
    ``SAFETY_CHUNK`` actions on their own (the usual case: one of them is safe); a small one (trot: 36
    cells, 2 legs per action) is cheaper to query whole than to try a chunk first.

    ``rank`` is the chosen action's position in ``order`` and ``discarded`` how many better-ranked actions
    were unsafe (the same number). No safe action in ``order``: step in place (see ``OraclePlanner``).
    """
    order = np.asarray(order)
    cells_xy = np.asarray(cell_xy_world, dtype=float)
    action_legs, action_cells = gait.action_cells
    whole_grid = cells_xy.shape[0] * cells_xy.shape[1] <= WHOLE_GRID_MAX_POINTS
    safe = np.zeros(0, dtype=bool)
    if not whole_grid:
        head = order[:SAFETY_CHUNK]
        landing = cells_xy[action_legs[head], action_cells[head]]
        safe = _usable(terrain, margin_m, action_legs[head].ravel(), landing.reshape(-1, 2), check)
        safe = safe.reshape(landing.shape[:2]).all(axis=1)
    if not safe.any() and (whole_grid or len(order) > SAFETY_CHUNK):
        grid_legs = None if check is None else np.repeat(np.arange(cells_xy.shape[0]), cells_xy.shape[1])
        cell_safe = _usable(terrain, margin_m, grid_legs, cells_xy.reshape(-1, 2), check).astype(np.float32)
        safe = (gait.action_cell_incidence @ cell_safe == gait.legs_per_step)[order]
    rank = int(safe.argmax()) if len(safe) else 0
    if not len(safe) or not safe[rank]:
        return step_in_place(gait, order, foot_pos_world, terrain)
    index = int(order[rank])
    return PlannedStep(legs=gait.swing_groups[index // gait.actions_per_group],
                       footholds_xy_world=cells_xy[action_legs[index], action_cells[index]], action_index=index,
                       rank=rank, discarded=rank)


def cell_grid(gait: GaitSpec, footholds_xy_world: np.ndarray) -> np.ndarray:
    """(4, cells_per_leg, 2) every leg's candidate cells, from (N_a, 4, 2) feet after each action (the
    ranking cost's ``footholds_xy_world``). An action lands its legs on ``grid[gait.action_cells]``."""
    legs, cells = gait.action_cells
    grid = np.full((4, gait.cells_per_leg, 2), np.nan)
    grid[legs, cells] = np.asarray(footholds_xy_world)[np.arange(gait.n_actions)[:, None], legs]
    return grid


def step_in_place(gait: GaitSpec, order: np.ndarray, foot_pos_world: np.ndarray, terrain: Terrain) -> PlannedStep:
    """No safe candidate: lift a group of legs and put them back where they are. Groups are tried in the
    order their best action appears in ``order``; the first whose feet stand on safe ground is used
    (``safe=True``), else the first group with ``safe=False``."""
    groups = list(dict.fromkeys(int(a) // gait.actions_per_group for a in np.asarray(order)))
    feet_xy = np.asarray(foot_pos_world, dtype=float)[:, 0:2]
    for group in groups:
        legs = gait.swing_groups[group]
        if terrain.is_safe(feet_xy[list(legs)], 0.0).all():
            return PlannedStep(legs=legs, footholds_xy_world=feet_xy[list(legs)].copy(), discarded=len(order))
    legs = gait.swing_groups[groups[0]]
    return PlannedStep(legs=legs, footholds_xy_world=feet_xy[list(legs)].copy(), discarded=len(order), safe=False)


class CandidateRanking:
    """What a ranking planner saw for the step it executes now, for viewers: every candidate cell of every
    leg (world XY), whether it is safe, its best rank among the actions that use it, and the chosen
    cells. Built lazily (``cells()``): planning itself never pays for it."""

    def __init__(self, gait: GaitSpec, order: np.ndarray, cell_xy_world: np.ndarray, terrain: Terrain,
                 margin_m: float, chosen_action: int | None, check: LandingCheck | None = None) -> None:
        self.check = check  # the planner's further test of landing points (heights), None on flat ground
        self.gait = gait
        self.order = np.asarray(order)
        self.cell_xy_world = cell_xy_world  # (4, cells_per_leg, 2), see first_safe_step
        self.terrain = terrain
        self.margin_m = float(margin_m)
        self.chosen_action = chosen_action
        self._cells: tuple | None = None

    def cells(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[int, ...]]:
        """(xy_world (C, 2), safe (C,), leg (C,), rank (C,), chosen cell indices), C = 4 x cells per leg.
        Cells no ranked action uses get rank len(order)."""
        if self._cells is None:
            gait = self.gait
            n_cells = gait.cells_per_leg
            rank = np.full((4, n_cells), len(self.order), dtype=int)
            chosen: list[int] = []
            action_legs, action_cells = gait.action_cells
            for position, index in enumerate(self.order):
                for leg, cell in zip(action_legs[index], action_cells[index], strict=True):
                    if rank[leg, cell] == len(self.order):
                        rank[leg, cell] = position
                    if index == self.chosen_action:
                        chosen.append(leg * n_cells + cell)
            used = rank < len(self.order)
            xy_used = np.asarray(self.cell_xy_world, dtype=float)[used]
            leg_ids = np.repeat(np.arange(4), n_cells).reshape(4, n_cells)[used]
            flat_index = np.cumsum(used.ravel()) - 1
            chosen_used = tuple(int(flat_index[c]) for c in chosen)
            safe = _usable(self.terrain, self.margin_m, leg_ids, xy_used, self.check)
            self._cells = (xy_used, safe, leg_ids, rank[used], chosen_used)
        return self._cells

    @property
    def xy_world(self) -> np.ndarray:
        return self.cells()[0]

    @property
    def safe(self) -> np.ndarray:
        return self.cells()[1]

    @property
    def leg(self) -> np.ndarray:
        return self.cells()[2]

    @property
    def rank(self) -> np.ndarray:
        return self.cells()[3]

    @property
    def chosen(self) -> tuple[int, ...]:
        return self.cells()[4]


# ----------------------------------------------------------------------------------------------------
# ContactNet
# ----------------------------------------------------------------------------------------------------


class ContactNetPlanner:
    """The paper's planner: the network ranks every candidate action and the best safe one is taken.

    Three successive evaluations per call (``gait.steps_per_plan``): step 1 from the measured state, steps 2
    and 3 from the state predicted at the end of the previous step (the CoM moved by the commanded
    velocity, the chosen footholds fed into the next input: ``contactnet.cost.predicted_state``, as the
    oracle does). Each walks down the network's ranking to the first candidate whose landing points are
    safe (``terrain.is_safe`` with ``margin_m``, default half the foot radius like the oracle). Inference
    is a numpy forward pass (``NumpyContactNet``), no torch on the hot path.

    On terrain with tops at several heights a candidate must also pass the height checks of
    ``contactnet.footholds`` (reach from the predicted hip, a swing the robot can clear, room for the foot
    ball and the shin), and heights are measured from the feet's support (``contactnet.ground``): the CoM
    height the network sees, and the one predicted for steps 2 and 3, follow the tops under the feet. On a
    single-height terrain none of this runs and the plan is today's.

    ``model``: a ``contactnet.network.LoadedModel`` of this gait.
    """

    name = "contactnet"

    def __init__(self, gait: GaitSpec, robot: RobotDescription, model,  # noqa: ANN001
                 margin_m: float | None = None) -> None:
        if model.gait != gait.name or model.n_actions not in (gait.n_actions, gait.n_choices):
            raise ValueError(f"model {model.path} is for {model.gait} ({model.n_actions} outputs), "
                             f"not {gait.name} ({gait.n_choices} choices: {gait.n_actions} actions and standing)")
        self.gait = gait
        self.robot = robot
        self.model = model
        self.hip_ref_xy_base = np.array(robot.foot_nominal_base[:, :2], dtype=float)
        self.margin_m = 0.5 * robot.foot_radius_m if margin_m is None else float(margin_m)
        self.footholds = FootholdChecker(robot)
        self.hip_xy_base = np.array(robot.hip_pos_base[:, :2], dtype=float)
        self.last_candidates: CandidateRanking | None = None

    def reset(self) -> None:
        self.last_candidates = None

    def _order(self, scores: np.ndarray, step_index: int) -> np.ndarray:
        """Action indices best first (higher score = cheaper)."""
        return np.argsort(-scores, kind="stable")

    def _advance(self) -> None:
        """Called once per plan (the fixed gait moves on to the next group)."""

    def plan(self, ctx: PlanningContext) -> list[PlannedStep]:
        """Three steps. The state is carried in a few arrays rather than ``CostState`` objects (this is the
        hot path); ``tests/test_planner.py`` checks it against ``network_input_of_state`` and
        ``predicted_state`` step by step."""
        gait = self.gait
        c, s = np.cos(ctx.yaw_rad), np.sin(ctx.yaw_rad)
        to_world = np.array([[c, -s], [s, c]])  # heading frame -> world
        hips_world = self.hip_ref_xy_base @ to_world.T
        offsets_world = gait.cell_offsets_xy @ to_world.T
        feet_xy = np.array(ctx.foot_pos_world, dtype=float)[:, 0:2]
        com = np.array(ctx.com_pos_world, dtype=float)
        vel = np.array(ctx.com_vel_world, dtype=float)
        base_xy = np.array(ctx.base_xy_world, dtype=float)
        cmd_xy = np.asarray(ctx.vel_cmd_xy, dtype=float)
        cmd_world = to_world @ cmd_xy
        shift = cmd_world * gait.step_duration_s
        terrain = ctx.terrain
        heights = self.footholds.applies(terrain)
        tops = terrain.ground_z(feet_xy)  # (4,) the support (contactnet.ground)
        ground_z = sum(tops.tolist()) / len(tops)
        if heights:  # each leg's hip (flexion joint) at touchdown, from the base at the start of the step
            hips_touchdown = self.hip_xy_base @ to_world.T + cmd_world * touchdown_times_s(gait)[0]
        steps = []
        for j in range(gait.steps_per_plan):
            u = network_input_one(feet_xy, com, vel, cmd_xy, ctx.yaw_rad, ground_z)
            order, stand_position = split_stand(gait, self._order(self.model.scores(u), j))
            cells = (base_xy + hips_world)[:, None, :] + offsets_world[None]
            check = None
            if heights:
                cells = self.footholds.centred(terrain, cells.reshape(-1, 2)).reshape(cells.shape)
                check = self._height_check(terrain, feet_xy.copy(), base_xy + hips_touchdown, tops.copy(),
                                           ctx.yaw_rad)
                if j == 0:
                    promoted = self._swing_cornered_legs_first(order, cells, terrain, feet_xy, tops, base_xy,
                                                               to_world, cmd_world, ctx.yaw_rad)
                    if promoted is not order:  # a leg is cornered: it steps, the robot does not stand
                        order, stand_position = promoted, None
            step = prefer_stand(gait, first_safe_step(gait, order, cells, feet_xy, terrain, self.margin_m, check),
                                stand_position)
            if j == 0:
                self.last_candidates = CandidateRanking(gait, order, cells, terrain, self.margin_m,
                                                        step.action_index, check)
            steps.append(step)
            # The state a step later, as contactnet.cost.predicted_state predicts it.
            feet_xy[list(step.legs)] = step.footholds_xy_world
            if heights and step.legs:
                tops[list(step.legs)] = terrain.ground_z(step.footholds_xy_world)
                ground_z = sum(tops.tolist()) / len(tops)
            com[0:2] += shift
            com[2] = ground_z + ctx.com_height_ref_m
            base_xy += shift
            vel = np.array([cmd_world[0], cmd_world[1], 0.0])
        self._advance()
        return steps

    def replan_swing(self, ctx: PlanningContext, legs: tuple[int, ...]) -> PlannedStep | None:
        """The best safe landing of the swing group ``legs`` from the state ``ctx`` (their feet where they lifted
        off), the network's ranking restricted to that group's actions: a swing's new target after a disturbance
        (``contactnet.retarget``). None when none of them is safe."""
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

    def _swing_cornered_legs_first(self, order: np.ndarray, cells: np.ndarray, terrain: Terrain,
                                   feet_xy: np.ndarray, tops: np.ndarray, base_xy: np.ndarray, to_world: np.ndarray,
                                   cmd_world: np.ndarray, yaw_rad: float) -> np.ndarray:
        """The ranking with the actions that move a *cornered* leg forward first (each part in its own order):
        a leg whose shank, knee or thigh would reach the terrain if it stood where it is for
        ``CORNERED_LOOKAHEAD_STEPS`` more steps of the commanded motion (a hind foot behind a higher top, the
        body moving on over it). The network knows nothing of heights and may keep such a leg down until it
        touches. Actions that put a cornered leg further back are not promoted (that would corner it more)."""
        lookahead_s = CORNERED_LOOKAHEAD_STEPS * self.gait.step_duration_s
        ahead = base_xy + self.hip_xy_base @ to_world.T + cmd_world * lookahead_s
        clear = self.footholds.stance_clear(terrain, feet_xy, tops, ahead, yaw_rad)
        if clear.all():
            return order
        action_legs, action_cells = self.gait.action_cells
        legs = action_legs[order]  # (K, legs per step)
        forward = to_world[:, 0]
        progress = (cells[legs, action_cells[order]] - feet_xy[legs]) @ forward  # (K, legs per step)
        urgent = (~clear[legs] & (progress >= -CORNERED_BACKSTEP_M)).any(axis=1)
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


class FixedGaitPlanner(ContactNetPlanner):
    """The paper's fixed-gait baseline: the same network, restricted to a prescribed cyclic leg order (walk:
    HL, FL, HR, FR; trot: alternating diagonal pairs). Only the footholds are chosen (the best safe cell of
    the leg whose turn it is); with no safe cell that leg swings in place."""

    name = "fixed"

    def __init__(self, gait: GaitSpec, robot: RobotDescription, model,  # noqa: ANN001
                 margin_m: float | None = None) -> None:
        super().__init__(gait, robot, model, margin_m)
        self._next_group = 0

    def reset(self) -> None:
        super().reset()
        self._next_group = 0

    def _order(self, scores: np.ndarray, step_index: int) -> np.ndarray:
        cyclic = self.gait.cyclic_order
        group = cyclic[(self._next_group + step_index) % len(cyclic)]
        first = group * self.gait.actions_per_group
        own = scores[first : first + self.gait.actions_per_group]
        return first + np.argsort(-own, kind="stable")

    def _advance(self) -> None:
        self._next_group = (self._next_group + 1) % len(self.gait.cyclic_order)
