"""The /api session routes: state, velocity, push, reset, pause, compare, settings and the session's terrain.
Each command goes to the live session's queue and answers the state after it (`run`)."""

# No `from __future__ import annotations`: FastAPI must see the body models themselves (some are built at run
# time, from the registry), not their names.

import asyncio
import time

from fastapi import FastAPI, Request
from fastapi.responses import StreamingResponse

from app.api.errors import ErrorCodes, as_http_errors, responses
from app.api.models import (
    ImpulseAtAngle,
    Info,
    NudgeCommand,
    PauseCommand,
    PushAtAngle,
    PushCommand,
    State,
    TerrainSelect,
    VelocityCommand,
    compare_command_model,
    settings_command_model,
    state_of,
)
from app.live.commands import (
    ApplyPush,
    NudgeVelocity,
    Reset,
    SetCompare,
    SetGait,
    SetLoop,
    SetNoise,
    SetObserver,
    SetPaused,
    SetPlanner,
    SetRetarget,
    SetSim,
    SetSpeed,
    SetVelocity,
    TogglePause,
)
from app.live.settings import (
    PUSH_DURATION_LIMIT_S,
    PUSH_FORCE_LIMIT_N,
    VELOCITY_LIMIT_M_S,
)
from contactnet.sim.world import IMPULSE_DURATION_S

#: How long a route waits for the session thread to apply a command.
COMMAND_TIMEOUT_S = 60.0
#: GET /api/state/stream: a new state is sent this often at most (the 3D view's panel refreshes at 5 Hz too) ...
STREAM_PERIOD_S = 0.2
#: ... and at least this often (a state that did not change: the connection is alive) ...
STREAM_KEEPALIVE_S = 2.0
#: ... and the stream ends after this long (the browser's EventSource opens a new one at once): a server that stops
#: is never held up by open streams, and a reclaimed session's stream ends.
STREAM_LIFETIME_S = 15.0


def add_session_routes(api: FastAPI, app, codes: ErrorCodes) -> None:  # noqa: ANN001 - a ContactnetApp
    """Add the session routes of `app` (a ContactnetApp) to `api`."""
    everywhere, session_command = codes.everywhere, codes.session_command
    SettingsCommand = settings_command_model()  # noqa: N806 - a model class
    CompareCommand = compare_command_model()  # noqa: N806 - a model class

    def run(command, timeout: float = COMMAND_TIMEOUT_S) -> State:
        with as_http_errors():
            app.session.call(command, timeout=timeout)
        return app.state()

    # ---- session ------------------------------------------------------------------------------------
    @api.get("/api/info", response_model=Info, tags=["session"], responses=responses(*everywhere))
    def info() -> Info:
        return Info(
            session_id=app.session.session_id,
            viser_port=app.viser_port,
            viewer_url="/viewer/",
            version="0.1.0",
            robot=app.settings.robot,
            sim=app.settings.sim,
            watch_id=app.visit().watch_id,
            shared=app.visits.shared,
        )

    @api.get("/api/state", response_model=State, tags=["session"], responses=responses(*everywhere, 503))
    def get_state() -> State:
        return app.state()

    @api.get(
        "/api/state/stream",
        tags=["session"],
        responses={**responses(*everywhere), 200: {"content": {"text/event-stream": {}},
                                                   "description": "server-sent events, each a State"}},
    )
    async def stream_state(request: Request) -> StreamingResponse:
        """The session's state as it changes: server-sent events (`text/event-stream`), each `data:` line one State
        (as GET /api/state answers), sent when the session published a new view, at most every
        {period} s and at least every {keepalive} s. The stream ends after {lifetime} s (a browser's `EventSource`
        reconnects by itself). The front page follows it instead of polling: its header and cards then show the
        state the 3D view shows, not one a poll interval (or a busy renderer's late timer) old."""
        visit = app.visit()  # the visitor's session, as the request's cookie named it

        async def events():  # noqa: ANN202 - an async generator of str
            yield f"retry: {int(1000 * STREAM_PERIOD_S * 5)}\n\n"
            end = time.monotonic() + STREAM_LIFETIME_S
            last_seq, last_sent = None, 0.0
            while time.monotonic() < end and visit.session.alive:
                view = visit.session.view
                now = time.monotonic()
                if view is not None and (view.seq != last_seq or now - last_sent >= STREAM_KEEPALIVE_S):
                    last_seq, last_sent = view.seq, now
                    state = state_of(view, visit.viewer.port, visit.recorder.recording)
                    yield f"data: {state.model_dump_json()}\n\n"
                if await request.is_disconnected():
                    return
                await asyncio.sleep(STREAM_PERIOD_S)
            yield "event: end\ndata: {}\n\n"  # a planned end: the page opens the next stream at once

        headers = {"Cache-Control": "no-store", "X-Accel-Buffering": "no"}
        return StreamingResponse(events(), media_type="text/event-stream", headers=headers)

    stream_state.__doc__ = stream_state.__doc__.format(
        period=STREAM_PERIOD_S, keepalive=STREAM_KEEPALIVE_S, lifetime=STREAM_LIFETIME_S)

    @api.post(
        "/api/command",
        response_model=State,
        tags=["session"],
        description=f"Set the commanded velocity (|vx|, |vy| <= {VELOCITY_LIMIT_M_S:g} m/s).",
        responses=responses(*session_command),
    )
    def command(body: VelocityCommand) -> State:
        return run(SetVelocity(body.vx, body.vy))

    @api.post(
        "/api/push",
        response_model=State,
        tags=["session"],
        description=f"Push the base now with a force (fx, fy) for a duration (0 < |f| <= {PUSH_FORCE_LIMIT_N:g} N, "
        f"0 < duration <= {PUSH_DURATION_LIMIT_S:g} s). Only while the robot walks: 409 when it is paused, "
        "has fallen or reached the goal. Along an angle: /api/push/angle and /api/push/impulse.",
        responses=responses(*session_command, 409),
    )
    def push(body: PushCommand) -> State:
        return run(ApplyPush(body.fx, body.fy, body.duration))

    @api.post(
        "/api/push/angle",
        response_model=State,
        tags=["session"],
        description=f"Push the base now with a force along angle_deg (world frame: 0 = +x, 90 = +y) for a duration "
        f"(0 < force <= {PUSH_FORCE_LIMIT_N:g} N). 409 as /api/push.",
        responses=responses(*session_command, 409),
    )
    def push_angle(body: PushAtAngle) -> State:
        return run(ApplyPush(*body.as_push()))

    @api.post(
        "/api/push/impulse",
        response_model=State,
        tags=["session"],
        description=f"Push the base now with an impulse (N s) along angle_deg (world frame: 0 = +x, 90 = +y), given "
        f"as its force over {IMPULSE_DURATION_S:g} s: the free body's velocity changes by impulse / mass. 409 as "
        "/api/push.",
        responses=responses(*session_command, 409),
    )
    def push_impulse(body: ImpulseAtAngle) -> State:
        return run(ApplyPush(*body.as_push()))

    @api.post("/api/reset", response_model=State, tags=["session"], responses=responses(*session_command))
    def reset() -> State:
        """Back to the start of the terrain, running."""
        return run(Reset())

    @api.post("/api/pause", response_model=State, tags=["session"], responses=responses(*session_command))
    def pause(body: PauseCommand) -> State:
        """Stop or run the clock; running also ends the wait for the first browser."""
        return run(SetPaused(body.paused))

    @api.post("/api/pause/toggle", response_model=State, tags=["session"], responses=responses(*session_command))
    def toggle_pause() -> State:
        """Pause a running robot, run a paused one (the P key; the session decides, so quick presses alternate). At
        the end of a run it never starts the next one: paused, the loop's count-down holds and the end-of-run card
        stays; toggled again, the count-down goes on. A session stopped by an error restarts."""
        return run(TogglePause())

    @api.post(
        "/api/command/nudge",
        response_model=State,
        tags=["session"],
        description=f"Add (dvx, dvy) to the commanded velocity, clipped to |vx|, |vy| <= {VELOCITY_LIMIT_M_S:g} m/s "
        "(the I/K/J/L keys: applied in the order received, so quick presses add up).",
        responses=responses(*session_command),
    )
    def nudge(body: NudgeCommand) -> State:
        return run(NudgeVelocity(body.dvx, body.dvy))

    @api.post("/api/compare", response_model=State, tags=["session"], responses=responses(*session_command))
    def compare(body: CompareCommand) -> State:
        """Compare mode: ``{"planners": ["contactnet", "fixed"]}`` runs two robots on the same terrain with the
        same command (the main robot with the first planner, the other drawn as a ghost), both from the start;
        ``{"planners": []}`` turns it off. `State.compare` reports the other robot."""
        return run(SetCompare(tuple(body.planners)))

    @api.post("/api/settings", response_model=State, tags=["session"], responses=responses(*session_command))
    def settings(body: SettingsCommand) -> State:
        """Change gait, planner, noise (each restarts the robot), simulation speed, loop, swing retargeting and the
        disturbance observer."""
        if body.speed is not None:
            run(SetSpeed(body.speed))
        if body.loop is not None:
            run(SetLoop(body.loop))
        if body.gait is not None:
            run(SetGait(body.gait))
        if body.planner is not None:
            run(SetPlanner(body.planner))
        if body.noise is not None:
            run(SetNoise(body.noise))
        if body.sim is not None:
            run(SetSim(body.sim))
        if body.retarget is not None:
            run(SetRetarget(body.retarget))
        if body.observer is not None:
            run(SetObserver(body.observer))
        return app.state()

    @api.post(
        "/api/session/terrain",
        response_model=State,
        tags=["session"],
        responses=responses(*session_command, 404, 409),
    )
    def session_terrain(body: TerrainSelect) -> State:
        """Put the robot on another terrain (a file, a shipped generator, or the random field); 409 when that
        file is not a valid terrain."""
        with as_http_errors():
            app.terrains.load(body.name, removed=body.removed, seed=body.seed, timeout=COMMAND_TIMEOUT_S)
        return app.state()

