"""The walk down the network's ranking on a terrain with tops at several heights, compiled with numba: the planner's
hot loop with the height checks (``contactnet.planning.ranking.HeightsWalk``), as ``safe_walk`` is on one level.

``walk_step`` finds the action ``first_safe_step`` finds with ``FootholdChecker.usable`` as its check: in the stable
ascending order of the costs (NaN last), on a plan's first step with the actions that move a cornered leg forward
first (see ``contactnet.planning.cornered``), the first action whose landing points are all
placed (a small top's cell moved to its centre), safe and usable. It never sorts (the next action is a pass over the
costs away, a heap's after the first few), an unusable cell rules out every action using it, and each grid cell is
placed and checked at most once (the cheap checks of an action's cells before the rest of any of them)
per step, in straight loops over arrays (``contactnet.planning.heights_tables``: the terrain's rasters and outlines,
the robot's numbers). Cell by cell it computes what ``usable`` computes, in the same order of operations:

- the placement, safety, the top under the foot and the ring around the foot ball are exact: the rasters of
  ``contactnet.terrain.locate``, and next to an outline, where those ask shapely about the regions their cell
  touches, the same regions asked (``contactnet.planning.heights_lookup``). Where that cannot decide (a point within
  rounding of a segment's line; two parts with the same top; the safe region's outline), the walk stops and asks
  (``ASK`` with the question's slot), the caller answers in ``answers`` and calls again (as ``safe_walk`` asks);
- the swing path and the side of a leaning foot are the same floats as numpy's, so their checks are exact;
- the hip height at touchdown and the leg's outline go through ``atan2`` and ``acos``, which numpy computes with its
  own vector routines (an ulp from the C library's in about 1 case of 10), and the turn into the heading frame is
  a matrix product (BLAS, with fused multiply-adds). Their checks are decided here only when clear of their limit
  by more than ``EPS_M`` (1 um; the floats differ by less than 1e-8 m, near the leg's full stretch), and each
  outline point's raster cell only when every cell within ``EPS_M`` of it holds the same height; otherwise the
  walk asks (``UNSURE``) and the caller decides that landing with ``FootholdChecker.usable`` itself.

So each landing's verdict is ``usable``'s, and the choice ``first_safe_step``'s. ``stance_clear`` is
``FootholdChecker.stance_clear`` the same way (the cornered-leg test of every plan), a leg answering ``UNSURE_LEG``
when numpy must decide. The arrays reach the helpers as views that do not own their data (``borrow``): an owned
array argument costs two atomic reference-count updates per call, most of the time of the inner calls.
``tests/test_planner_fast.py`` and ``tests/test_heights_walk.py`` check the plans against the plain walk down the
ranking, each landing against ``evaluate`` and the lookups against shapely. The kernels are compiled on first use
and cached next to this file (``cache=True``), renewed when it changes: ``LOOKUP_SOURCE`` (the hash of
``heights_lookup.py``, whose code they inline) makes a change there a change here.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contactnet.planning.heights_lookup import (
    EPS_M,
    UNDECIDED,
    borrow,
    code_views,
    heap_after,
    height_at,
    next_action,
    order_keys,
    part_at,
    raster_cell,
    sift_down,
    terrain_views,
    tile_at,
    upper_at,
    upper_near,
)

#: The hash of ``heights_lookup.py`` (sha256, 16 hex digits) the kernels were written against (see its doc).
LOOKUP_SOURCE = "b805035ddd5a1998"

#: ``walk_step``'s status: an action found, none is usable, a question for the caller.
FOUND, NONE, ASK = 0, 1, 2
#: The questions, as slots of ``answers`` per grid cell: the top part under the cell's point, whether the landing
#: is safe, its top, the tops under the ring around the foot ball (``RING_POINTS`` slots, asked at once), and the
#: landing's ``usable`` itself (a check too close to its limit). ``CENTRE``: a top part's centre (``index`` the part).
PART, SAFE, TOP, RING = 0, 1, 2, 3
RING_POINTS = 8
UNSURE = RING + RING_POINTS
SLOTS = UNSURE + 1
CENTRE = SLOTS
#: Rows of ``cell_state`` per grid cell: placed (0 / 1), moved to its top's centre, its check (``UNKNOWN``,
#: ``USABLE``, ``UNUSABLE``, or ``PASSED`` the cheap ones: an action's cells all pass those before any is checked
#: whole), a spare row.
PLACED, CENTRED, CHECKED = 0, 1, 2
UNKNOWN, USABLE, UNUSABLE, PASSED = 0, 1, 2, 3
#: ``walk_step`` finds each of the first this many actions of a ranking by a pass over them all, the rest by a heap.
SCANS = 6
#: Below this height of the hip over the foot (the leg folded flat) the outline's lean is left to numpy.
MIN_RISE_M = 1e-3
#: ``stance_clear``'s answer per leg.
CLEAR, BLOCKED, UNSURE_LEG = 0, 1, 2
_QUESTION = -1  # ``_check`` / ``_place``: a question for the caller

# Rows of ``KernelConstants.legs`` (per leg) and entries of ``KernelConstants.scalars``.
(_KNEE_SIDE, _HIP_ABOVE, _PLANE_LEFT, _SHANK, _SQ_DIFF, _HIP_Z, _HIP_X, _SLOPE_W, _LATE, _KNEE_DIR, _HIP_BASE_X,
 _HIP_BASE_Y) = range(12)
(_FOOT_R, _FRONT_HIND, _PITCH_SHARE, _COM_H, _REACH, _MAX_LEAN, _LEVER_MARGIN, _MIN_LEVER, _TINY, _TRAVEL, _MAX_STEP,
 _BALL_TOL, _SMALL, _FALLBACK_ELEV, _KNOWN_KNEES, _N_LINES, _N_PATH, _N_SIDE, _N_SAMPLES) = range(19)


@numba.njit(cache=True, nogil=True, inline="always")
def _hip_z(tops: np.ndarray, leg: int, top: float, legs: np.ndarray, scalars: np.ndarray) -> float:
    """``FootholdChecker._landing_hip_z`` of one landing (the C library's atan2: within an ulp or so of numpy's)."""
    fl, fr, hl, hr = tops[0], tops[1], tops[2], tops[3]
    change = top - tops[leg]
    mean_top = (change + (((fl + fr) + hl) + hr)) * 0.25
    slope = legs[_SLOPE_W, leg] * change + (0.5 * (hl + hr) - 0.5 * (fl + fr))
    pitch = math.atan2(slope, scalars[_FRONT_HIND]) * scalars[_PITCH_SHARE]
    return ((mean_top + scalars[_COM_H]) + legs[_HIP_Z, leg] * math.cos(pitch)) - legs[_HIP_X, leg] * math.sin(pitch)


@numba.njit(cache=True, nogil=True)
def _outline(leg: int, x: float, y: float, foot_z: float, lever: float, rise: float, lean: float, c: float,
             s: float, legs: np.ndarray, scalars: np.ndarray, samples: np.ndarray, vectors: np.ndarray,
             rasters: np.ndarray, upper_codes: np.ndarray, code_z: np.ndarray, coarse: np.ndarray) -> int:
    """CLEAR, BLOCKED or UNSURE_LEG: the leg's lower outline in one pose (``FootholdChecker._leg_outline``, its points
    placed as ``_clear`` and ``_outline_points`` place them, ``lean`` the offset toward the leg's plane at the hip)
    against the terrain's upper bound, the foot at (x, y)."""
    if rise < MIN_RISE_M:
        return UNSURE_LEG
    dist = math.hypot(lever, rise)
    shank = legs[_SHANK, leg]
    cos_alpha = (legs[_SQ_DIFF, leg] + dist * dist) / ((2.0 * shank) * dist)
    elevation = math.atan2(rise, lever) - math.acos(min(max(cos_alpha, -1.0), 1.0))
    mirrored = scalars[_KNOWN_KNEES] == 0.0
    if mirrored and legs[_KNEE_SIDE, leg] == 0.0:
        elevation = scalars[_FALLBACK_ELEV]
    if not elevation > 0.0:  # np.fmax: NaN -> 0
        elevation = 0.0
    elevation = min(elevation, 0.5 * math.pi)
    extent = shank * math.cos(elevation)
    knee = shank * math.sin(elevation)
    direction = legs[_KNEE_DIR, leg]
    n_lines = int(scalars[_N_LINES])
    highest = rasters[3, 0]
    unsure = False
    for j in range(samples.shape[1]):
        distance = (extent * samples[0, j] + lever * samples[1, j]) + samples[2, j]
        up = knee * samples[0, j] + rise * samples[1, j]
        allowed = (foot_z + up) - samples[3, j]
        if highest - allowed <= -EPS_M:  # above every top
            continue
        lean_j = (lean * up) / rise
        along = direction * distance
        base_x, base_y = x + along * c, y + along * s
        low, high = -math.inf, -math.inf
        for i in range(n_lines):
            across = lean_j + vectors[i]
            px, py = base_x + across * (-s), base_y + across * c
            lo, hi = upper_near(px, py, allowed, rasters, upper_codes, code_z, coarse)
            low, high = max(low, lo), max(high, hi)
            if mirrored:
                lo, hi = upper_near(2.0 * x - px, 2.0 * y - py, allowed, rasters, upper_codes, code_z, coarse)
                low, high = max(low, lo), max(high, hi)
        if low - allowed > EPS_M:
            return BLOCKED
        if high - allowed > -EPS_M:
            unsure = True
    return UNSURE_LEG if unsure else CLEAR


@numba.njit(cache=True, nogil=True, inline="always")
def _usable(leg: int, x: float, y: float, top: float, at_centre: bool, liftoff_x: float, liftoff_y: float,
            hip_x: float, hip_y: float, tops: np.ndarray, c: float, s: float, legs: np.ndarray, scalars: np.ndarray,
            samples: np.ndarray, vectors: np.ndarray, rasters: np.ndarray, upper_codes: np.ndarray,
            code_z: np.ndarray, coarse: np.ndarray, quick: bool) -> int:
    """USABLE, UNUSABLE or -1 (a check too close to its limit) for a safe landing at (x, y) on ``top``: the checks of
    ``FootholdChecker.usable`` but the foot ball's ring (the caller's); ``quick``: all but the leg's outline."""
    foot_z = top + scalars[_FOOT_R]
    hip_z = _hip_z(tops, leg, top, legs, scalars)
    to_x, to_y = hip_x - x, hip_y - y
    ahead = to_x * c + to_y * s
    toward_plane = (to_x * (-s) + to_y * c) + legs[_PLANE_LEFT, leg]
    rise = hip_z - foot_z
    # 1. reach from the hip at touchdown, the leg leaning at most max_lean_m
    reach = math.sqrt((to_x * to_x + to_y * to_y) + rise * rise)
    if reach > scalars[_REACH] + EPS_M:
        return UNUSABLE
    if reach > scalars[_REACH] - EPS_M:
        return -1
    max_lean = scalars[_MAX_LEAN]
    leaning = abs(toward_plane) > max_lean + EPS_M
    if not leaning and abs(toward_plane) > max_lean - EPS_M:
        return -1
    n_lines, n_path = int(scalars[_N_LINES]), int(scalars[_N_PATH])
    highest = rasters[3, 0]  # (a check that no top could fail is skipped)
    if leaning:
        if at_centre:
            return UNUSABLE
        sign = 1.0 if toward_plane > 0.0 else -1.0
        limit = top + scalars[_BALL_TOL]
        if highest > limit:
            for i in range(int(scalars[_N_SIDE])):
                shift = sign * vectors[n_lines + n_path + i]
                side_x, side_y = x + shift * (-s), y + shift * c
                if tile_at(side_x, side_y, rasters, coarse, code_z) > limit:
                    if upper_at(side_x, side_y, rasters, upper_codes, code_z, coarse) > limit:
                        return UNUSABLE
    # 2. the swing: the step, and the terrain along the path
    start_top = tops[leg]
    if abs(top - start_top) - scalars[_MAX_STEP] > 0.0:
        return UNUSABLE
    higher = max(start_top, top)
    if (highest - higher) - scalars[_MAX_STEP] > 0.0:
        delta_x, delta_y = x - liftoff_x, y - liftoff_y
        for i in range(n_path):
            fraction = vectors[n_lines + i]
            path_x, path_y = liftoff_x + delta_x * fraction, liftoff_y + delta_y * fraction
            if (tile_at(path_x, path_y, rasters, coarse, code_z) - higher) - scalars[_MAX_STEP] > 0.0:
                z = upper_at(path_x, path_y, rasters, upper_codes, code_z, coarse)
                if (z - higher) - scalars[_MAX_STEP] > 0.0:
                    return UNUSABLE
    if quick:
        return USABLE
    # 4. the shin and the thigh, at touchdown and (a knee pointing forward) late in the stance
    side_k = legs[_KNEE_SIDE, leg]
    toward_knee = side_k * ahead if scalars[_KNOWN_KNEES] != 0.0 or side_k != 0.0 else abs(ahead)
    lever = max(toward_knee + scalars[_LEVER_MARGIN], scalars[_MIN_LEVER])
    nominal = legs[_HIP_ABOVE, leg]
    rise = min(max(hip_z - foot_z, scalars[_TINY]), nominal)
    lean = min(max(toward_plane, -max_lean), max_lean)
    first = _outline(leg, x, y, foot_z, lever, rise, lean, c, s, legs, scalars, samples, vectors, rasters,
                     upper_codes, code_z, coarse)
    if first == BLOCKED:
        return UNUSABLE
    late = CLEAR
    if legs[_LATE, leg] != 0.0:  # (else the late pose is the first)
        late = _outline(leg, x, y, foot_z, toward_knee + scalars[_TRAVEL], nominal, lean, c, s, legs, scalars,
                        samples, vectors, rasters, upper_codes, code_z, coarse)
        if late == BLOCKED:
            return UNUSABLE
    if first == UNSURE_LEG or late == UNSURE_LEG:
        return -1
    return USABLE


@numba.njit(cache=True, nogil=True, inline="always")
def _place(flat: int, n_cells: int, base_x: float, base_y: float, hips: np.ndarray, offsets: np.ndarray,
           cell_state: np.ndarray, points: np.ndarray, answers: np.ndarray, answered: np.ndarray,
           rasters: np.ndarray, cover_codes: np.ndarray, part_ints: np.ndarray, part_coords: np.ndarray,
           part_tops: np.ndarray, part_values: np.ndarray, scalars: np.ndarray) -> int:
    """Place grid cell ``flat`` (``points[flat]``: x, y, its top part; ``cell_state[CENTRED]``): 0, or _QUESTION
    (the PART slot of ``flat``)."""
    if cell_state[PLACED, flat]:
        return 0
    leg, cell = flat // n_cells, flat % n_cells
    x = (base_x + hips[leg, 0]) + offsets[cell, 0]
    y = (base_y + hips[leg, 1]) + offsets[cell, 1]
    points[flat, 0], points[flat, 1] = x, y
    if answered[flat, PART]:
        part = int(answers[flat, PART])
    else:
        part = part_at(x, y, rasters, cover_codes, part_ints, part_coords, part_tops)
        if part == UNDECIDED:
            return _QUESTION
    at_centre = part >= 0 and part_values[part, 0] <= scalars[_SMALL]
    if at_centre:
        points[flat, 0], points[flat, 1] = part_values[part, 1], part_values[part, 2]
    points[flat, 2] = part
    cell_state[CENTRED, flat] = at_centre
    cell_state[PLACED, flat] = 1
    return 0


@numba.njit(cache=True, nogil=True)
def _check(flat: int, n_cells: int, feet: np.ndarray, tops: np.ndarray, hips_touchdown: np.ndarray, c: float,
           s: float, cell_state: np.ndarray, points: np.ndarray, answers: np.ndarray, answered: np.ndarray,
           rasters: np.ndarray, safe_codes: np.ndarray, height_codes: np.ndarray, upper_codes: np.ndarray,
           code_z: np.ndarray, coarse: np.ndarray, region_ints: np.ndarray, region_coords: np.ndarray,
           region_tops: np.ndarray, part_values: np.ndarray, legs: np.ndarray, scalars: np.ndarray,
           samples: np.ndarray, vectors: np.ndarray, quick: bool) -> tuple[int, int, int]:
    """(USABLE or UNUSABLE, 0, 0), or (_QUESTION, kind, index), for placed grid cell ``flat``: safe and usable.
    ``quick``: the cheap checks only (all but the leg's outline and the ball's ring), PASSED if they pass."""
    leg = flat // n_cells
    x, y, part = points[flat, 0], points[flat, 1], int(points[flat, 2])
    at_centre = cell_state[CENTRED, flat] != 0
    if at_centre:
        if part_values[part, 5] < 0.0:
            return _QUESTION, CENTRE, part
        if part_values[part, 5] == 0.0:  # not safe
            return UNUSABLE, 0, 0
        top = part_values[part, 3]
    else:
        if answered[flat, SAFE]:
            safe = answers[flat, SAFE] != 0.0
        else:
            code = safe_codes[raster_cell(x, y, rasters, 1)]
            if code == 2:  # next to an outline
                return _QUESTION, SAFE, flat
            safe = code == 1
        if not safe:
            return UNUSABLE, 0, 0
        if answered[flat, TOP]:
            top = answers[flat, TOP]
        else:
            top, decided = height_at(x, y, rasters, height_codes, code_z, region_ints, region_coords, region_tops)
            if not decided:
                return _QUESTION, TOP, flat
    if top != top:  # no top
        return UNUSABLE, 0, 0
    points[flat, 3] = top
    if answered[flat, UNSURE]:
        return (USABLE if answers[flat, UNSURE] != 0.0 else UNUSABLE), 0, 0
    result = _usable(leg, x, y, top, at_centre, feet[leg, 0], feet[leg, 1], hips_touchdown[leg, 0],
                     hips_touchdown[leg, 1], tops, c, s, legs, scalars, samples, vectors, rasters, upper_codes, code_z,
                     coarse, quick)
    if result == UNUSABLE:
        return UNUSABLE, 0, 0
    if quick:
        return PASSED, 0, 0
    # 3. the ball's side: no higher top on the ring around it (exact heights)
    limit = top + scalars[_BALL_TOL]
    if at_centre:
        if part_values[part, 4] == 0.0:  # no room for the ball
            return UNUSABLE, 0, 0
    elif answered[flat, RING]:
        for r in range(RING_POINTS):
            if answers[flat, RING + r] > limit:
                return UNUSABLE, 0, 0
    elif rasters[3, 0] > limit:  # (else no top is higher)
        ring = int(scalars[_N_LINES] + scalars[_N_PATH] + scalars[_N_SIDE])
        for r in range(RING_POINTS):
            z, decided = height_at(x + vectors[ring + 2 * r], y + vectors[ring + 2 * r + 1], rasters, height_codes,
                                   code_z, region_ints, region_coords, region_tops)
            if not decided:
                return _QUESTION, RING, flat
            if z > limit:  # (NaN: no top)
                return UNUSABLE, 0, 0
    if result < 0:
        return _QUESTION, UNSURE, flat
    return USABLE, 0, 0


@numba.njit(cache=True, nogil=True)
def stance_clear(feet: np.ndarray, tops: np.ndarray, hips: np.ndarray, c: float, s: float, legs: np.ndarray,
                 scalars: np.ndarray, samples: np.ndarray, vectors: np.ndarray, rasters: np.ndarray,
                 upper_codes: np.ndarray, code_z: np.ndarray, coarse: np.ndarray) -> np.ndarray:
    """(4,) CLEAR, BLOCKED or UNSURE_LEG: ``FootholdChecker.stance_clear`` of each leg standing at ``feet`` (4, 2) on
    ``tops`` (4,), its hip at ``hips`` (4, 2)."""
    result = np.empty(4, dtype=np.int8)
    for leg in range(4):
        top = tops[leg]
        if top != top:
            result[leg] = CLEAR
            continue
        to_x, to_y = hips[leg, 0] - feet[leg, 0], hips[leg, 1] - feet[leg, 1]
        ahead = to_x * c + to_y * s
        toward_plane = (to_x * (-s) + to_y * c) + legs[_PLANE_LEFT, leg]
        foot_z = top + scalars[_FOOT_R]
        rise = min(max(_hip_z(tops, leg, top, legs, scalars) - foot_z, scalars[_TINY]), legs[_HIP_ABOVE, leg])
        side_k = legs[_KNEE_SIDE, leg]
        lever = side_k * ahead if scalars[_KNOWN_KNEES] != 0.0 or side_k != 0.0 else abs(ahead)
        result[leg] = _outline(leg, feet[leg, 0], feet[leg, 1], foot_z, lever, rise, toward_plane, c, s, legs,
                               scalars, samples, vectors, rasters, upper_codes, code_z, coarse)
    return result


# The plan's numbers (``HeightsWalk.plan``): the cornered legs' least progress, ``surface_z``, the touchdown time and
# the cornered legs' look-ahead (s) (a planner's constants); then the heading's cosine and sine (the C library's, as
# ``FootholdChecker`` takes them), the forward direction (numpy's), the commanded velocity (world), the hips' offsets
# from the base (world, 4 x 2, ``prepare`` turns them), the feet (4 x 2), the tops under them (4; NaN: not known yet);
# then each step's base for the candidate grid, and each step's base for the hips (2 each).
_MIN_PROGRESS, _SURFACE, _TOUCHDOWN, _LOOKAHEAD, _COS, _SIN, _FORWARD_C, _FORWARD_S, _CMD_X, _CMD_Y = range(10)
MIN_PROGRESS, PER_PLAN = _MIN_PROGRESS, _COS
_HIPS, FEET, TOPS, _BASES = 10, 18, 26, 30
#: ``walk_step``'s question about the cornered legs (numpy's ``stance_clear`` decides: a leg too close to its limit).
STANCE = CENTRE + 1


@numba.njit(cache=True, nogil=True, inline="always")
def _constant_views(constants: np.ndarray) -> tuple:
    """``KernelConstants.floats`` unpacked: (scalars, legs (12, 4), samples (4, S), vectors)."""
    constants = borrow(constants)
    n = int(constants[0])
    scalars = constants[1: 1 + n]
    samples_at = 1 + n + 48
    s = int(scalars[_N_SAMPLES])
    return (scalars, constants[1 + n: samples_at].reshape((12, 4)),
            constants[samples_at: samples_at + 4 * s].reshape((4, s)), constants[samples_at + 4 * s:])


@numba.njit(cache=True, nogil=True)
def prepare(plan: np.ndarray, floats: np.ndarray, ints: np.ndarray, wide_codes: np.ndarray,
            narrow_codes: np.ndarray, constants: np.ndarray) -> int:
    """The start of a plan: the hips from the base in the world frame, and the tops under the feet
    (``Terrain.ground_z``) where ``plan`` has NaN. -1 when done, else a leg whose top only shapely can tell."""
    rasters, code_z, _, _, region_coords, _, region_tops, _, region_ints = terrain_views(floats, ints)
    plan, height_codes = borrow(plan), code_views(borrow(ints), wide_codes, narrow_codes)[2]
    legs = _constant_views(constants)[1]
    c, s = plan[_FORWARD_C], plan[_FORWARD_S]
    for leg in range(4):  # the hips from the base, turned into the world (as ``hip_xy_base @ to_world.T``)
        x, y = legs[_HIP_BASE_X, leg], legs[_HIP_BASE_Y, leg]
        plan[_HIPS + 2 * leg] = x * c + y * (-s)
        plan[_HIPS + 2 * leg + 1] = x * s + y * c
    for leg in range(4):
        if plan[TOPS + leg] != plan[TOPS + leg]:
            z, decided = height_at(plan[FEET + 2 * leg], plan[FEET + 2 * leg + 1], rasters, height_codes, code_z,
                                   region_ints, region_coords, region_tops)
            if not decided:
                return leg
            plan[TOPS + leg] = plan[_SURFACE] if z != z else z
    return -1


@numba.njit(cache=True, nogil=True)
def walk_step(costs: np.ndarray, first: int, stop: int, step: int, fresh: int, moved: int, action_flat: np.ndarray,
              hips_world: np.ndarray, offsets: np.ndarray, plan: np.ndarray, flags: np.ndarray, values: np.ndarray,
              floats: np.ndarray, ints: np.ndarray, wide_codes: np.ndarray, narrow_codes: np.ndarray,
              constants: np.ndarray) -> tuple:
    """(status, rank, action, kind, index, x, y, top of the action's first landing point, x, y, top of its last) of
    step ``step`` of a plan: the first usable action of ``first..stop - 1`` in the stable ascending order of their
    ``costs`` (NaN last); on the first step the cornered legs are found (``stance_clear`` with the hips ``plan``'s
    look-ahead further; ``kind`` then has a bit per cornered leg) and the actions moving one forward go first
    (``urgent``). For ``ASK``: the question (``kind``: a slot of ``answers`` of grid cell ``index``, ``CENTRE`` of top
    part ``index`` or ``STANCE``); the caller answers and calls again with ``fresh`` 0 (1 after ``STANCE``, the
    cornered legs filled in; the first call of a step: 2). ``moved``: the action the previous step took (its cells
    still in the scratch), whose legs now stand where it landed them; -1 for none.

    A grid cell ``flat`` (leg * cells per leg + cell) is (base + hips_world[leg]) + offsets[cell] (world), or its
    small top's centre. ``plan``: the plan's numbers (``HeightsWalk``: the feet and the tops under them now);
    ``flags`` and ``values`` the step's scratch (``Scratch``); ``floats``, ``ints`` and the codes the
    terrain's (``TerrainTables``); ``constants`` the checker's (``KernelConstants.floats``).

    The urgent actions are found lazily: an action is urgent when one of its cells on a cornered leg, placed, lies
    at least the least progress ahead of the foot along the forward direction; the walk places such cells only for
    the actions it needs to order (the cheapest ones, and those ranked before the choice)."""
    costs, action_flat, hips_world, offsets = borrow(costs), borrow(action_flat), borrow(hips_world), borrow(offsets)
    plan, flags, values = borrow(plan), borrow(flags), borrow(values)
    cover_codes, safe_codes, height_codes, upper_codes, coarse = code_views(borrow(ints), wide_codes, narrow_codes)
    n_cells = offsets.shape[0]
    cells, n_actions, per_action = 4 * n_cells, action_flat.shape[0], action_flat.shape[1]
    state_end = 4 * cells + cells * SLOTS
    cell_state = flags[: 4 * cells].reshape((4, cells))
    answered = flags[4 * cells: state_end].reshape((cells, SLOTS))
    urgent = flags[state_end: state_end + n_actions]  # 0 not known yet, 1 no, 2 yes
    cornered = flags[state_end + n_actions: state_end + n_actions + 4]
    points = values[: 4 * cells].reshape((cells, 4))
    answers = values[4 * cells: 4 * cells + cells * SLOTS].reshape((cells, SLOTS))
    work = 4 * cells + cells * SLOTS  # then room for the hips, the order's keys and a heap
    hips = values[work: work + 8].reshape((4, 2))
    keys = order_keys(costs, first, stop, values[work + 8: work + 8 + n_actions])
    heap = values[work + 8 + n_actions: work + 8 + 2 * n_actions].view(np.int64)
    (rasters, code_z, part_values, part_coords, region_coords, part_tops, region_tops, part_ints,
     region_ints) = terrain_views(floats, ints)
    scalars, legs, samples, vectors = _constant_views(constants)
    steps = (plan.shape[0] - _BASES) // 4
    base_x, base_y = plan[_BASES + 2 * step], plan[_BASES + 2 * step + 1]
    hip_x, hip_y = plan[_BASES + 2 * steps + 2 * step], plan[_BASES + 2 * steps + 2 * step + 1]
    feet = plan[FEET: FEET + 8].reshape((4, 2))
    tops = plan[TOPS: TOPS + 4]
    c, s, forward_x, forward_y = plan[_COS], plan[_SIN], plan[_FORWARD_C], plan[_FORWARD_S]
    min_progress = plan[_MIN_PROGRESS]
    if moved >= 0:  # the previous step's action was taken: its legs stand where it landed them
        for k in range(per_action):
            flat = action_flat[moved, k]
            leg = flat // n_cells
            feet[leg, 0], feet[leg, 1], tops[leg] = points[flat, 0], points[flat, 1], points[flat, 3]
    if fresh:
        flags[:state_end] = 0
        if step != 0:
            cornered[:] = 0
        elif fresh == 2:  # the cornered legs: their lower legs against the terrain, the body further on
            for leg in range(4):
                hips[leg, 0] = (hip_x + plan[_HIPS + 2 * leg]) + plan[_CMD_X] * plan[_LOOKAHEAD]
                hips[leg, 1] = (hip_y + plan[_HIPS + 2 * leg + 1]) + plan[_CMD_Y] * plan[_LOOKAHEAD]
            stance = stance_clear(feet, tops, hips, c, s, legs, scalars, samples, vectors, rasters, upper_codes,
                                  code_z, coarse)
            for leg in range(4):
                if stance[leg] == UNSURE_LEG:
                    return ASK, 0, -1, STANCE, leg, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            for leg in range(4):
                cornered[leg] = stance[leg] == BLOCKED
    cornered_bits = cornered[0] + 2 * cornered[1] + 4 * cornered[2] + 8 * cornered[3]
    if fresh:  # an action with no cell on a cornered leg is not urgent (1); the others are not known yet (0)
        urgent[first:stop] = 1
        if cornered_bits:
            for a in range(first, stop):
                for k in range(per_action):
                    if cornered[action_flat[a, k] // n_cells]:
                        urgent[a] = 0
    for leg in range(4):  # hips at touchdown: the step's base + (hip offset + velocity x touchdown time)
        hips[leg, 0] = hip_x + (plan[_HIPS + 2 * leg] + plan[_CMD_X] * plan[_TOUCHDOWN])
        hips[leg, 1] = hip_y + (plan[_HIPS + 2 * leg + 1] + plan[_CMD_Y] * plan[_TOUCHDOWN])
    # The actions in the ranking's order: first the urgent ones (only actions with a cell on a cornered leg can be),
    # then the others. ``position``: how many of the phase's actions came before; its rank adds the urgent ones
    # before the others.
    urgent_total = 0
    for phase in range(2):
        if phase == 0 and not cornered_bits:
            continue
        position, a, n = 0, -1, -1
        skip = 1 if phase == 0 else 2
        while True:  # the next action: a pass for each of the first SCANS, then out of a heap of the rest
            if position < SCANS:
                a = next_action(keys, first, stop, urgent, skip, a)
                if a < 0:
                    break
            else:
                if n < 0:
                    n = heap_after(heap, keys, first, stop, urgent, skip, a)
                if n == 0:
                    break
                a = heap[0]
                n -= 1
                if n > 0:
                    heap[0] = heap[n]
                    sift_down(heap, 0, n, keys, first)
            if phase == 0 and urgent[a] == 0:  # is it urgent?
                urgent[a] = 1
                for k in range(per_action):
                    flat = action_flat[a, k]
                    leg = flat // n_cells
                    if cornered[leg]:
                        if _place(flat, n_cells, base_x, base_y, hips_world, offsets, cell_state, points, answers,
                                  answered, rasters, cover_codes, part_ints, part_coords, part_tops, part_values,
                                  scalars) < 0:
                            urgent[a] = 0
                            return ASK, 0, a, PART, flat, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                        progress = ((points[flat, 0] - feet[leg, 0]) * forward_x
                                    + (points[flat, 1] - feet[leg, 1]) * forward_y)
                        if progress >= min_progress:
                            urgent[a] = 2
            if urgent[a] != (2 if phase == 0 else 1):
                continue
            usable = True
            for k in range(2 * per_action):  # the cheap checks of every cell first, then the rest
                flat = action_flat[a, k % per_action]
                state = cell_state[CHECKED, flat]
                if state == (UNKNOWN if k < per_action else PASSED):
                    if _place(flat, n_cells, base_x, base_y, hips_world, offsets, cell_state, points, answers,
                              answered, rasters, cover_codes, part_ints, part_coords, part_tops, part_values,
                              scalars) < 0:
                        return ASK, 0, a, PART, flat, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                    state, kind, index = _check(flat, n_cells, feet, tops, hips, c, s, cell_state, points,
                                                answers, answered, rasters, safe_codes, height_codes, upper_codes,
                                                code_z, coarse, region_ints, region_coords, region_tops,
                                                part_values, legs, scalars, samples, vectors, k < per_action)
                    if state == _QUESTION:
                        return ASK, 0, a, kind, index, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                    cell_state[CHECKED, flat] = state
                if state == UNUSABLE:
                    usable = False
                    break
            if usable:
                first_cell, last_cell = action_flat[a, 0], action_flat[a, per_action - 1]  # (the same for one)
                return (FOUND, urgent_total + position, a, cornered_bits, 0, points[first_cell, 0],
                        points[first_cell, 1], points[first_cell, 3], points[last_cell, 0], points[last_cell, 1],
                        points[last_cell, 3])
            position += 1
        urgent_total = position  # (every urgent action came before the others, none usable)
    return NONE, -1, -1, cornered_bits, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


__all__ = ["ASK", "FOUND", "LOOKUP_SOURCE", "NONE", "prepare", "stance_clear", "walk_step"]
