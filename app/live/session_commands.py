"""What each command does to a live session: one handler per command type (`SessionCommands._handle` dispatches
on it), applied by the session thread (`app.live.session.LiveSession._apply`), never concurrently.

Handlers change the session's settings (velocity, speed, pause, gait, planner, engine, noise, the observer and
swing retargeting, compare mode) and its terrain (load, edit, undo, redo, rename). A change that needs a new
`Locomotion` goes through `_rebuild`, which keeps the old settings and world when the new ones fail; a terrain edit
away from every robot is applied in place (`app.live.terrain_change.change_is_away`), one near a robot restarts it,
paused. Each change that restarts the robot says so in a notice (`_notify`).

`LiveSession` is the state these handlers work on (its attributes are set by its thread's start-up, `_run`); the
split is by concern: the thread, its pacing and what it publishes there, what a command does here.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from app.live.commands import (
    ApplyPush,
    Command,
    CommandConflict,
    EditTerrain,
    Notify,
    NudgeVelocity,
    RedoTerrainEdit,
    RenameTerrain,
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
    SetTerrain,
    SetVelocity,
    TogglePause,
    UndoTerrainEdit,
    ViewerConnected,
)
from app.live.editor import EditHistory, to_terrain
from app.live.settings import VELOCITY_LIMIT_M_S
from app.live.step_events import use_observer, use_retarget
from app.live.terrain_change import change_is_away
from contactnet.locomotion import Locomotion
from contactnet.sim.world import ENGINE_NAMES, Push, engine_installed
from contactnet.terrain import Terrain


class SessionCommands:
    """The command handlers of `app.live.session.LiveSession` (see the module docstring)."""

    # ---- one handler per command: `_handle` dispatches on the command's type ------------------------------
    @functools.singledispatchmethod
    def _handle(self, command: Command) -> Any:  # pragma: no cover - check_command lets only known commands through
        raise ValueError(f"unknown command {command!r}")

    @_handle.register
    def _on_velocity(self, command: SetVelocity) -> None:
        self._set_velocity((float(command.vx), float(command.vy)))

    @_handle.register
    def _on_nudge(self, command: NudgeVelocity) -> None:
        self._set_velocity(
            tuple(
                float(np.clip(round(v + d, 3), -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S))
                for v, d in zip(self._vel, (command.dvx, command.dvy), strict=True)
            )
        )

    @_handle.register
    def _on_push(self, command: ApplyPush) -> None:
        if not self._running:  # the clock stands still: the push would act later, or never
            why = self._runs.held_because(self._error, self._done)
            raise CommandConflict(f"cannot push now: the robot is {why}")
        push = Push(
            t0_s=self._loco.t_s,
            duration_s=float(command.duration_s),
            force_world=(float(command.fx), float(command.fy), 0.0),
        )
        self._loco.push(push)
        if self._compare is not None:
            self._compare.push(push)
        self._pushes.append(push)

    @_handle.register
    def _on_reset(self, command: Reset) -> None:
        self._restart()
        self._paused = False
        self._runs.start_now()
        self._error = None

    @_handle.register
    def _on_paused(self, command: SetPaused) -> None:
        self._paused = bool(command.paused)
        self._runs.hold(self._paused)
        if not self._paused:
            self._runs.start_now()  # an explicit start needs no viewer

    @_handle.register
    def _on_toggle_pause(self, command: TogglePause) -> None:
        if self._error is not None:
            self._handle(Reset())
        else:  # also at the end of a run: a pause holds the loop's count-down, it never starts the next run
            self._handle(SetPaused(not self._paused))

    @_handle.register
    def _on_notify(self, command: Notify) -> None:
        self._notify(command.text, command.level)

    @_handle.register
    def _on_viewer(self, command: ViewerConnected) -> None:
        self._runs.viewer_connected()

    @_handle.register
    def _on_loop(self, command: SetLoop) -> None:
        self._runs.set_loop(bool(command.on))

    @_handle.register
    def _on_compare(self, command: SetCompare) -> None:
        self._set_compare(tuple(command.planners))

    @_handle.register
    def _on_speed(self, command: SetSpeed) -> None:
        self._speed = float(command.speed)

    @_handle.register
    def _on_gait(self, command: SetGait) -> None:
        if command.gait != self._gait_name:
            self._rebuild(gait=command.gait)
            self._notify(f"Gait set to {command.gait}: the robot restarted from the start.")

    @_handle.register
    def _on_planner(self, command: SetPlanner) -> None:
        if command.planner != self._planner_name:
            compare = self._compare_planners
            if compare:  # the main robot's planner is compare mode's first
                self._compare_planners = (command.planner, *compare[1:])
            try:
                self._rebuild(planner=command.planner)
            except Exception:
                self._compare_planners = compare
                raise
            self._notify(f"Planner set to {self._planner_active}: the robot restarted from the start.")

    @_handle.register
    def _on_retarget(self, command: SetRetarget) -> None:
        if bool(command.on) != self._retarget:
            self._retarget = bool(command.on)
            for loco in self._locos():
                use_retarget(loco, self._retarget)
            self._notify(f"Swing retargeting {'on: a pushed swing may land elsewhere' if command.on else 'off'}"
                         " (ContactNet and fixed planners; no restart).")

    @_handle.register
    def _on_observer(self, command: SetObserver) -> None:
        if bool(command.on) != self._observer:
            self._observer = bool(command.on)
            for loco in self._locos():
                use_observer(loco, self._observer)
            self._notify(f"Disturbance observer {'on: a push is estimated, resisted and leaned into' if command.on else 'off'}"
                         " (no restart).")

    @_handle.register
    def _on_sim(self, command: SetSim) -> None:
        if command.engine != self._sim:
            if not engine_installed(command.engine):
                raise ValueError(f"the physics engine {command.engine} is not installed on this server")
            self._rebuild(sim=command.engine)
            self._notify(f"Physics engine {ENGINE_NAMES[command.engine]}: the robot restarted.")

    @_handle.register
    def _on_noise(self, command: SetNoise) -> None:
        if bool(command.on) != self._noise:
            self._rebuild(noise=bool(command.on))
            self._notify(f"Joint-velocity noise {'on' if command.on else 'off'}: the robot restarted.")

    @_handle.register
    def _on_terrain(self, command: SetTerrain) -> None:
        history = EditHistory(command.terrain.to_dict())  # a new terrain forgets the undo steps
        self._rebuild(terrain=(command.terrain, command.label))
        self._terrain_history, self._terrain_base_label = history, command.label
        self._terrain_chosen = True
        self._notify(f"Terrain {command.label} loaded: the robot starts from its start.")

    @_handle.register
    def _on_edit(self, command: EditTerrain) -> bool:
        history = self._terrain_history
        new = command.edit(history.current, *command.args)
        if new == history.current:
            return False
        self._change_terrain(new, "edited")
        history.apply(new)
        return True

    @_handle.register
    def _on_undo(self, command: UndoTerrainEdit) -> None:
        previous = self._terrain_history.previous  # EditError when there is nothing to undo
        self._change_terrain(previous, "edit undone")
        self._terrain_history.undo()

    @_handle.register
    def _on_redo(self, command: RedoTerrainEdit) -> None:
        following = self._terrain_history.following  # EditError when there is nothing to redo
        self._change_terrain(following, "edit redone")
        self._terrain_history.redo()

    @_handle.register
    def _on_rename(self, command: RenameTerrain) -> None:
        self._terrain_label = self._terrain_base_label = command.label

    def _set_velocity(self, vel: tuple[float, float]) -> None:
        self._vel = vel
        self._loco.set_command(*vel)
        if self._compare is not None:
            self._compare.set_command(*vel)

    def _set_compare(self, planners: tuple[str, ...]) -> None:
        """Compare mode on (main planner first) or off; either way every robot restarts from the start."""
        old = (self._compare_planners, self._planner_name)
        self._compare_planners = planners
        try:
            self._rebuild(planner=planners[0] if planners else None)
        except Exception:
            self._compare_planners, self._planner_name = old
            raise
        others = ", ".join(self._compare.planners) if self._compare is not None else ""
        self._notify(f"Compare mode: {self._planner_active} (solid) beside {others} (ghost), both from the start."
                     if planners else "Compare mode off: the robot restarted from the start.")

    def _change_terrain(self, data: dict[str, Any], what: str) -> None:
        """Make ``data`` the session's terrain: in place when the change is away from the robot, else by
        restarting the robot (paused, so several edits can be made before it walks again)."""
        terrain = to_terrain(data)
        label = self._edited_label()
        same_robot = self._robot.for_terrain(terrain, self._gait_name) is self._loco.robot  # stance, gains by terrain
        if same_robot and change_is_away(self._terrain, terrain, self._robot,
                                         [loco.snapshot() for loco in self._locos()]):
            self._loco.replace_terrain(terrain)
            if self._compare is not None:
                self._compare.replace_terrain(terrain)
            self._terrain, self._terrain_label = terrain, label
            self._tracker.terrain = terrain
            self._terrain_version += 1
            self._notify(f"Terrain {what} away from the robot: applied without a restart.")
        else:
            self._rebuild(terrain=(terrain, label))
            self._paused = True
            why = "near the robot" if same_robot else (
                "and the robot takes its stance and gains for terrain " + ("with heights" if terrain.has_heights else "of one level"))
            self._notify(f"Terrain {what} {why}: it restarted from the start and waits - press Run.", "warning")

    def _locos(self) -> list[Locomotion]:
        """The main robot's Locomotion, then compare mode's others."""
        return [self._loco] + ([o.loco for o in self._compare.others] if self._compare is not None else [])

    def _edited_label(self) -> str:
        return f"{self._terrain_base_label} (edited)"

    def _rebuild(
        self,
        gait: str | None = None,
        planner: str | None = None,
        noise: bool | None = None,
        terrain: tuple[Terrain, str] | None = None,
        sim: str | None = None,
    ) -> None:
        """New settings need a new Locomotion; on failure the old settings and world stay."""
        old = (self._gait_name, self._planner_name, self._noise, self._terrain, self._terrain_label, self._sim)
        if gait is not None:
            self._gait_name = gait
        if planner is not None:
            self._planner_name = planner
        if noise is not None:
            self._noise = noise
        if terrain is not None:
            self._terrain, self._terrain_label = terrain
        self._sim = self._sim if sim is None else sim
        try:
            self._build(publish=False)  # the terrain's history changes after this: publish both at once
        except Exception:
            self._gait_name, self._planner_name, self._noise, self._terrain, self._terrain_label, self._sim = old
            raise
        if terrain is not None:
            self._terrain_version += 1
        self._error = None
