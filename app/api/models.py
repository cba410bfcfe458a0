"""The REST API's request and response models (pydantic): bounds from `app.live.settings`, gait and
planner names from `contactnet.registry`, and `state_of`, the State of a LiveView."""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    WithJsonSchema,
    create_model,
    model_validator,
)

from app.live.compare import compare_offer
from app.live.settings import PUSH_DURATION_LIMIT_S, PUSH_FORCE_LIMIT_N, SIM_SPEED_RANGE, VELOCITY_LIMIT_M_S
from app.live.view import STATUS_KINDS, LiveView, RunSummary, is_stand, status_kind, status_line
from contactnet import registry
from contactnet.records import StepCounts
from contactnet.sim.world import ENGINES, IMPULSE_DURATION_S, Push


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


def _integral(value: Any) -> Any:
    """18.0 is the integer 18 in JSON (and JSON Schema's "integer"); 18.5, "18" and true are not."""
    return int(value) if isinstance(value, float) and value.is_integer() and abs(value) < 2**53 else value


def json_int(ge: int, le: int) -> Any:
    """An integer in [ge, le] of a request body: strict, but a float with an integral value counts (JSON
    Schema's rule for "integer")."""
    return Annotated[int, Field(ge=ge, le=le), BeforeValidator(_integral)]


class VelocityCommand(_Strict):
    """Commanded base velocity in the robot's horizontal frame."""

    vx: float = Field(
        ..., ge=-VELOCITY_LIMIT_M_S, le=VELOCITY_LIMIT_M_S, allow_inf_nan=False, description="m/s, forward",
        examples=[0.05],  # the paper's speed (Swagger's "Try it out" would otherwise fill in the minimum)
    )
    vy: float = Field(
        0.0, ge=-VELOCITY_LIMIT_M_S, le=VELOCITY_LIMIT_M_S, allow_inf_nan=False, description="m/s, left",
        examples=[0.0],
    )


class PushCommand(_Strict):
    """A horizontal push on the base (world frame), starting now: 0 < |(fx, fy)| <= the force limit. It acts
    only while the robot walks (409 when paused, fallen, at the goal)."""

    # The part of "0 < |(fx, fy)|" JSON Schema can say: fx or fy given and not 0.
    model_config = ConfigDict(
        json_schema_extra={
            "anyOf": [
                {"required": ["fx"], "properties": {"fx": {"not": {"const": 0}}}},
                {"required": ["fy"], "properties": {"fy": {"not": {"const": 0}}}},
            ]
        }
    )

    fx: float = Field(0.0, ge=-PUSH_FORCE_LIMIT_N, le=PUSH_FORCE_LIMIT_N, allow_inf_nan=False, description="N")
    fy: float = Field(0.0, ge=-PUSH_FORCE_LIMIT_N, le=PUSH_FORCE_LIMIT_N, allow_inf_nan=False, description="N")
    duration: float = Field(1.0, gt=0.0, le=PUSH_DURATION_LIMIT_S, allow_inf_nan=False, description="s")

    @model_validator(mode="after")
    def _magnitude(self) -> PushCommand:
        magnitude = math.hypot(self.fx, self.fy)
        if magnitude == 0.0:
            raise ValueError("fx, fy: a push needs a force: |(fx, fy)| must be more than 0 N")
        if magnitude > PUSH_FORCE_LIMIT_N:
            raise ValueError(
                f"fx, fy: push force |(fx, fy)| = {magnitude:.3g} N exceeds {PUSH_FORCE_LIMIT_N:g} N"
            )
        return self


class PushAtAngle(_Strict):
    """A horizontal push of ``force`` N for ``duration`` s along ``angle_deg`` (world frame: 0 = +x, the walking
    direction; 90 = +y, the robot's left at the start), starting now."""

    angle_deg: float = Field(..., ge=-360.0, le=360.0, allow_inf_nan=False, description="deg, world: 0 = +x, 90 = +y")
    force: float = Field(..., ge=0.001, le=PUSH_FORCE_LIMIT_N, allow_inf_nan=False, description="N")
    duration: float = Field(1.0, gt=0.0, le=PUSH_DURATION_LIMIT_S, allow_inf_nan=False, description="s")

    def as_push(self) -> tuple[float, float, float]:
        push = Push.at_angle(0.0, math.radians(self.angle_deg), self.force, self.duration)
        return push.force_world[0], push.force_world[1], push.duration_s


class ImpulseAtAngle(_Strict):
    """An impulse of ``impulse`` N s along ``angle_deg`` (world frame: 0 = +x, 90 = +y), given as its force over
    0.1 s, starting now; it changes the free body's velocity by impulse / mass."""

    angle_deg: float = Field(..., ge=-360.0, le=360.0, allow_inf_nan=False, description="deg, world: 0 = +x, 90 = +y")
    impulse: float = Field(..., ge=0.0001, le=PUSH_FORCE_LIMIT_N * IMPULSE_DURATION_S, allow_inf_nan=False,
                           description=f"N s, over {IMPULSE_DURATION_S:g} s")

    def as_push(self) -> tuple[float, float, float]:
        push = Push.impulse(0.0, math.radians(self.angle_deg), self.impulse)
        return push.force_world[0], push.force_world[1], push.duration_s


class NudgeCommand(_Strict):
    """A change of the commanded velocity (the page's I/K/J/L keys): added to the command in the order received,
    so quick presses add up; the result is clipped to the limits."""

    dvx: float = Field(0.0, ge=-2 * VELOCITY_LIMIT_M_S, le=2 * VELOCITY_LIMIT_M_S, allow_inf_nan=False,
                       description="m/s, added to the forward command", examples=[0.05])
    dvy: float = Field(0.0, ge=-2 * VELOCITY_LIMIT_M_S, le=2 * VELOCITY_LIMIT_M_S, allow_inf_nan=False,
                       description="m/s, added to the leftward command", examples=[0.0])


class PauseCommand(_Strict):
    paused: bool = Field(description="true: stop the clock; false: run (also ends the wait for a first browser)")


def compare_command_model() -> type[BaseModel]:
    """The body of POST /api/compare: two of the registry's planner names (read now: build the API after
    registering your own), the main robot's first, or none."""
    planner = Literal[registry.planner_names()]  # type: ignore[valid-type]
    return create_model(
        "CompareCommand",
        __base__=_Strict,
        __doc__="Compare mode: two planners' robots on the same terrain with the same command, the main robot's "
        "planner first (both restart); an empty list turns compare mode off.",
        planners=(
            list[planner],  # type: ignore[valid-type]
            Field(
                ...,
                max_length=2,
                description="two planner names, or none",
                json_schema_extra={"anyOf": [{"maxItems": 0}, {"minItems": 2}]},
            ),
        ),
        __validators__={"two_or_none": model_validator(mode="after")(_two_or_none)},
    )


def _two_or_none(model: BaseModel) -> BaseModel:
    if len(model.planners) not in (0, 2):
        raise ValueError("planners: give two planner names (the main robot's first), or none to turn it off")
    return model


def settings_command_model() -> type[BaseModel]:
    """The body of POST /api/settings: any subset of the session settings, gait and planner one of the
    registry's names (read now: build the API after registering your own)."""
    return create_model(
        "SettingsCommand",
        __base__=_Strict,
        __doc__="Any subset of the session settings. Gait, planner, noise and sim restart the robot; retarget does not.",
        gait=(Literal[registry.gait_names()] | None, None),  # type: ignore[valid-type]
        planner=(Literal[registry.planner_names()] | None, None),  # type: ignore[valid-type]
        noise=(
            bool | None,
            Field(None, description="Gaussian joint-velocity noise, variance 0.01 (rad/s)^2"),
        ),
        sim=(
            Literal[ENGINES] | None,  # type: ignore[valid-type]
            Field(None, description="the physics engine (pybullet or mujoco, if installed on the server): the robot "
                  "restarts in it"),
        ),
        loop=(
            bool | None,
            Field(None, description="start the next run a few seconds after the goal or a fall"),
        ),
        retarget=(
            bool | None,
            Field(None, description="swing retargeting: during a swing, when the measured velocity is off the command "
                  "(a push), the swinging legs' landing is ranked again and may move (ContactNet and fixed planners; "
                  "off by default, as in the paper; no restart)"),
        ),
        observer=(
            bool | None,
            Field(None, description="the disturbance observer: a push is estimated from the body's momentum, cancelled "
                  "by the controller and leaned into by the capture step (on by default; no restart)"),
        ),
        speed=(
            float | None,
            Field(
                None,
                ge=SIM_SPEED_RANGE[0],
                le=SIM_SPEED_RANGE[1],
                allow_inf_nan=False,
                description="simulated seconds per wall-clock second",
            ),
        ),
    )


class TerrainSelect(_Strict):
    """A terrain for the session: a terrain file (the user's or a shipped one), a shipped generator, or
    'random' (which needs 'removed')."""

    model_config = ConfigDict(
        json_schema_extra={
            "anyOf": [
                {
                    "required": ["name", "removed"],
                    "properties": {"name": {"const": "random"}, "removed": {"type": "integer"}},
                },
                {"properties": {"name": {"not": {"const": "random"}}}},
            ]
        }
    )

    name: str = Field(..., pattern=r"^(random|[A-Za-z0-9][A-Za-z0-9_-]{0,63})$")
    removed: json_int(0, 300) | None = Field(None, description="random: squares removed (0..300)")
    seed: json_int(0, 2**31 - 1) = Field(0, description="random: seed")

    @model_validator(mode="after")
    def _random_needs_removed(self) -> TerrainSelect:
        if self.name == "random" and self.removed is None:
            raise ValueError("removed: the random terrain needs 'removed' (0..300)")
        return self


def _vector(kind: type, json_type: str, n: int) -> Any:
    """A tuple of ``n`` values, described in JSON Schema as an array with ``items`` and min/maxItems (a tuple's
    default schema, ``prefixItems``, is not read by every OpenAPI tool)."""
    schema = {"type": "array", "items": {"type": json_type}, "minItems": n, "maxItems": n}
    return Annotated[tuple[(kind,) * n], WithJsonSchema(schema)]


Float2, Float3, Bool4 = _vector(float, "number", 2), _vector(float, "number", 3), _vector(bool, "boolean", 4)


class RunResult(BaseModel):
    """How one robot of a run ended (or stands when the run was summed up)."""

    planner: str = Field(description="the planner this robot used")
    x: float = Field(description="m, the base's forward position (world frame)")
    fell: bool = Field(description="the robot fell")
    success: bool = Field(description="the robot reached the goal line without falling")
    steps: int = Field(description="steps taken")
    rank_mean: float | None = Field(
        description="mean ranking position of the chosen actions (0 = the network's first choice); null for "
        "planners that do not rank"
    )


class StepCounters(BaseModel):
    """A run's step counters (`contactnet.records.StepCounts`, declared once): the end-of-run report and the state
    carry them."""

    stand_steps: int = Field(description="step horizons the planner chose to stand (all four feet down), a count "
                             "(each lasts the gait's step duration)")
    useless_steps: int = Field(description="steps whose feet landed less than 2 cm from where they lifted off, a count "
                               "(known one step horizon after the step)")
    swing_retargets: int = Field(description="swings whose landing moved during the swing, a count (only while "
                                 "retarget is on)")
    capture_steps: int = Field(description="steps whose candidates moved towards the capture point after a push "
                               "(the CoM velocity off the command by more than 0.15 m/s), a count")


def counters(counts: StepCounts) -> dict[str, int]:
    """The `StepCounters` fields of a run's counts."""
    return {name: getattr(counts, name) for name in StepCounters.model_fields}


class RunReport(StepCounters):
    """A finished run (goal, fall, or stopped) of the main robot."""

    index: int = Field(description="1 for the session's first run, then 2, 3, ...")
    t_s: float = Field(description="s, simulated time the run lasted")
    steps: int = Field(description="steps taken")
    rank_mean: float | None = Field(description="mean ranking position of the chosen actions (ranking planners)")
    rank_max: int | None = Field(description="worst ranking position chosen (ranking planners)")
    success: bool = Field(description="reached the goal line without falling")
    reason: str = Field(description='"goal reached", "fell: <why>" or "stopped: <why>"')
    x: float = Field(description="m, the base's forward position at the end")
    terrain: str = Field(description="the terrain's label")
    gait: str = Field(description="the gait")
    planner: str = Field(description="the planner actually used")
    compare: list[RunResult] | None = Field(description="the other robots' results in compare mode, else null")


class NoticeModel(BaseModel):
    """A message for the user about a change they made (shown once, as a toast)."""

    seq: int = Field(description="grows by one per notice of the session: show those above the last one shown")
    level: Literal["info", "warning", "error"] = Field(
        description="warning: the change stopped or restarted the robot; error: a control of the 3D view was refused")
    text: str = Field(description="one sentence")


class Scenario(BaseModel):
    """The query of a link that opens this scenario: /?terrain=...&gait=...&planner=...&compare=a,b."""

    terrain: str | None = Field(
        description="a terrain name, or 'random' (with removed and seed); null for an edited terrain not saved"
    )
    removed: int | None = Field(description="random terrain: squares removed")
    seed: int | None = Field(description="random terrain: seed")
    gait: str = Field(description="the gait")
    planner: str = Field(description="the main robot's planner")
    compare: list[str] | None = Field(description="compare mode's planners, main first; null when off")


class CompareOfferModel(BaseModel):
    """Compare mode on a terrain where its planners are known to do the same: a terrain where they differ."""

    terrain: str = Field(description="the terrain to load (POST /api/session/terrain {\"name\": terrain}); compare "
                         "mode stays on")
    planners: list[str] = Field(description="compare mode's planners there, main first (the ones running now)")
    reason: str = Field(description="one sentence: why that terrain shows the difference")


class State(StepCounters):
    """The live session now (world frame: x forward along the terrain, z up; SI units)."""

    session_id: str = Field(description="new on every server start: a client seeing it change reconnects")
    status_text: str = Field(description="the session's state in one sentence (the page's header and the 3D "
                             "view's status panel show the same)")
    status_kind: str = Field("walking", description="the state status_text names, one word for a client's colour: "
                             + ", ".join(STATUS_KINDS) + " (walking also on a step horizon the planner stands while "
                             "told to walk: see standing)")
    t_s: float = Field(description="s, simulated time since the run started")
    running: bool = Field(description="the simulation advances (not paused, waiting, counting down or done)")
    paused: bool = Field(description="paused by a user (POST /api/pause)")
    waiting_for_viewer: bool = Field(
        description="the robot waits for the first browser to open the 3D view (or POST /api/pause "
        '{"paused": false})'
    )
    starts_in_s: float | None = Field(description="s (wall), count-down before the robot starts; else null")
    done: str | None = Field(description='how the run ended: "goal reached" or "fell: <why>"; null while walking')
    fell: bool = Field(description="the main robot fell (see fall_reason)")
    fall_reason: str | None = Field(description="why the fall detector ended the run; null when not fallen")
    reached_goal: bool = Field(description="the base crossed the goal line")
    loop: bool = Field(description="the next run starts a few seconds after the goal or a fall")
    restart_in_s: float | None = Field(description="s (wall) until the next run (loop); else null")
    runs: int = Field(description="finished runs since the server started")
    last_run: RunReport | None = Field(description="the last finished run; null before the first one ends")
    progress: float = Field(description="0 at the start, 1 at the goal line (forward position)")
    start_x_m: float = Field(description="m, forward position of the start")
    goal_x_m: float = Field(description="m, forward position of the goal line")
    speed: float = Field(description="simulated seconds per wall-clock second")
    real_time_factor: float = Field(description="simulated / wall time over the last ~2 s of running")
    terrain: str = Field(description="the terrain's label (file name, generator, or '<name> (edited)')")
    gait: str = Field(description="the gait (walk: one leg at a time; trot: diagonal pairs)")
    planner: str = Field(description="the planner asked for")
    planner_active: str = Field(description="the planner used (the heuristic when the asked one's model is "
                                "missing: see planner_note)")
    planner_note: str | None = Field(description="why the planner used is not the one asked for; else null")
    noise: bool = Field(description="the paper's joint-velocity noise (variance 0.01 (rad/s)^2) is on")
    sim: str = Field("pybullet", description="the physics engine the robot runs in (pybullet or mujoco)")
    vel_cmd: Float2 = Field(description="m/s, commanded (forward, left) velocity in the robot's heading frame")
    base_position: Float3 = Field(description="m, base position (world)")
    com_position: Float3 = Field(description="m, centre of mass (world)")
    com_velocity: Float3 = Field(description="m/s, centre-of-mass velocity (world)")
    stance: Bool4 = Field(description="planned stance per leg (FL, FR, HL, HR)")
    foot_contact: Bool4 = Field(description="measured contact per leg (FL, FR, HL, HR)")
    steps: int = Field(description="steps taken in this run (step horizons in which legs swung; stands not counted)")
    standing: bool = Field(description="the planner chose to stand for the current step horizon (all four feet "
                           "down): a choice, not a pause")
    retarget: bool = Field(description="swing retargeting is on (POST /api/settings {\"retarget\": true}); off by "
                           "default")
    observer: bool = Field(description="the disturbance observer is on (POST /api/settings {\"observer\": false} "
                           "turns it off); on by default")
    rank_chosen: int | None = Field(description="ranking position of the step being taken (ranking planners)")
    last_planner_ms: float = Field(description="ms, the last planner call")
    last_trajopt_ms: float = Field(description="ms, the last trajectory optimization")
    pushes: int = Field(description="pushes applied in this run")
    push_force: Float3 = Field(description="N, the pushes acting now (world)")
    estimated_push: Float3 | None = Field(
        None, description="N, world: the push the disturbance observer estimates and uses now; null when it is off "
        "or its estimate is below its threshold (0.8 N per kg of the robot: 2 N for Solo12)")
    error: str | None = Field(description="the error that stopped the simulation; null when none")
    recording: bool = Field(description="a scene recording is in progress")
    viser_port: int = Field(description="port of the 3D view's websocket (viser)")
    robot: str = Field(description="the robot's registry name")
    notices: list[NoticeModel] = Field(description="the last few notices, oldest first")
    compare: list[RunResult] | None = Field(description="compare mode: the other robots now; null when off")
    scenario: Scenario = Field(description="the query of a link that opens this scenario (see Scenario)")
    compare_offer: CompareOfferModel | None = Field(
        None, description="compare mode on a terrain the session started on where its two planners are known to do "
        "the same (ContactNet and the fixed gait both cross the stepping stones): the terrain where they differ, and "
        "why; null otherwise (compare off, a terrain the user loaded, other planners or robots)")


class TerrainEntry(BaseModel):
    name: str
    shipped: bool
    url: str


class TerrainList(BaseModel):
    terrains: list[TerrainEntry]
    generators: list[str] = ["random"]
    current: str


class Saved(BaseModel):
    name: str
    path: str


class Info(BaseModel):
    session_id: str = Field(description="new on every server start")
    viser_port: int = Field(description="port of the 3D view's websocket (viser)")
    viewer_url: str = Field(description="the 3D view's page (give it ?websocket=ws://host:viser_port)")
    version: str = Field(description="contactnet's version")
    robot: str = Field(description="the robot's registry name")
    sim: str = Field("pybullet", description="the physics engine the server started with (serve --sim)")
    watch_id: str = Field("", description="your session's public id: /?watch=ID shows it read-only to others")
    shared: bool = Field(False, description="serve --shared: every visitor drives the one default session")


class VisitEntry(BaseModel):
    watch_id: str = Field(description="the session's public id (never its cookie)")
    yours: bool = Field(description="the session this request acts on")
    default: bool = Field(description="the default session (requests without the visit cookie act on it)")
    terrain: str
    status: str = Field(description="its state in one sentence")
    viewers: int = Field(description="browsers with its 3D view open (watchers not counted)")
    idle_s: float = Field(description="seconds since its visitor last showed up (0 while its page is open)")
    watch_url: str = Field(description="the page that shows it read-only")


class VisitList(BaseModel):
    sessions: list[VisitEntry]
    max_sessions: int = Field(description="serve --max-sessions: at most this many at once, the default included")
    shared: bool = Field(description="serve --shared: one session for every visitor")
    idle_timeout_s: float = Field(description="a session is reclaimed this long after its page was closed")


class WatchInfo(BaseModel):
    watch_id: str
    viser_port: int = Field(description="port of the read-only 3D view's websocket (viser, no control panel)")
    viewer_url: str = Field(description="the 3D view's page (give it ?websocket=ws://host:viser_port)")


def _result(r: Any) -> RunResult:
    return RunResult(planner=r.planner, x=r.x_m, fell=r.fell, success=r.success, steps=r.steps,
                     rank_mean=r.rank_mean)


def _run_report(run: RunSummary | None) -> RunReport | None:
    if run is None:
        return None
    return RunReport(
        index=run.index, t_s=run.t_s, steps=run.steps, rank_mean=run.rank_mean, rank_max=run.rank_max,
        success=run.success, reason=run.reason, x=run.reached_x_m, terrain=run.terrain, gait=run.gait,
        planner=run.planner, compare=None if run.compare is None else [_result(r) for r in run.compare],
        **counters(run.counts),
    )


_RANDOM_LABEL = re.compile(r"^random \(removed (\d+), seed (\d+)\)$")
_TERRAIN_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")


def scenario_of(view: LiveView) -> Scenario:
    """The shareable scenario: the terrain as loadable by name (not an edited one), gait, planner, compare."""
    s = view.status
    terrain, removed, seed = None, None, None
    random_label = _RANDOM_LABEL.match(s.terrain)
    if random_label:
        terrain, removed, seed = "random", int(random_label[1]), int(random_label[2])
    elif _TERRAIN_NAME.match(s.terrain):
        terrain = s.terrain
    compare = None if view.compare is None else [s.planner, *(r.planner for r in view.compare)]
    return Scenario(terrain=terrain, removed=removed, seed=seed, gait=s.gait, planner=s.planner, compare=compare)


def compare_offer_of(view: LiveView) -> CompareOfferModel | None:
    """`State.compare_offer` (`app.live.compare.compare_offer`)."""
    s = view.status
    planners = None if view.compare is None else (s.planner, *(r.planner for r in view.compare))
    offer = compare_offer(s.terrain, s.terrain_chosen, planners, s.robot)
    return None if offer is None else CompareOfferModel(terrain=offer.terrain, planners=list(offer.planners),
                                                        reason=offer.reason)


def state_of(view: LiveView, viser_port: int, recording: bool) -> State:
    s, snap, run = view.status, view.snapshot, view.run
    q = snap.q
    return State(
        session_id=view.session_id,
        status_text=status_line(view),
        status_kind=status_kind(view),
        t_s=snap.t_s,
        running=s.running,
        paused=s.paused,
        waiting_for_viewer=run.waiting_for_viewer,
        starts_in_s=run.starts_in_s,
        done=s.done,
        fell=snap.fell,
        fall_reason=snap.fall_reason,
        reached_goal=snap.reached_goal,
        loop=run.loop,
        restart_in_s=run.restart_in_s,
        runs=run.runs,
        last_run=_run_report(run.last_run),
        progress=run.progress,
        start_x_m=run.start_x_m,
        goal_x_m=run.goal_x_m,
        speed=s.speed,
        real_time_factor=s.real_time_factor,
        terrain=s.terrain,
        gait=s.gait,
        planner=s.planner,
        planner_active=s.planner_active,
        planner_note=s.planner_note,
        noise=s.noise,
        sim=s.sim,
        vel_cmd=snap.vel_cmd_xy,
        base_position=tuple(float(v) for v in q[:3]),
        com_position=tuple(float(v) for v in snap.com_pos),
        com_velocity=tuple(float(v) for v in snap.com_vel),
        stance=tuple(bool(v) for v in snap.stance),
        foot_contact=tuple(bool(v) for v in snap.foot_contact),
        steps=snap.steps,
        standing=is_stand(snap),
        **counters(view.counts),
        retarget=s.retarget,
        observer=s.observer,
        rank_chosen=snap.planned_steps[0].rank if snap.planned_steps else None,
        last_planner_ms=snap.last_planner_ms,
        last_trajopt_ms=snap.last_trajopt_ms,
        pushes=s.pushes,
        push_force=tuple(float(v) for v in view.push_force_world),
        estimated_push=None if view.estimated_push_world is None else tuple(float(v) for v in view.estimated_push_world),
        error=s.error,
        recording=recording,
        viser_port=viser_port,
        robot=s.robot,
        notices=[NoticeModel(seq=n.seq, level=n.level, text=n.text) for n in view.notices],
        compare=None if view.compare is None else [_result(r) for r in view.compare],
        scenario=scenario_of(view),
        compare_offer=compare_offer_of(view),
    )


def json_safe(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value
