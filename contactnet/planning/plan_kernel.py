"""A whole plan of ``ContactNetPlanner`` on a terrain of one level in one compiled call: its common path.

``ContactNetPlanner._plan_one_level`` makes each of a plan's three steps in Python: the network's input from the
state (``network_input_values``), the forward pass (``network_kernel.forward_one``), the walk down the ranking to
the first safe action (``safe_walk``), the stand choice (``stand.network_stands``), and the state a step later.
Each of these is a few microseconds of compiled or numpy work, but the calls between them cost more than the work:
about two thirds of a plan (line-profiled on Go2's walk). Here the same operations, on the same floats in the
same order, run in one call (``plan_steps``), and Python only wraps the answer (``CompiledOneLevel.plan``).

It covers the path almost every plan takes while walking: a network planner (the numpy network), no zero command
with a balanced state (the idle rule), no useless-swing rule (``IdleConfig.step_when_moving``). Anything else a plan
meets (a leg left behind, ``contactnet.planning.reach``; a landing point on an outline
that only shapely can decide, no safe action and no stand) stops it: it returns how many steps it made, and the
planner then makes the whole plan in Python (the reference: ``tests/test_plan_kernel.py``
checks that both give the same plans, step by step, on fields with and without holes, pushes, both gaits and the
fixed gait, Solo12 and Go2).
"""

from __future__ import annotations

import numba
import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning.network import NumpyContactNet
from contactnet.planning.network_kernel import forward_one
from contactnet.planning.ranking import ActionCells, PlannedStep
from contactnet.planning.safe_walk import ASK, FOUND, NONE, first_safe, first_safe_with_room
from contactnet.planning.stand import TOP_RANK_TIE, stand_step
from contactnet.terrain.locate import PointLocator

#: ``plan_steps``' kinds of step: a step of an action, or standing chosen from the network's stand output.
STEP, STAND = 0, 1


@numba.njit(cache=True, nogil=True)
def _network_input(feet: np.ndarray, com_x: float, com_y: float, com_z: float, vel_x: float, vel_y: float,
                   vel_z: float, cmd_x: float, cmd_y: float, c: float, s: float, ground_z: float,
                   u: np.ndarray) -> None:
    """``network_input_values`` into ``u`` (14,), the same float64 operations (then rounded to ``u``'s dtype, as
    ``np.array(values, dtype)`` rounds them)."""
    for leg in range(4):
        dx = feet[leg, 0] - com_x
        dy = feet[leg, 1] - com_y
        u[2 * leg] = c * dx + s * dy
        u[2 * leg + 1] = -s * dx + c * dy
    u[8] = com_z - ground_z
    u[9] = c * vel_x + s * vel_y
    u[10] = -s * vel_x + c * vel_y
    u[11] = vel_z
    u[12] = cmd_x
    u[13] = cmd_y


@numba.njit(cache=True, nogil=True)
def plan_steps(feet: np.ndarray, com: np.ndarray, vel: np.ndarray, cmd: np.ndarray, cmd_world: np.ndarray,
               cos_yaw: float, sin_yaw: float, ground_z: float, com_z: float, shift_x: float, shift_y: float,
               bases: np.ndarray, spans: np.ndarray, n_actions: int, may_stand: bool, stand_first: bool,
               weights: tuple, biases: tuple, u: np.ndarray, costs_out: np.ndarray, per_group: int,
               ahead_x: float, ahead_y: float, with_room: bool, action_flat: np.ndarray, leg_cell: np.ndarray,
               hips: np.ndarray, offsets: np.ndarray, raster: np.ndarray, codes: np.ndarray, entries: np.ndarray,
               row_first: np.ndarray, behind_x: float, behind_y: float,
               behind_threshold: float, result: np.ndarray, points: np.ndarray) -> int:
    """The plan's steps, as ``ContactNetPlanner._plan_one_level`` makes them on its common path; returns how many it
    made (all ``bases.shape[0]``, or fewer where it stopped: the caller then plans in Python).

    ``feet`` (4, 2) world XY (changed: the feet a step later), ``com``, ``vel`` (3,) world, ``cmd`` (2,) the command
    (heading frame) and ``cmd_world`` (2,) in the world, the yaw's cosine and sine, the ground's and the predicted
    CoM's height, the CoM's shift per step, ``bases`` (steps, 2) the base XY of each step's grid, ``spans``
    (steps, 2) the actions each step ranks. The network (``weights``, ``biases``: the negated network, its output the
    costs) writes each step's costs into ``costs_out`` (steps, outputs); ``u`` (14,) of its dtype holds the input.
    Standing may be chosen when ``may_stand`` and the network has the stand output (``stand_first`` False: not at
    the first step, a pushed robot steps). ``with_room``: with room ``ahead`` for the foot's roll
    (``safe_walk.first_safe_with_room``, ``per_group`` actions a swing group); the rest is the walk's terrain
    (``safe_walk.first_safe``). Per step ``result`` (steps, 3) gets (kind, rank, action) and ``points`` (steps,
    legs per step, 2) the landing points of a step. It stops at once when a leg is left behind
    (``contactnet.planning.reach.left_behind``: its foot further than ``behind_threshold`` from its hip reference
    moved by ``behind``; a threshold 0 for no such test)."""
    steps = bases.shape[0]
    cells = leg_cell.shape[0]
    legs_per_step = action_flat.shape[1]
    has_stand = costs_out.shape[1] > n_actions and may_stand
    com_x, com_y, com_z0 = com[0], com[1], com[2]
    vel_x, vel_y, vel_z = vel[0], vel[1], vel[2]
    if behind_threshold > 0.0:
        limit = behind_threshold * behind_threshold
        for leg in range(4):
            dx = feet[leg, 0] - (bases[0, 0] + hips[leg, 0]) - behind_x
            dy = feet[leg, 1] - (bases[0, 1] + hips[leg, 1]) - behind_y
            if dx * dx + dy * dy > limit:
                return 0
    for j in range(steps):
        _network_input(feet, com_x, com_y, com_z0, vel_x, vel_y, vel_z, cmd[0], cmd[1], cos_yaw, sin_yaw, ground_z, u)
        out = costs_out[j]
        forward_one(u, weights, biases, out)
        costs = out[:n_actions]
        stands_allowed = has_stand and (j > 0 or stand_first)
        base_x, base_y = bases[j, 0], bases[j, 1]
        first, stop = spans[j, 0], spans[j, 1]
        if codes.size == 0:  # no safe region at all
            status, rank, action = NONE, -1, -1
        elif with_room:
            status, rank, action = first_safe_with_room(
                costs, first, stop, per_group, action_flat, leg_cell, hips, offsets, base_x, base_y, raster, codes,
                entries, row_first, np.zeros(cells, np.int8), np.zeros(cells, np.int8), ahead_x, ahead_y)
        else:
            status, rank, action = first_safe(costs, first, stop, action_flat, leg_cell, hips, offsets, base_x,
                                              base_y, raster, codes, entries, row_first,
                                              np.zeros(cells, np.int8), 0.0, 0.0)
        if status == ASK:
            return j
        found = status == FOUND
        stand = False
        if stands_allowed:  # stand.network_stands, in float64 as there
            stand_cost = float(out[n_actions])
            stand = (not found or stand_cost < float(costs[action])
                     or -stand_cost >= 1.0 - TOP_RANK_TIE / n_actions)
        if stand:
            result[j, 0], result[j, 1], result[j, 2] = STAND, 0, -1
        elif not found:  # nothing safe: the planner steps in place (Python)
            return j
        else:
            result[j, 0], result[j, 1], result[j, 2] = STEP, rank, action
            for k in range(legs_per_step):
                flat = action_flat[action, k]
                leg, cell = leg_cell[flat, 0], leg_cell[flat, 1]
                x = (base_x + hips[leg, 0]) + offsets[cell, 0]
                y = (base_y + hips[leg, 1]) + offsets[cell, 1]
                points[j, k, 0], points[j, k, 1] = x, y
                feet[leg, 0], feet[leg, 1] = x, y
        com_x, com_y, com_z0 = com_x + shift_x, com_y + shift_y, com_z
        vel_x, vel_y, vel_z = cmd_world[0], cmd_world[1], 0.0
    return steps


class CompiledOneLevel:
    """A planner's constants for ``plan_steps`` (its negated network, its actions as grid cells), and the plan it
    makes (``plan``)."""

    def __init__(self, gait: GaitSpec, cost_net: NumpyContactNet, actions: ActionCells) -> None:
        self.gait = gait
        self.weights, self.biases = cost_net._layers
        self.dtype = cost_net.dtype
        self.n_out = cost_net.n_actions
        self.actions = actions
        self.n_actions, self.per_group = gait.n_actions, gait.actions_per_group

    def plan(self, feet: np.ndarray, com: np.ndarray, vel: np.ndarray, cmd: np.ndarray, cmd_world: list[float],
             cos_yaw: float, sin_yaw: float, ground_z: float, com_z: float, shift_x: float, shift_y: float,
             bases: list[list[float]], spans: np.ndarray, may_stand: bool, stand_first: bool,
             ahead: tuple[float, float] | None, locator: PointLocator, hips_world: np.ndarray,
             offsets_world: np.ndarray,
             reach: tuple[float, float, float] | None) -> tuple[list[PlannedStep], np.ndarray] | None:
        """The plan's steps and the first step's costs (N_a,: its ranking's), or None (plan in Python). ``feet``
        (4, 2) is changed; ``may_stand``: standing may be chosen (not by the fixed gait), ``stand_first``: at the
        first step too (not by a pushed robot); ``ahead`` None: no room for the roll; ``locator``: where landing is
        safe (``Terrain.safe_locator``); ``reach``: the left-behind test's shift and threshold (None: no test); the
        rest as ``plan_steps`` takes it."""
        gait, actions, n_actions = self.gait, self.actions, self.n_actions
        steps = len(bases)
        costs = np.empty((steps, self.n_out), dtype=self.dtype)
        result = np.empty((steps, 3), dtype=np.int64)
        points = np.empty((steps, actions.legs_per_step, 2))
        outline = locator.outline
        ahead_x, ahead_y = ahead if ahead is not None else (0.0, 0.0)
        behind_x, behind_y, behind_threshold = reach if reach is not None else (0.0, 0.0, 0.0)
        made = plan_steps(feet, com, vel, cmd, np.array(cmd_world), cos_yaw, sin_yaw, ground_z, com_z, shift_x, shift_y,
                          np.array(bases), spans, n_actions, may_stand, stand_first, self.weights, self.biases,
                          np.empty(14, dtype=self.dtype), costs, self.per_group, ahead_x, ahead_y,
                          ahead is not None, actions.flat_array, actions.leg_cell_array, hips_world, offsets_world,
                          locator.raster, locator.codes, outline.entries, outline.row_first,
                          behind_x, behind_y, behind_threshold, result, points)
        if made < steps:
            return None
        planned = []
        group = actions.group
        for j, (kind, rank, action) in enumerate(result.tolist()):
            if kind == STAND:
                planned.append(stand_step(gait, costs[j, :n_actions], float(costs[j, n_actions])))
            else:
                planned.append(PlannedStep.ranked(group[action], points[j], action, rank))
        return planned, costs[0, :n_actions]


__all__ = ["STAND", "STEP", "CompiledOneLevel", "plan_steps"]
