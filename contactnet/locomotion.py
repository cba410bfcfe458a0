"""The locomotion loop: plan after each touchdown, optimize the body motion, track it at 1 kHz.

One `Locomotion` object owns a PyBullet world, a planner, the trajectory optimizer and the whole-body controller. A
CLI, a test or the web server drives it the same way: `advance(n_ticks)` and `snapshot()`; `run(duration)` does both.

Timing (the paper's Sec. III-C): a step horizon lasts 8 nodes of 40 ms. At the start of each one (right after the
previous touchdown) the planner gives 3 steps, the optimizer plans CoM motion and forces over those 3 steps (960 ms),
and the controller tracks the first step. We go one step further than the paper: between plans we re-solve the
optimizer from the measured state every 2 nodes (80 ms), keeping the contact plan. Each solve costs a few
milliseconds, and pushes do far less harm.

Terrain with heights (tops at several heights): the optimizer's CoM height and pitch references follow
the tops under the feet node by node (``contactnet.motion.ground``), swings clear the tops on their way
(``contactnet.motion.swing``) and touchdown adapts to the contact sensed (``contactnet.motion.touchdown``). A terrain whose
tops are all at one height takes exactly the flat-ground path, and a robot may stand wider on it: build the planner
and the loop with ``robot.for_terrain(terrain)`` (``contactnet.robots.Robot.for_terrain``; Solo12 does).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from contactnet.frames import rotate_xy
from contactnet.motion.active_plan import ActivePlan
from contactnet.motion.com_reference import ComReference
from contactnet.motion.controller import ControllerGains, ControlTarget, SwingTrajectory, WholeBodyController
from contactnet.motion.foot_hold import FootHold, FootHoldConfig
from contactnet.motion.gait import GaitSpec
from contactnet.motion.ground import body_pitch, front_to_hind_m, ground_normals
from contactnet.motion.swing import swing_over_terrain, swing_past_holes
from contactnet.motion.touchdown import adapt_to_contact
from contactnet.motion.trajopt import (
    SrbdModel,
    TrajectoryOptimizer,
    TrajoptConfig,
    TrajoptProblem,
    TrajoptWeights,
    reference_forces,
)
from contactnet.planning.brace import BraceConfig, braces, standing_horizon, touch_down_now
from contactnet.planning.observer import DEFAULT_OBSERVER, DisturbanceObserver, ObserverConfig
from contactnet.planning.planner import Planner, PlanningContext
from contactnet.planning.retarget import RetargetConfig, retarget
from contactnet.planning.roll import short_top_test
from contactnet.planning.stand import StallWatch, stalled
from contactnet.records import Snapshot, StepCounts, StepRecord, records_summary, summary_stats
from contactnet.robots.description import Robot
from contactnet.sim.engines import make_simulator
from contactnet.sim.world import Push, SimConfig, SimState
from contactnet.terrain import Terrain


@dataclass(frozen=True)
class LocomotionConfig:
    """Settings of the loop (the gait, planner, world and controller have their own)."""

    swing_height_m: float = 0.05  # for the paper's Solo12: times the robot's size_scale (gait.SIZE_RULE)
    # Re-solve the optimizer from the measured state every this many nodes between plans (2: every 80 ms, 12.5 Hz);
    # 0: only after each touchdown, as in the paper.
    reoptimize_every_nodes: int = 2
    # At those re-solves a swing may get a new landing (contactnet.planning.retarget); None: never, as in the paper.
    retarget: RetargetConfig | None = None
    fall_check_every_ticks: int = 10
    # The CoM reference integrates the commanded velocity within this distance of the measured CoM (motion.com_reference)
    ref_leash_m: float = 0.05
    mu: float = 0.6
    trajopt: TrajoptConfig = TrajoptConfig()
    trajopt_weights: TrajoptWeights | None = None  # None: the robot's (TrajoptWeights.for_robot; Solo12: the defaults)
    # One level: a swing leaves (lands) vertically for this share of its time on a top too short for the roll next to a
    # hole; heights (tops at several heights): swings pass this far above the tops they travel over (motion.swing) ...
    hole_vertical_fraction: float = 0.2
    swing_clearance_m: float = 0.015
    # ... and touchdown adapts to the contact sensed: a swinging foot that touches down in the last quarter of its
    # swing near its landing point becomes a stance foot; one that has not touched at the planned time keeps
    # descending at this speed, at most this far below its planned landing height, before it is stance anyway.
    late_touchdown_speed_m_s: float = 0.2
    late_touchdown_depth_m: float = 0.03
    # An early contact counts as touchdown only this close (horizontally) to the planned landing point (farther
    # away the foot has hit an edge on its way: it keeps swinging).
    early_touchdown_radius_m: float = 0.03
    # None: adapt touchdown only on terrain with heights; True / False: always / never.
    adapt_touchdown: bool | None = None
    # A push estimated from the body's momentum, cancelled and leaned into (contactnet.planning.observer); None: off.
    observer: ObserverConfig | None = DEFAULT_OBSERVER
    # While the observer's push is at least its threshold, new step horizons stand (contactnet.planning.brace).
    brace: BraceConfig | None = BraceConfig()
    # The CoM height reference this much below the robot's nominal (m, RobotDescription.check_crouch), all the time: a
    # lower CoM moves the centre of pressure that balances a push less (F h / (m g)). 0: the paper's height; None: the
    # robot's default for the gait and the terrain (RobotDescription.default_crouch_m: its walk_crouch_m and
    # trot_crouch_m on terrain of one level, nothing on terrain with heights, where the legs would meet the tops).
    crouch_m: float | None = None
    # A stance foot that slid off safe ground toward an edge held where it stood (contactnet.motion.foot_hold).
    foot_hold: FootHoldConfig | None = FootHoldConfig()


class Locomotion:
    """The planning-and-control loop around one simulated robot."""

    def __init__(
        self,
        robot: Robot,
        terrain: Terrain,
        gait: GaitSpec,
        planner: Planner,
        sim_config: SimConfig | None = None,
        gains: ControllerGains | None = None,
        config: LocomotionConfig = LocomotionConfig(),
        vel_cmd_xy: tuple[float, float] = (0.0, 0.0),
    ):
        sim_config = SimConfig() if sim_config is None else sim_config
        robot.description.check_crouch(robot.description.default_crouch_m(gait.name, heights=False)
                                       if config.crouch_m is None else config.crouch_m)  # before anything is built
        self.robot = robot
        self.terrain = terrain
        self.gait = gait
        self.planner = planner
        self.config = config
        self.sim = make_simulator(robot, terrain, sim_config)
        self.controller = WholeBodyController(robot, gains)
        self.set_observer(config.observer)
        model = SrbdModel.for_robot(robot.description, gravity=sim_config.gravity, mu=config.mu)
        trajopt = config.trajopt
        if abs(trajopt.dt_s - gait.node_dt_s) > 1e-12:  # a gait sized to another robot: its node duration
            trajopt = replace(trajopt, dt_s=gait.node_dt_s)
        if trajopt.n_nodes != gait.horizon_nodes:
            raise ValueError("the optimizer's horizon must be the gait's 3 step horizons")
        self.optimizer = TrajectoryOptimizer(model, trajopt, config.trajopt_weights or TrajoptWeights.for_robot(
            robot.description), tilted_normals=terrain.sloped)
        self.ticks_per_node = round(gait.node_dt_s / sim_config.dt_s)
        self.ticks_per_step = self.ticks_per_node * gait.nodes_per_step
        self._reoptimize_ticks = self.ticks_per_node * config.reoptimize_every_nodes
        self.foot_radius_m = robot.description.foot_radius_m
        self._front_to_hind_m = front_to_hind_m(robot.description.foot_nominal_base)
        self.vel_cmd_xy = np.asarray(vel_cmd_xy, dtype=float)
        self._stall = StallWatch(gait.step_duration_s)  # plans in a row with the CoM not following the command
        self._use_terrain(terrain)
        self.reset()

    # ---- commands --------------------------------------------------------------------------
    def reset(self, joint_pos: np.ndarray | None = None, joint_vel: np.ndarray | None = None) -> None:
        """Back to the terrain's start (standing, or the given joint positions and velocities)."""
        self.sim.reset(joint_pos=joint_pos, joint_vel=joint_vel)
        self.planner.reset()
        self._stall.reset()
        self.tick, self.yaw_ref_rad = 0, 0.0
        self.set_command(*self.vel_cmd_xy)
        self.plan: ActivePlan | None = None
        self.records: list[StepRecord] = []
        self._swing_height_m = self.config.swing_height_m * self.robot.description.size_scale
        self.planner_times_s: list[float] = []
        self.trajopt_times_s: list[float] = []
        self.trajopt_failures, self.swing_retargets = 0, 0
        self.stall_plans = 0  # plans made stalled (contactnet.planning.stand.StallWatch): the first step went on
        self.brace_touchdowns = 0  # steps whose swinging feet bracing put down early
        self.fall_reason: str | None = None
        self.reached_goal = False
        self._state = self.sim.state()
        self._last_target: ControlTarget | None = None
        self.start_xy = self._state.base_pos_world[:2].copy()
        com, _, _, _ = self.controller.kinematics(self._state.q_pinocchio(), self._state.v_pinocchio())
        self.com_ref = ComReference(com[:2], self.config.ref_leash_m, self.sim.config.dt_s)
        self.max_abs_yaw_rad, self.wall_time_s = 0.0, 0.0
        # The last step's legs, the tops under them and where they stood at lift-off.
        self._liftoff_tops: tuple[tuple[int, ...], np.ndarray, np.ndarray] | None = None
        self._contact_tick, self._contact = -1, np.zeros(4, dtype=bool)  # (_foot_contact)
        self._foot_hold = None if self.config.foot_hold is None else FootHold(self.config.foot_hold)
        self._well_inside = lambda xy: bool(self.terrain.is_safe(xy[None], self.foot_radius_m)[0])  # (foot_hold)
        if self.observer is not None:
            self.observer.reset()
        self._delivered, self._leg_sigma_m = np.zeros((4, 3)), np.full(4, np.inf)
        self._still_xy = np.zeros(2)

    def set_command(self, vx: float, vy: float) -> None:
        """Commanded velocity (m/s) in the horizontal body frame of the reference heading."""
        self.vel_cmd_xy = np.array([vx, vy], dtype=float)
        self._vel_cmd_world = rotate_xy(self.vel_cmd_xy, self.yaw_ref_rad)

    def replace_terrain(self, terrain: Terrain) -> None:
        """Walk on ``terrain`` from now on without a restart (its start and goal must be the old ones): for
        edits away from the robot and its planned steps. The plan in progress is kept."""
        if not np.allclose(terrain.start_xy, self.terrain.start_xy) or terrain.goal_x != self.terrain.goal_x:
            raise ValueError("replace_terrain keeps the start and the goal: restart for a new start or goal")
        self.sim.replace_terrain(terrain)
        self.terrain = terrain
        self._use_terrain(terrain)

    def _use_terrain(self, terrain: Terrain) -> None:
        """Whether the terrain has heights (``Terrain.has_heights``: swings clear the tops on their way, touchdown
        adapts to the contact sensed; else the flat-ground path), and the crouch and the bracing's outward landing
        (m, ``BraceConfig.outward_on``) that go with it."""
        self._heights, adapt, brace = terrain.has_heights, self.config.adapt_touchdown, self.config.brace
        self._adapt_touchdown = self._heights if adapt is None else bool(adapt)
        description, crouch = self.robot.description, self.config.crouch_m
        #: m, the crouch walked with (``LocomotionConfig.crouch_m``, or the robot's default for this terrain)
        self.crouch_m = description.default_crouch_m(self.gait.name, self._heights) if crouch is None else crouch
        self._brace_outward_m = 0.0 if brace is None else brace.outward_on(description.brace_outward_m, self._heights)
        self.com_height_ref_m = description.com_height_nominal_m - self.crouch_m

    def push(self, push: Push) -> None:
        self.sim.add_push(push)

    def set_observer(self, observer: ObserverConfig | None) -> None:
        """The disturbance observer on (a fresh estimate) or off (None), also while it runs (no restart)."""
        self.config = replace(self.config, observer=observer)
        self.observer = None if observer is None else DisturbanceObserver(observer, self.robot.mass_kg, self.sim.config.dt_s)
        self._delivered = np.zeros((4, 3))  # the ground forces of the last tick's torques (the observer's input)
        self._leg_sigma_m = np.full(4, np.inf)  # and the legs' smallest Jacobian singular values then

    @property
    def t_s(self) -> float:
        return self.sim.t_s

    @property
    def done(self) -> bool:
        return self.fall_reason is not None or self.reached_goal

    @property
    def state(self) -> SimState:  # the measured state the loop acts on now (read only)
        return self._state

    @property
    def target(self) -> ControlTarget | None:  # what the controller tracked at the last tick (None before it)
        return self._last_target

    # ---- the loop --------------------------------------------------------------------------
    def advance(self, n_ticks: int = 1) -> None:
        """Run n control ticks (1 ms each), unless the robot has fallen."""
        for _ in range(n_ticks):
            if self.fall_reason is not None:
                return
            self._tick_once()

    def run_for(self, duration_s: float, stop_at_goal: bool = True) -> None:
        """Simulate duration_s more seconds, stopping early at a fall or (by default) at the goal."""
        wall0 = time.perf_counter()
        end = self.tick + round(duration_s / self.sim.config.dt_s)
        while self.tick < end and self.fall_reason is None and not (stop_at_goal and self.reached_goal):
            self._tick_once()
        self.wall_time_s += time.perf_counter() - wall0

    def run(self, duration_s: float, stop_at_goal: bool = True) -> dict:
        """Run from now until duration_s of simulated time in total; return the summary."""
        self.run_for(max(0.0, duration_s - self.t_s), stop_at_goal)
        return self.summary()

    def _tick_once(self) -> None:
        phase = self.tick % self.ticks_per_step
        state = self._state
        if phase == 0:
            self._plan_steps(state)
        elif self._reoptimize_ticks and phase % self._reoptimize_ticks == 0:
            if self.config.retarget is not None and self.plan is not None and self.plan.steps:
                self._retarget(state, self.plan)
            self._optimize(state, self.plan)
        target = self._target(self.sim.t_s)
        q = state.q_pinocchio()
        tau = self.controller.torques(q, state.v_pinocchio(), target)
        if self.observer is not None:  # the forces the last tick's torques delivered; a foot off the ground none
            contact = self._foot_contact()
            known = not (contact & (self._leg_sigma_m < self.observer.config.min_leg_jacobian_m)).any()
            self.observer.update(self.controller.last_com_vel, self._delivered * contact[:, None], known)
            self._delivered, self._leg_sigma_m = self.controller.delivered_forces(q, tau)
            plan = self.plan
            if plan is not None and plan.swings and not plan.braced_down and self.config.brace is not None:
                self._brace_touchdown(state, plan)
        self._last_target = target
        self.sim.step(tau)
        self.com_ref.advance(self.controller.last_com[:2], self._reference_vel_world())
        self.tick += 1
        self._state = state = self.sim.state(with_contacts=False)
        if self.tick % self.config.fall_check_every_ticks == 0:
            self.fall_reason = self.sim.fall_reason(state)
            self.max_abs_yaw_rad = max(self.max_abs_yaw_rad, abs(float(state.rpy[2] - self.yaw_ref_rad)))
        if not self.reached_goal and self.sim.reached_goal(state):
            self.reached_goal = True

    def _reference_vel_world(self) -> np.ndarray:
        """(2,) the CoM reference's velocity: the command's, held still while the active plan's horizon is braced
        (``BraceConfig.hold_reference``)."""
        plan, brace = self.plan, self.config.brace
        held = plan is not None and plan.braced and brace is not None and brace.hold_reference
        return self._still_xy if held else self._vel_cmd_world

    # ---- planning --------------------------------------------------------------------------
    def _context(self, state: SimState) -> PlanningContext:
        com, vcom, feet, _ = self.controller.kinematics(state.q_pinocchio(), state.v_pinocchio())
        return PlanningContext(
            com_pos_world=com,
            com_vel_world=vcom,
            yaw_rad=float(state.rpy[2]),
            foot_pos_world=feet,
            hip_ref_xy_base=self.robot.foot_nominal_base[:, :2],
            base_xy_world=state.base_pos_world[:2].copy(),
            vel_cmd_xy=self.vel_cmd_xy.copy(),
            terrain=self.terrain,
            gait=self.gait,
            rpy=state.rpy,
            ang_vel_world=state.base_ang_vel_world.copy(),
            com_height_ref_m=self.com_height_ref_m,
            external_force_xy_world=None if self.observer is None else self.observer.force_for("lean"),
        )

    def _plan_steps(self, state: SimState) -> None:
        ctx = self._context(state)
        # a moving command the CoM has not followed for some plans: the planner's stall rule (contactnet.planning.stand)
        idle = getattr(self.planner, "idle", None)
        ctx = replace(ctx, still_plans=self._stall.count(ctx.com_pos_world, ctx.vel_cmd_xy, ctx.yaw_rad, idle))
        self.stall_plans += stalled(ctx.still_plans, idle)
        self._close_height_change(ctx.foot_pos_world)
        t0 = time.perf_counter()
        steps = self.planner.plan(ctx)
        planner_s = time.perf_counter() - t0
        self.planner_times_s.append(planner_s)
        braced = braces(self.config.brace, None if self.observer is None else self.observer.active_force_xy(), steps[0],
                        self.robot.mass_kg)
        if braced:  # pushed: stand on four feet until the push is over
            steps = standing_horizon(self.gait, len(steps))

        gait = self.gait
        terrain = self.terrain
        contact = gait.horizon_contact([s.legs for s in steps])
        n = len(contact)
        foot_pos = np.repeat(ctx.foot_pos_world[None], n, axis=0)
        foot_pos[..., 2] -= self.foot_radius_m  # contact points, not ball centres
        tops = np.repeat(terrain.ground_z(ctx.foot_pos_world[:, :2])[None], n, axis=0)  # (n, 4)
        for j, step in enumerate(steps):
            touchdown_node = j * gait.nodes_per_step + gait.n_stance_pre + gait.n_swing
            ground_z = terrain.ground_z(step.footholds_xy_world)
            for leg, xy, z in zip(step.legs, step.footholds_xy_world, ground_z, strict=True):
                foot_pos[touchdown_node:, leg, :2] = xy
                foot_pos[touchdown_node:, leg, 2] = z
                tops[touchdown_node:, leg] = z
        t_now, first, swings = self.sim.t_s, steps[0], {}
        short_top = short_top_test(terrain, ctx.vel_cmd_xy, ctx.yaw_rad, self.foot_radius_m)  # (planning.roll)
        for leg, xy in zip(first.legs, first.footholds_xy_world, strict=True):
            end = np.array([xy[0], xy[1], foot_pos[gait.n_stance_pre + gait.n_swing, leg, 2] + self.foot_radius_m])
            t0_s, t1_s = t_now + gait.liftoff_s, t_now + gait.liftoff_s + gait.swing_duration_s
            start = ctx.foot_pos_world[leg].copy()
            if self._heights:
                swings[leg] = swing_over_terrain(terrain, start, end, t0_s, t1_s, self._swing_height_m,
                                                 self.foot_radius_m, self.config.swing_clearance_m)
            else:  # one level: vertical at an end on a top too short for the roll, next to a hole (motion.swing)
                swings[leg] = swing_past_holes(terrain, start, end, t0_s, t1_s, self._swing_height_m, self.foot_radius_m,
                                               self.config.hole_vertical_fraction, short_top)
        self._liftoff_tops = (tuple(first.legs), tops[0, list(first.legs)].copy(),
                              ctx.foot_pos_world[list(first.legs), :2].copy())
        landing_safe = bool(terrain.is_safe(first.footholds_xy_world).all())
        self.records.append(
            StepRecord(
                t_s=t_now,
                legs=tuple(self.robot.description.leg_names[leg] for leg in first.legs),
                footholds_xy_world=np.asarray(first.footholds_xy_world),
                planner_s=planner_s,
                rank=first.rank,
                discarded=first.discarded,
                safe_landing=landing_safe,
                captured=first.captured,
                braced=braced,
            )
        )
        plan = ActivePlan(
            t0_s=t_now, plan_t0_s=t_now, steps=steps, contact=contact, foot_pos=foot_pos, solution=None, swings=swings,
            tops_z=tops, braced=braced,
        )
        previous = self.plan
        self.plan = plan
        self._optimize(state, plan, fallback=previous)

    def _retarget(self, state: SimState, plan: ActivePlan) -> None:
        """Give the swinging legs a new landing if the measured state calls for one (``contactnet.planning.retarget``):
        the swings, the first step and its footholds in the plan until those legs' next planned step."""
        new = retarget(self.planner, self._context(state), plan.steps[0], plan.swings, self.sim.t_s,
                       self.foot_radius_m, self.config.retarget)
        if new is None:
            return
        step, swings = new
        plan.swings.update(swings)
        plan.steps[0] = step
        gait = self.gait
        for leg, swing in swings.items():
            plan.stand_on(leg, gait.n_stance_pre + gait.n_swing, swing.end_world - np.array([0.0, 0.0, self.foot_radius_m]),
                          gait)
        self.swing_retargets += 1

    def _brace_touchdown(self, state: SimState, plan: ActivePlan) -> None:
        """Bracing's touchdown (``contactnet.planning.brace.touch_down_now``): the first tick a push is estimated at
        the bracing threshold during a step that bracing would have stood, the swinging feet come down, and the
        optimizer solves again with them in stance (a foot on the push's side ``_brace_outward_m`` along it)."""
        config, push_xy = self.config.brace, self.observer.active_force_xy()
        if not (config.touch_down and braces(config, push_xy, plan.steps[0], self.robot.mass_kg)):
            return
        plan.braced_down = True  # once per step
        if touch_down_now(plan, config, self.gait, self.sim.t_s, self.controller.last_foot_pos, self.terrain,
                          self.foot_radius_m, push_xy, self.controller.last_com[:2], self._brace_outward_m):
            self.brace_touchdowns += 1
            self._optimize(state, plan)

    def _close_height_change(self, feet_world: np.ndarray) -> None:
        """The last step's rise or drop (the tops under its legs now against those at lift-off) and how far its
        feet moved."""
        if self._liftoff_tops is None or not self.records:
            return
        legs, liftoff, liftoff_xy = self._liftoff_tops
        self._liftoff_tops = None
        if not legs:  # standing
            self.records[-1].height_change_m = self.records[-1].moved_m = 0.0
            return
        now_xy = feet_world[list(legs), :2]
        now = self.terrain.ground_z(now_xy)
        self.records[-1].height_change_m = float(np.max(np.abs(now - liftoff)))
        self.records[-1].moved_m = float(np.max(np.hypot(*(now_xy - liftoff_xy).T)))

    def _optimize(self, state: SimState, plan: ActivePlan, fallback: ActivePlan | None = None) -> None:
        """Solve the optimizer from the measured state over the plan's remaining nodes (padded with
        four-leg stance to the full horizon). On failure keep the previous solution."""
        t_now = self.sim.t_s
        offset = round((t_now - plan.plan_t0_s) / self.gait.node_dt_s)
        n = self.config.trajopt.n_nodes
        contact = np.ones((n, 4), dtype=bool)
        foot_pos = np.repeat(plan.foot_pos[-1][None], n, axis=0)
        remaining = len(plan.contact) - offset
        contact[:remaining] = plan.contact[offset:]
        foot_pos[:remaining] = plan.foot_pos[offset:]
        # The CoM height and pitch references follow the tops under the feet (contactnet.motion.ground), node by node.
        tops = np.repeat(plan.tops_z[-1][None], n + 1, axis=0)
        tops[:remaining] = plan.tops_z[offset:]
        com, vcom, _, _ = self.controller.kinematics(state.q_pinocchio(), state.v_pinocchio())
        rot_omega = state.base_ang_vel_world
        x0 = np.concatenate([com, vcom, state.rpy, rot_omega])
        known_world = None if self.observer is None else self.observer.force_world("plan")
        problem = TrajoptProblem(
            x0=x0,
            contact=contact,
            foot_pos_world=foot_pos,
            com_vel_ref_xy=self._reference_vel_world().copy(),
            com_height_ref_m=np.mean(tops, axis=1) + self.com_height_ref_m,
            yaw_ref_rad=self.yaw_ref_rad,
            com_xy_ref_start=self.com_ref.xy_world.copy(),
            pitch_ref_rad=body_pitch(tops, self._front_to_hind_m),
            external_force_world=known_world, contact_normals_world=ground_normals(self.terrain, foot_pos),
        )
        solution = self.optimizer.solve(problem)
        self.trajopt_times_s.append(solution.solve_time_s)
        if solution.success:
            plan.solution = solution
            plan.solution_force_world = known_world
            plan.t0_s = t_now
            return
        self.trajopt_failures += 1
        if plan.solution is None and fallback is not None and fallback.solution is not None:
            plan.solution = fallback.solution
            plan.solution_force_world = fallback.solution_force_world
            plan.t0_s = fallback.t0_s

    def _target(self, t_s: float) -> ControlTarget:
        """Interpolate the active solution at t_s; stand still on the current feet without one."""
        plan = self.plan
        gait = self.gait
        node_in_plan = int((t_s - plan.plan_t0_s + 1e-9) // gait.node_dt_s)
        stance = plan.contact[min(node_in_plan, len(plan.contact) - 1)].copy()
        swing_pos = self.controller.last_foot_pos.copy()
        swing_vel = np.zeros((4, 3))
        in_stance = stance.tolist()
        for leg, swing in plan.swings.items():
            if not in_stance[leg]:
                swing_pos[leg], swing_vel[leg], _ = swing.sample(t_s)
        if self._adapt_touchdown and plan.swings:
            config = self.config  # touchdown as sensed (contactnet.motion.touchdown)
            adapt_to_contact(plan, t_s, stance, swing_pos, swing_vel, self._landed, config.late_touchdown_speed_m_s,
                             config.late_touchdown_depth_m)
        if self._foot_hold is not None:  # a stance foot off the ground
            self._foot_hold.apply(stance, self._foot_contact(), self.controller.last_foot_pos, swing_pos, swing_vel,
                                  self._well_inside)
        solution = plan.solution
        external_world = None if self.observer is None else self.observer.feedforward_world(
            None if solution is None else plan.solution_force_world)
        normals = self.terrain.normal_at(self.controller.last_foot_pos[:, :2]) if self.terrain.sloped else None
        if solution is None:
            com = self.controller.last_com.copy()
            weight = reference_forces(stance[None], self.robot.mass_kg, self.sim.config.gravity)[0]
            return ControlTarget(
                com_pos=com,
                com_vel=np.zeros(3),
                rpy=np.array([0.0, 0.0, self.yaw_ref_rad]),
                ang_vel=np.zeros(3),
                forces=weight,
                stance=stance,
                swing_pos=swing_pos,
                swing_vel=swing_vel,
                external_force_world=external_world, contact_normals_world=normals,  # friction about the normals
            )
        u = (t_s - plan.t0_s) / gait.node_dt_s
        k = min(max(int(u // 1), 0), len(solution.forces_world) - 1)
        a = min(max(u - k, 0.0), 1.0)
        x = (1 - a) * solution.x[k] + a * solution.x[k + 1]
        forces = solution.forces_world[k] * stance[:, None]
        return ControlTarget(
            com_pos=x[0:3],
            com_vel=x[3:6],
            rpy=x[6:9],
            ang_vel=x[9:12],
            forces=forces,
            stance=stance,
            swing_pos=swing_pos,
            swing_vel=swing_vel,
            external_force_world=external_world, contact_normals_world=normals,
        )

    def _landed(self, swing: SwingTrajectory, leg: int) -> bool:
        """The foot touches the terrain within ``early_touchdown_radius_m`` of its landing point."""
        if not self._foot_contact()[leg]:
            return False
        foot = self.controller.last_foot_pos[leg]
        radius = self.config.early_touchdown_radius_m
        return (foot[0] - swing.end_world[0]) ** 2 + (foot[1] - swing.end_world[1]) ** 2 <= radius**2

    def _foot_contact(self) -> np.ndarray:
        """(4,) bool: the feet touching the terrain at this tick (queried once per tick, when needed)."""
        if self._contact_tick != self.tick:
            self._contact = self.sim.foot_contact()
            self._contact_tick = self.tick
        return self._contact

    # ---- reading -----------------------------------------------------------------------------
    def snapshot(self) -> Snapshot:
        state = self._state
        plan = self.plan
        com_plan = plan.solution.x[:, :3].copy() if plan and plan.solution is not None else np.zeros((0, 3))
        target = self._last_target
        return Snapshot(
            t_s=self.sim.t_s,
            q=state.q_pinocchio(),
            com_pos=self.controller.last_com.copy(),
            com_vel=state.base_lin_vel_world.copy(),
            stance=target.stance.copy() if target is not None else np.ones(4, dtype=bool),
            foot_contact=self.sim.foot_contact(),  # not state(): that draws the sensor noise, and a viewer would change the run
            forces=self.controller.last_forces.copy(),
            planned_steps=list(plan.steps) if plan else [],
            com_plan=com_plan,
            vel_cmd_xy=(float(self.vel_cmd_xy[0]), float(self.vel_cmd_xy[1])),
            fell=self.fall_reason is not None,
            fall_reason=self.fall_reason,
            reached_goal=self.reached_goal,
            last_planner_ms=1e3 * self.planner_times_s[-1] if self.planner_times_s else 0.0,
            last_trajopt_ms=1e3 * self.trajopt_times_s[-1] if self.trajopt_times_s else 0.0,
            steps=self.steps_taken,
            candidates=self.planner.last_candidates,
        )

    @property
    def steps_taken(self) -> int:
        """Steps in which legs swung (standing not counted)."""
        return sum(1 for r in self.records if r.legs)

    def summary(self) -> dict:
        """The `contactnet simulate --json` object (docs/architecture.md, "Contracts"), plus a few diagnostics.
        ``steps`` counts the steps that swung legs; ``stand_steps`` the step horizons the planner chose to stand;
        ``useless_steps`` the steps whose feet landed less than ``USELESS_STEP_M`` from where they lifted off;
        ``capture_steps`` the steps whose candidates moved towards the capture point after a push
        (``contactnet.planning.capture``); ``stall_plans`` the plans made while the CoM had stopped following a moving
        command, whose first step went on along it (``contactnet.planning.stand.StallWatch``)."""
        sim_time = float(self.sim.t_s)
        displacement = self._state.base_pos_world[:2] - self.start_xy
        return {
            "success": bool(self.reached_goal and self.fall_reason is None), "fell": self.fall_reason is not None,
            "reached_x": float(self._state.base_pos_world[0]),
            "sim_time_s": sim_time,
            "wall_time_s": float(self.wall_time_s),
            "steps": self.steps_taken,
            **StepCounts.of_run(self.records, self.swing_retargets).as_dict(), **records_summary(self.records),
            "planner_ms": summary_stats(self.planner_times_s), "trajopt_ms": summary_stats(self.trajopt_times_s),
            "fall_reason": self.fall_reason,
            "mean_velocity_xy": (displacement / sim_time).tolist() if sim_time > 0 else [0.0, 0.0],
            "max_abs_yaw_rad": self.max_abs_yaw_rad,
            "trajopt_failures": self.trajopt_failures,
            "max_external_force_n": 0.0 if self.observer is None else float(self.observer.max_estimate_n),
            "sim": self.sim.engine, "brace_touchdowns": self.brace_touchdowns, "crouch_m": self.crouch_m,
            "stance_abduction_rad": float(self.robot.spec.stance_abduction_rad), "stall_plans": self.stall_plans,
            "foot_hold_ticks": 0 if self._foot_hold is None else self._foot_hold.held_ticks,
        }

    def close(self) -> None:
        self.sim.close()

    def __enter__(self) -> Locomotion:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
