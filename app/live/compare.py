"""Compare mode: other robots beside the live session's own, each with its own planner, on the same terrain,
with the same gait, command and pushes (the paper's Fig. 6 made live).

`CompareRobots` belongs to the session thread (`app/live/session.py`) like the main `Locomotion`: it builds one
`Locomotion` (its own PyBullet world) per other planner, steps those still walking when the main one is
stepped, and sums each up as a `CompareRobot` (drawn as a ghost) or a `CompareResult` (a run's end).

`compare_offer` says where compare mode teaches: on the terrains where ContactNet and the fixed gait are known to
do the same, it offers the one where they differ (narrow stones).
"""

from __future__ import annotations

from dataclasses import dataclass

from app.live.planners import PlannerFactory
from app.live.view import CompareResult, CompareRobot
from contactnet.locomotion import Locomotion, LocomotionConfig
from contactnet.motion.gait import GaitSpec
from contactnet.records import Snapshot
from contactnet.robots import Robot
from contactnet.sim.world import Push, SimConfig
from contactnet.terrain import Terrain


def rank_stats(loco: Locomotion) -> tuple[float | None, int | None]:
    """(mean, max) ranking position of the actions chosen so far; (None, None) for planners that do not rank."""
    ranks = [r.rank for r in loco.records if r.rank is not None]
    if not ranks:
        return None, None
    return sum(ranks) / len(ranks), max(ranks)


def end_of(loco: Locomotion) -> str | None:
    """How the robot's run ended ("fell: ...", "goal reached"), None while it walks."""
    if loco.fall_reason is not None:
        return f"fell: {loco.fall_reason}"
    if loco.reached_goal:
        return "goal reached"
    return None


#: Terrains on which ContactNet and the fixed gait are known to do the same with Solo12 (compare mode shows no
#: difference): `contactnet simulate --terrain T --gait G --planner P --json`, vx 0.05 m/s, measured 2026-12 on the
#: shipped models: stepping_stones walk and trot, both planners cross (x 1.40 m in 28 s); flat walk, both walk 3.0 m
#: in 60 s. Only shipped names count: an edited terrain is labelled "<name> (edited)".
SAME_TERRAINS = frozenset({"flat", "stepping_stones"})
#: Where they differ: on narrow_stones the fixed gait falls (walk: at x 0.48 m, 9.6 s, "the FR foot stepped into a
#: gap"; trot: at x 0.52 m, 10.6 s) while ContactNet crosses (x 0.97 m in 19.3 s, walk and trot, 0 unsafe landings).
SHOWCASE_TERRAIN = "narrow_stones"
SHOWCASE_PLANNERS = frozenset({"contactnet", "fixed"})
SHOWCASE_ROBOTS = frozenset({"solo12"})  # measured with Solo12 only
SHOWCASE_REASON = (
    "Both planners walk on the {terrain} without a fall, so compare shows no difference here; on narrow stones the fixed gait steps into "
    "a gap and falls while ContactNet ranks the footholds and crosses."
)


@dataclass(frozen=True)
class CompareOffer:
    """A terrain where compare mode shows what the current one cannot: load `terrain` (compare mode stays on)."""

    terrain: str
    planners: tuple[str, ...]
    reason: str  # one sentence: why this terrain


def compare_offer(
    terrain_label: str, terrain_chosen: bool, planners: tuple[str, ...] | None, robot: str
) -> CompareOffer | None:
    """The terrain to offer while compare mode runs ``planners`` (main first) on ``terrain_label``: narrow stones
    when the two planners are ContactNet and the fixed gait, the robot Solo12 and the terrain one of
    `SAME_TERRAINS` that the user did not pick (``terrain_chosen``: a terrain loaded in the session, not the one
    it started on); None otherwise (compare off, a terrain the user chose, an edited terrain, other planners)."""
    if not planners or terrain_chosen or terrain_label not in SAME_TERRAINS or robot not in SHOWCASE_ROBOTS:
        return None
    if set(planners) != SHOWCASE_PLANNERS:
        return None
    return CompareOffer(SHOWCASE_TERRAIN, tuple(planners), SHOWCASE_REASON.format(terrain=terrain_label.replace("_", " ")))


@dataclass
class _Other:
    planner: str
    planner_active: str
    loco: Locomotion


class CompareRobots:
    """The other robots of compare mode (session thread only)."""

    def __init__(
        self,
        planners: tuple[str, ...],
        robot: Robot,
        terrain: Terrain,
        gait: GaitSpec,
        planner_factory: PlannerFactory,
        sim_config: SimConfig,
        vel_cmd_xy: tuple[float, float],
        config: LocomotionConfig = LocomotionConfig(),
    ):
        self.robot = robot
        self.others: list[_Other] = []
        try:
            for name in planners:
                planner, active, _ = planner_factory(name, gait, robot)
                loco = Locomotion(robot, terrain, gait, planner, sim_config, config=config, vel_cmd_xy=vel_cmd_xy)
                self.others.append(_Other(name, active, loco))
        except BaseException:
            self.close()
            raise

    @property
    def planners(self) -> tuple[str, ...]:
        return tuple(o.planner for o in self.others)

    def advance(self, ticks: int) -> None:
        for other in self.others:
            if end_of(other.loco) is None:
                other.loco.advance(ticks)

    @property
    def ended(self) -> list[bool]:
        return [end_of(o.loco) is not None for o in self.others]

    def set_command(self, vx: float, vy: float) -> None:
        for other in self.others:
            other.loco.set_command(vx, vy)

    def push(self, push: Push) -> None:
        for other in self.others:
            other.loco.push(push)

    def reset(self, vel_cmd_xy: tuple[float, float]) -> None:
        for other in self.others:
            other.loco.reset()
            other.loco.set_command(*vel_cmd_xy)

    def replace_terrain(self, terrain: Terrain) -> None:
        for other in self.others:
            other.loco.replace_terrain(terrain)

    def results(self) -> tuple[CompareResult, ...]:
        return tuple(self._result(other, other.loco.snapshot()) for other in self.others)

    def views(self) -> tuple[CompareRobot, ...]:
        """Each other robot now: its result so far and its pose (forward kinematics on the session's robot)."""
        out = []
        for other in self.others:
            snap = other.loco.snapshot()
            out.append(
                CompareRobot(
                    **vars(self._result(other, snap)),
                    planner_active=other.planner_active,
                    snapshot=snap,
                    foot_pos_world=self.robot.foot_positions_world(snap.q),
                )
            )
        return tuple(out)

    @staticmethod
    def _result(other: _Other, snap: Snapshot) -> CompareResult:
        loco = other.loco
        done = end_of(loco)
        return CompareResult(
            planner=other.planner,
            x_m=float(snap.q[0]),
            fell=loco.fall_reason is not None,
            success=done == "goal reached",
            steps=loco.steps_taken,
            rank_mean=rank_stats(loco)[0],
            done=done,
        )

    def close(self) -> None:
        for other in self.others:
            other.loco.close()
        self.others = []

