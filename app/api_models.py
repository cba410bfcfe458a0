"""The REST API's request and response models (pydantic): bounds from `app.settings`, gait and
planner names from `contactnet.registry`, and `state_of`, the State of a LiveView."""

from __future__ import annotations

import math
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

from app.settings import PUSH_DURATION_LIMIT_S, PUSH_FORCE_LIMIT_N, SIM_SPEED_RANGE, VELOCITY_LIMIT_M_S
from app.view import LiveView
from contactnet import registry


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
        ..., ge=-VELOCITY_LIMIT_M_S, le=VELOCITY_LIMIT_M_S, allow_inf_nan=False, description="m/s, forward"
    )
    vy: float = Field(
        0.0, ge=-VELOCITY_LIMIT_M_S, le=VELOCITY_LIMIT_M_S, allow_inf_nan=False, description="m/s, left"
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


class PauseCommand(_Strict):
    paused: bool


def settings_command_model() -> type[BaseModel]:
    """The body of POST /api/settings: any subset of the session settings, gait and planner one of the
    registry's names (read now: build the API after registering your own)."""
    return create_model(
        "SettingsCommand",
        __base__=_Strict,
        __doc__="Any subset of the session settings. Gait, planner and noise restart the robot.",
        gait=(Literal[registry.gait_names()] | None, None),  # type: ignore[valid-type]
        planner=(Literal[registry.planner_names()] | None, None),  # type: ignore[valid-type]
        noise=(
            bool | None,
            Field(None, description="Gaussian joint-velocity noise, variance 0.01 (rad/s)^2"),
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


class RecordingStart(_Strict):
    label: str = Field("", max_length=40, pattern=r"^[A-Za-z0-9_ -]*$")


def _vector(kind: type, json_type: str, n: int) -> Any:
    """A tuple of ``n`` values, described in JSON Schema as an array with ``items`` and min/maxItems (a tuple's
    default schema, ``prefixItems``, is not read by every OpenAPI tool)."""
    schema = {"type": "array", "items": {"type": json_type}, "minItems": n, "maxItems": n}
    return Annotated[tuple[(kind,) * n], WithJsonSchema(schema)]


Float2, Float3, Bool4 = _vector(float, "number", 2), _vector(float, "number", 3), _vector(bool, "boolean", 4)


class State(BaseModel):
    """The live session now."""

    t_s: float
    running: bool
    paused: bool
    done: str | None
    fell: bool
    fall_reason: str | None
    reached_goal: bool
    speed: float
    real_time_factor: float
    terrain: str
    gait: str
    planner: str
    planner_active: str
    planner_note: str | None
    noise: bool
    vel_cmd: Float2
    base_position: Float3
    com_position: Float3
    com_velocity: Float3
    stance: Bool4
    foot_contact: Bool4
    steps: int
    rank_chosen: int | None
    last_planner_ms: float
    last_trajopt_ms: float
    pushes: int
    push_force: Float3
    error: str | None
    recording: bool
    viser_port: int
    robot: str


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


class RecordingEntry(BaseModel):
    name: str
    size_bytes: int
    modified: float
    download_url: str
    html_url: str
    play_url: str


class RecordingStatus(BaseModel):
    recording: bool
    name: str | None
    frames: int
    duration_s: float
    last_saved: str | None


class Info(BaseModel):
    viser_port: int
    viewer_url: str
    version: str
    robot: str


def state_of(view: LiveView, viser_port: int, recording: bool) -> State:
    s, snap = view.status, view.snapshot
    q = snap.q
    return State(
        t_s=snap.t_s,
        running=s.running,
        paused=s.paused,
        done=s.done,
        fell=snap.fell,
        fall_reason=snap.fall_reason,
        reached_goal=snap.reached_goal,
        speed=s.speed,
        real_time_factor=s.real_time_factor,
        terrain=s.terrain,
        gait=s.gait,
        planner=s.planner,
        planner_active=s.planner_active,
        planner_note=s.planner_note,
        noise=s.noise,
        vel_cmd=snap.vel_cmd_xy,
        base_position=tuple(float(v) for v in q[:3]),
        com_position=tuple(float(v) for v in snap.com_pos),
        com_velocity=tuple(float(v) for v in snap.com_vel),
        stance=tuple(bool(v) for v in snap.stance),
        foot_contact=tuple(bool(v) for v in snap.foot_contact),
        steps=snap.steps,
        rank_chosen=snap.planned_steps[0].rank if snap.planned_steps else None,
        last_planner_ms=snap.last_planner_ms,
        last_trajopt_ms=snap.last_trajopt_ms,
        pushes=s.pushes,
        push_force=tuple(float(v) for v in view.push_force_world),
        error=s.error,
        recording=recording,
        viser_port=viser_port,
        robot=s.robot,
    )


def json_safe(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value
