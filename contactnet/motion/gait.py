"""Walk and trot as in the paper: step timing, the candidate foothold grid, and the action index.

An *action* is one step: which leg(s) swing and where each lands. The landing spots are a fixed
grid of offsets around each leg's *hip reference*: the nominal foot position under the hip, moved
with the robot (the paper's "fixed offsets from the current hip position"). Offsets are in the
horizontal body frame (x forward, y left, rotated by the base yaw only).

Action indices (0 .. N_a - 1) map one-to-one to (swing group, one grid cell per swinging leg):
- walk: 4 groups of one leg, 5 x 5 cells at 5 cm (20 x 20 cm): N_a = 4 * 25 = 100,
  index = leg * 25 + cell;
- trot: 2 diagonal pairs, 3 x 3 cells at 5 cm (10 x 10 cm) per leg: N_a = 2 * 9 * 9 = 162,
  index = pair * 81 + cell_of_first_leg * 9 + cell_of_second_leg.
A grid cell is `cell = ix * n + iy`, ix counting along +x (back to front), iy along +y (right to left).

Beside the stepping actions there is one more *choice*: **stand** (``GaitSpec.stand_index`` = N_a), no leg
swings for the next step horizon, all four feet stay in stance. The ranking cost scores it like any action
(``contactnet.planning.cost``) and a network trained on those costs has N_a + 1 outputs (``GaitSpec.n_choices``); a
model with N_a outputs (trained before the stand choice existed) never stands.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from contactnet.frames import rotation_2d
from contactnet.motion.cost_weights import TROT_WEIGHTS, WALK_WEIGHTS, CostWeights
from contactnet.robots.description import LEG_NAMES, REFERENCE_LEG_M

FL, FR, HL, HR = range(4)


def step_schedule(
    swing_legs: Sequence[int], n_stance_pre: int = 3, n_swing: int = 4, n_stance_post: int = 1
) -> np.ndarray:
    """Contact schedule of one step horizon, (n_stance_pre + n_swing + n_stance_post, 4) bool.

    All legs are in stance except ``swing_legs`` during the ``n_swing`` middle nodes.
    """
    n = n_stance_pre + n_swing + n_stance_post
    contact = np.ones((n, 4), dtype=bool)
    for leg in swing_legs:
        if not 0 <= leg < 4:
            raise ValueError(f"leg index {leg} not in 0..3")
        contact[n_stance_pre : n_stance_pre + n_swing, leg] = False
    return contact


def horizon_schedule(swing_legs_per_step: Sequence[Sequence[int]], **step_kwargs: int) -> np.ndarray:
    """Concatenate the step schedules of successive step horizons, (sum of nodes, 4) bool."""
    return np.concatenate([step_schedule(s, **step_kwargs) for s in swing_legs_per_step], axis=0)


@dataclass(frozen=True)
class Action:
    """One decoded action: the legs that swing and each one's foothold offset from its hip reference."""

    index: int
    group: int
    legs: tuple[int, ...]
    cells: tuple[int, ...]
    offsets_xy: np.ndarray  # (len(legs), 2) metres, horizontal body frame

    @property
    def leg_names(self) -> tuple[str, ...]:
        return tuple(LEG_NAMES[leg] for leg in self.legs)


@dataclass(frozen=True)
class GaitSpec:
    """Timing and candidate grid of one gait. One step horizon = stance, swing, stance nodes."""

    name: str
    swing_groups: tuple[tuple[int, ...], ...]
    grid_n: int
    grid_spacing_m: float = 0.05
    node_dt_s: float = 0.04
    n_stance_pre: int = 3
    n_swing: int = 4
    n_stance_post: int = 1
    steps_per_plan: int = 3
    cyclic_order: tuple[int, ...] = ()  # group order of the fixed cyclic gait (the baseline)
    #: The ranking cost's weights tuned for this gait (``contactnet.motion.cost_weights``).
    cost_weights: CostWeights = CostWeights()
    #: The paper's top-5 accuracy of this gait's network, percent (train, test); None for new gaits.
    paper_top5: tuple[float, float] | None = None

    # ---- timing ----------------------------------------------------------------------------
    @property
    def nodes_per_step(self) -> int:
        return self.n_stance_pre + self.n_swing + self.n_stance_post

    @property
    def step_duration_s(self) -> float:
        return self.nodes_per_step * self.node_dt_s

    @property
    def liftoff_s(self) -> float:
        """Time of lift-off from the start of a step horizon."""
        return self.n_stance_pre * self.node_dt_s

    @property
    def swing_duration_s(self) -> float:
        return self.n_swing * self.node_dt_s

    @property
    def horizon_nodes(self) -> int:
        return self.steps_per_plan * self.nodes_per_step

    def step_contact(self, swing_legs: Sequence[int]) -> np.ndarray:
        """(nodes_per_step, 4) bool: True where a leg is in stance during one step horizon."""
        return step_schedule(swing_legs, self.n_stance_pre, self.n_swing, self.n_stance_post)

    def horizon_contact(self, swing_legs_per_step: Sequence[Sequence[int]]) -> np.ndarray:
        """(n_steps * nodes_per_step, 4) bool: the contact schedule of consecutive steps."""
        return horizon_schedule(swing_legs_per_step, n_stance_pre=self.n_stance_pre, n_swing=self.n_swing,
                                n_stance_post=self.n_stance_post)

    # ---- candidate grid --------------------------------------------------------------------
    @property
    def legs_per_step(self) -> int:
        return len(self.swing_groups[0])

    @property
    def cells_per_leg(self) -> int:
        return self.grid_n * self.grid_n

    @property
    def actions_per_group(self) -> int:
        return self.cells_per_leg**self.legs_per_step

    @property
    def n_actions(self) -> int:
        """The stepping actions (swing groups x cells)."""
        return len(self.swing_groups) * self.actions_per_group

    @property
    def stand_index(self) -> int:
        """The choice not to step: all four feet in stance for the next step horizon."""
        return self.n_actions

    @property
    def n_choices(self) -> int:
        """Stepping actions plus standing: the outputs of a network that can choose to stand."""
        return self.n_actions + 1

    @cached_property
    def cell_offsets_xy(self) -> np.ndarray:
        """(cells_per_leg, 2) offsets of the grid cells from the hip reference, metres."""
        half = (self.grid_n - 1) / 2
        ix, iy = np.divmod(np.arange(self.cells_per_leg), self.grid_n)
        offsets = np.stack([ix - half, iy - half], axis=1) * self.grid_spacing_m
        offsets.flags.writeable = False
        return offsets

    @cached_property
    def action_table(self) -> tuple[np.ndarray, np.ndarray]:
        """Every action at once: swing mask (N_a, 4) bool and offsets (N_a, 4, 2), zero for stance legs."""
        swing = np.zeros((self.n_actions, 4), dtype=bool)
        offsets = np.zeros((self.n_actions, 4, 2))
        for index in range(self.n_actions):
            action = self.decode(index)
            swing[index, list(action.legs)] = True
            offsets[index, list(action.legs)] = action.offsets_xy
        swing.flags.writeable = False
        offsets.flags.writeable = False
        return swing, offsets

    @cached_property
    def action_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Every action's swinging legs and their grid cells: two (N_a, legs_per_step) int arrays."""
        legs = np.array([self.decode(i).legs for i in range(self.n_actions)], dtype=np.intp)
        cells = np.array([self.decode(i).cells for i in range(self.n_actions)], dtype=np.intp)
        legs.flags.writeable = False
        cells.flags.writeable = False
        return legs, cells

    @cached_property
    def action_cell_incidence(self) -> np.ndarray:
        """(N_a, 4 * cells_per_leg) float32: 1 where the action lands a leg on that cell (index leg *
        cells_per_leg + cell). ``incidence @ cell_safe == legs_per_step``: which actions are safe."""
        legs, cells = self.action_cells
        incidence = np.zeros((self.n_actions, 4 * self.cells_per_leg), dtype=np.float32)
        incidence[np.arange(self.n_actions)[:, None], legs * self.cells_per_leg + cells] = 1.0
        incidence.flags.writeable = False
        return incidence

    # ---- sized to a robot -------------------------------------------------------------------
    def scaled(self, scale: float) -> GaitSpec:
        """This gait for a robot ``scale`` times the reference's size (`SIZE_RULE`): the candidate grid's spacing
        times ``scale``, the node duration (so the step timing) times its square root, the same number of cells and
        nodes; the node duration is rounded to the millisecond (the control loop's tick). ``scale`` 1 is this very
        spec."""
        if not (isinstance(scale, int | float) and math.isfinite(scale) and 0.1 <= scale <= 10.0):
            raise ValueError(f"a gait's scale must be a number in [0.1, 10], got {scale!r}")
        if scale == 1.0:
            return self
        return replace(self, grid_spacing_m=round(self.grid_spacing_m * scale, 6),
                       node_dt_s=round(self.node_dt_s * math.sqrt(scale), 3))  # whole milliseconds: 1 kHz ticks

    def decode(self, index: int) -> Action:
        if not 0 <= index < self.n_actions:
            raise IndexError(f"{self.name}: action {index} outside 0..{self.n_actions - 1}")
        group, rest = divmod(int(index), self.actions_per_group)
        cells = []
        for _ in range(self.legs_per_step):
            rest, cell = divmod(rest, self.cells_per_leg)
            cells.append(cell)
        cells.reverse()
        legs = self.swing_groups[group]
        return Action(
            index=int(index),
            group=group,
            legs=legs,
            cells=tuple(cells),
            offsets_xy=self.cell_offsets_xy[cells].copy(),
        )

    def encode(self, group: int, cells: tuple[int, ...]) -> int:
        if not 0 <= group < len(self.swing_groups):
            raise IndexError(f"{self.name}: group {group} outside 0..{len(self.swing_groups) - 1}")
        if len(cells) != self.legs_per_step or not all(0 <= c < self.cells_per_leg for c in cells):
            raise IndexError(f"{self.name}: cells {cells} must be {self.legs_per_step} in 0..{self.cells_per_leg - 1}")
        index = 0
        for cell in cells:
            index = index * self.cells_per_leg + int(cell)
        return group * self.actions_per_group + index

    def group_of_legs(self, legs: tuple[int, ...]) -> int:
        return self.swing_groups.index(tuple(sorted(legs)))

    def candidates_world(self, hip_ref_xy_world: np.ndarray, yaw_rad: float) -> np.ndarray:
        """(4, cells_per_leg, 2) world XY of every leg's candidate footholds.

        `hip_ref_xy_world` (4, 2) are the legs' hip references (nominal foot XY) in the world.
        """
        return np.asarray(hip_ref_xy_world)[:, None, :] + (self.cell_offsets_xy @ rotation_2d(yaw_rad).T)[None, :, :]


WALK = GaitSpec(
    name="walk",
    swing_groups=((FL,), (FR,), (HL,), (HR,)),
    grid_n=5,
    cyclic_order=(HL, FL, HR, FR),  # the classic crawl: a hind leg, then the front leg on its side
    cost_weights=WALK_WEIGHTS,
    paper_top5=(93.48, 90.81),
)
TROT = GaitSpec(
    name="trot",
    swing_groups=((FL, HR), (FR, HL)),
    grid_n=3,
    cyclic_order=(0, 1),
    cost_weights=TROT_WEIGHTS,
    paper_top5=(99.48, 97.7),
)


# ---- the table of gaits (``contactnet.registry`` re-exports it) ------------------------------------------
_GAITS: dict[str, GaitSpec] = {}


def register_gait(spec: GaitSpec) -> GaitSpec:
    """Make a gait known by its name (CLI ``--gait``, the web app, model files). Returns the spec."""
    if spec.name in _GAITS and _GAITS[spec.name] is not spec:
        raise ValueError(f"a gait named {spec.name!r} is already registered")
    _GAITS[spec.name] = spec
    return spec


def gait_names() -> tuple[str, ...]:
    return tuple(_GAITS)


#: How a gait is sized to a robot: its numbers are the paper's, for Solo12, whose leg (hip flexion joint to knee to
#: foot centre) is `REFERENCE_LEG_M` (0.3245 m) long. A robot with a leg ``scale`` times that gets the candidate grid's spacing
#: and the swing height times ``scale`` and the step timing times sqrt(``scale``) (the same Froude number: a robot
#: twice as tall steps sqrt(2) times slower), rounded to 0.001 of the scale so Solo12 keeps exactly the paper's
#: numbers; a robot's ``size_scale`` overrides the rule (``contactnet.robots.description.RobotSpec``).
SIZE_RULE = f"grid spacing and swing height x scale, step timing x sqrt(scale), scale = leg / {REFERENCE_LEG_M} m"


def gait_by_name(name: str) -> GaitSpec:
    try:
        return _GAITS[name]
    except KeyError:
        raise ValueError(f"unknown gait {name!r}: choose one of {', '.join(_GAITS)}") from None


def gait_for(name: str, robot) -> GaitSpec:  # noqa: ANN001 - a Robot or a RobotDescription
    """The gait ``name`` sized to ``robot`` (`SIZE_RULE`, its ``size_scale``): Solo12's is the paper's spec."""
    description = getattr(robot, "description", robot)
    return gait_by_name(name).scaled(description.size_scale)


register_gait(WALK)
register_gait(TROT)
