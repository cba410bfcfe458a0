"""The left-right mirror of a ranking instance: twice the training data for free (``contactnet train --mirror``).

A quadruped and its candidate grids are symmetric about the base's x-z plane: mirroring a state (every y, the
lateral velocity and the command's y negated, the left and right legs swapped) mirrors its best footholds. So an
instance (inputs u, costs V of every choice) gives a second one: u mirrored (`mirror_inputs`), V with its choices
permuted (`choice_mirror`: action ``a`` swings the mirrored legs onto the mirrored cells of action
``choice_mirror(gait)[a]``; standing stays standing). The ranking cost's labels then hold up to the robot's own
asymmetry (a CoM a few millimetres off the centre line, an inertia with small products): ``tests/test_mirror.py``
evaluates the cost (`contactnet.planning.cost.RankingCost`, the optimizer included) on a state and its mirror and
compares, for Solo12 and Go2.

Only the training split is mirrored; the test split is the data as generated, so the test top-5 stays the
paper's figure.
"""

from __future__ import annotations

import numpy as np

from contactnet.motion.gait import GaitSpec
from contactnet.planning.network_input import INPUT_NAMES, N_INPUTS
from contactnet.robots.description import LEG_NAMES

#: Legs swapped by the mirror: FL <-> FR, HL <-> HR (indices into ``LEG_NAMES``).
MIRROR_LEGS = np.array([LEG_NAMES.index(name[0] + {"L": "R", "R": "L"}[name[1]]) for name in LEG_NAMES])


def _input_map() -> tuple[np.ndarray, np.ndarray]:
    """(source index, sign) per input: mirrored u[i] = sign[i] * u[source[i]]."""
    source = np.arange(N_INPUTS)
    sign = np.ones(N_INPUTS, dtype=np.float32)
    position = {name: index for index, name in enumerate(INPUT_NAMES)}
    for leg, other in enumerate(MIRROR_LEGS):
        for axis in ("x", "y"):
            here = position[f"{LEG_NAMES[leg]}_{axis}_com"]
            source[here] = position[f"{LEG_NAMES[other]}_{axis}_com"]
            sign[here] = -1.0 if axis == "y" else 1.0
    for name in ("com_vy", "cmd_vy"):
        sign[position[name]] = -1.0
    return source, sign


_SOURCE, _SIGN = _input_map()


def mirror_inputs(u: np.ndarray) -> np.ndarray:
    """The network inputs (..., 14) of the mirrored states (``INPUT_NAMES`` order), same dtype."""
    u = np.asarray(u)
    return (u[..., _SOURCE] * _SIGN).astype(u.dtype, copy=False)


def choice_mirror(gait: GaitSpec, n_choices: int | None = None) -> np.ndarray:
    """(n_choices,) permutation: the mirrored instance's cost of choice ``j`` is the original's cost of choice
    ``perm[j]`` (an involution). ``n_choices``: ``gait.n_actions`` (stepping actions only) or ``gait.n_choices``
    (standing last, mapped to itself; the default). ValueError for a gait whose grid or swing groups are not
    symmetric."""
    n_choices = gait.n_choices if n_choices is None else int(n_choices)
    if n_choices not in (gait.n_actions, gait.n_choices):
        raise ValueError(f"{gait.name}: {n_choices} choices; the gait has {gait.n_actions} actions (+1 standing)")
    swing, offsets = gait.action_table
    mirrored_swing = swing[:, MIRROR_LEGS]
    mirrored_offsets = offsets[:, MIRROR_LEGS] * np.array([1.0, -1.0])
    key = {(tuple(s), tuple(np.round(o, 9).ravel())): index for index, (s, o) in enumerate(zip(swing, offsets, strict=True))}
    perm = np.arange(n_choices)
    for index in range(gait.n_actions):
        match = key.get((tuple(mirrored_swing[index]), tuple(np.round(mirrored_offsets[index], 9).ravel())))
        if match is None:
            raise ValueError(f"{gait.name}: action {index} has no mirror image (the grid or the swing groups are "
                             "not symmetric about the base's x-z plane)")
        perm[index] = match
    return perm


def mirrored(u: np.ndarray, V: np.ndarray, gait: GaitSpec) -> tuple[np.ndarray, np.ndarray]:
    """The mirrored instances of inputs ``u`` (n, 14) and costs ``V`` (n, choices)."""
    return mirror_inputs(u), np.ascontiguousarray(V[:, choice_mirror(gait, V.shape[1])])
