"""What `contactnet serve` starts with (`ServeSettings`), and the limits every input of the web tool obeys.

The limits are defined here once: the command line, the REST models (pydantic bounds), the control
panel's sliders and the live session's last-line checks (`app.commands.check_command`) all read them.
`settings_from_args` builds the settings from the ``serve`` subcommand's argparse values.

This module is cheap to import (the command line builds its parser from it): the registry of gaits,
planners and robots is only imported when settings are validated.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: Commanded base velocity, per axis (|vx|, |vy|), in m/s.
VELOCITY_LIMIT_M_S = 0.3
#: Magnitude of a push's horizontal force |(fx, fy)|, in N.
PUSH_FORCE_LIMIT_N = 20.0
#: Longest push, in s (a push lasts more than 0 s).
PUSH_DURATION_LIMIT_S = 5.0
#: Simulation speed: simulated seconds per wall-clock second, (lowest, highest).
SIM_SPEED_RANGE = (0.1, 2.0)
#: Rate of the scene recordings, (lowest, highest), in Hz of simulated time.
RECORD_RATE_RANGE_HZ = (0.5, 60.0)


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class ServeSettings:
    """How the web tool starts: where it listens, what the live session runs first, and its folders.

    Invalid values raise a one-line ValueError naming the field (`__post_init__`)."""

    host: str = "127.0.0.1"
    port: int = 8000  #: the web page and the REST API
    viser_port: int = 8080  #: the 3D view (viser's own websocket server)
    terrain: str = "stepping_stones"  #: a terrain name (file in terrains/ or generator) or a JSON path
    robot: str = "solo12"
    gait: str = "walk"
    planner: str = "contactnet"
    vx_m_s: float = 0.05  #: commanded forward velocity at the start
    vy_m_s: float = 0.0  #: commanded leftward velocity at the start
    paused: bool = False  #: start paused (press Run)
    noise: bool = False  #: the paper's joint-velocity noise at the start
    sim_speed: float = 1.0  #: simulated seconds per wall-clock second at the start
    terrains_dir: Path | None = None  #: terrain files; None: the shipped terrains/ folder
    recordings_dir: Path = Path("recordings")
    models_dir: Path | None = None  #: trained models (registry.model_path names); None: the shipped ones
    scene_hz: float = 30.0  #: scene updates sent to browsers
    record_hz: float = 12.0  #: frames of a recording per simulated second

    def __post_init__(self) -> None:
        from contactnet import registry

        def fail(field: str, expected: str) -> None:
            raise ValueError(f"{field} must be {expected}, got {getattr(self, field)!r}")

        for field in ("port", "viser_port"):
            value = getattr(self, field)
            if not (isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= 65535):
                fail(field, "a port number in 1..65535")
        for field in ("vx_m_s", "vy_m_s"):
            value = getattr(self, field)
            if not (_finite(value) and abs(value) <= VELOCITY_LIMIT_M_S):
                fail(field, f"in [-{VELOCITY_LIMIT_M_S}, {VELOCITY_LIMIT_M_S}] m/s")
        low, high = SIM_SPEED_RANGE
        if not (_finite(self.sim_speed) and low <= self.sim_speed <= high):
            fail("sim_speed", f"in [{low}, {high}]")
        if not (_finite(self.scene_hz) and self.scene_hz > 0):
            fail("scene_hz", "a positive rate in Hz")
        low, high = RECORD_RATE_RANGE_HZ
        if not (_finite(self.record_hz) and low <= self.record_hz <= high):
            fail("record_hz", f"in [{low}, {high}] Hz")
        for field, names in (
            ("robot", registry.robot_names()),
            ("gait", registry.gait_names()),
            ("planner", registry.planner_names()),
        ):
            if getattr(self, field) not in names:
                fail(field, f"one of {', '.join(names)}")
        if not isinstance(self.terrain, str) or not self.terrain:
            fail("terrain", "a terrain name or a JSON path")
        for field in ("terrains_dir", "recordings_dir", "models_dir"):
            value = getattr(self, field)
            if value is not None and not isinstance(value, Path):
                object.__setattr__(self, field, Path(value))


#: argparse destination of the ``serve`` subcommand -> ServeSettings field (missing ones keep their defaults).
CLI_FIELDS = {
    "host": "host",
    "port": "port",
    "viser_port": "viser_port",
    "terrain": "terrain",
    "robot": "robot",
    "gait": "gait",
    "planner": "planner",
    "vx": "vx_m_s",
    "vy": "vy_m_s",
    "recordings": "recordings_dir",
}


def settings_from_args(args: Any) -> ServeSettings:
    """ServeSettings from the ``serve`` subcommand's values (an argparse Namespace or a mapping) named as in
    `CLI_FIELDS`; values that are absent or None keep the defaults. ValueError (one line) if one is invalid."""
    values = args if isinstance(args, Mapping) else vars(args)
    given = {field: values[dest] for dest, field in CLI_FIELDS.items() if values.get(dest) is not None}
    if "recordings_dir" in given:
        given["recordings_dir"] = Path(given["recordings_dir"])
    return ServeSettings(**given)
