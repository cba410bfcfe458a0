"""What `contactnet serve` starts with (`ServeSettings`), and the limits every input of the web tool obeys.

The limits are defined here once: the command line, the REST models (pydantic bounds), the control
panel's sliders and the live session's last-line checks (`app.live.commands.check_command`) all read them.
`settings_from_args` builds the settings from the ``serve`` subcommand's argparse values.

This module is cheap to import (the command line builds its parser from it): the registry of gaits,
planners and robots is only imported when settings are validated.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from contactnet.sim.world import default_engine

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
#: Largest request body of the JSON commands (everything but a terrain upload), in bytes.
COMMAND_BODY_LIMIT_BYTES = 64 * 1024
#: ``serve --engine``: where visitors' simulations run (`app.live.backend`): threads of the server, or Ray actors.
SESSION_ENGINES = ("local", "ray")
#: Host names that always reach the tool (DNS rebinding protection: any other Host header is refused).
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")


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
    #: the robot waits (``waiting_for_viewer``) until the first browser opens the 3D view, then starts after
    #: `viewer_start_delay_s` (so the scene is drawn before it moves), or until POST /api/pause {"paused": false}
    wait_for_viewer: bool = True
    viewer_start_delay_s: float = 3.0  #: software WebGL draws a first full scene 2-5 s after connecting
    loop: bool = True  #: after the goal or a fall, start the next run after `loop_delay_s`
    loop_delay_s: float = 6.0  #: wall seconds the end-of-run card shows before the next run
    noise: bool = False  #: the paper's joint-velocity noise at the start
    retarget: bool = False  #: swing retargeting (`contactnet.planning.retarget`) at the start; off like the library's default
    observer: bool = True  #: the disturbance observer (`contactnet.planning.observer`) at the start; on like the library's
    sim_speed: float = 1.0  #: simulated seconds per wall-clock second at the start
    sim: str = dataclasses.field(default_factory=default_engine)  #: the physics engine: pybullet (mujoco where it is not installed)
    #: the user's terrain files (saved from the page or PUT /api/terrains); None: <data dir>/terrains, the data
    #: dir being $CONTACTNET_DATA or ~/.local/share/contactnet. The shipped terrains are read from the package.
    terrains_dir: Path | None = None
    recordings_dir: Path | None = None  #: scene recordings; None: <data dir>/recordings
    models_dir: Path | None = None  #: trained models (registry.model_path names); None: the shipped ones
    scene_hz: float = 30.0  #: scene updates sent to browsers
    record_hz: float = 12.0  #: frames of a recording per simulated second
    #: more Host names the tool answers to (besides 127.0.0.1, localhost, ::1 and `host`), e.g. a machine name
    allowed_hosts: tuple[str, ...] = ()
    #: access token required by the API and the 3D view when `host` is not a loopback address (None: a new
    #: random one, printed at start-up); on loopback no token is asked for
    token: str | None = None
    #: a robot per visitor (`app.api.visits`): at most this many live sessions at once, the default one included
    #: (None: `app.api.visits.default_max_sessions()`, from a session's measured CPU cost)
    max_sessions: int | None = None
    session_idle_s: float = 120.0  #: a visitor's session is reclaimed after this long without its page open
    shared: bool = False  #: every visitor drives the one default session (no per-visitor sessions)
    #: where visitors' simulations run (`SESSION_ENGINES`, `app.live.backend`): ``local``, threads of this process;
    #: ``ray``, one Ray actor per session (`app.live.ray_session`, docs/sessions-on-ray.md)
    engine: str = "local"
    #: ``engine="ray"``: the Ray cluster to use (host:port, auto, ray://host:port); None: $RAY_ADDRESS, else a
    #: local Ray of this machine's CPUs (a Ray already started in this process is used as it is)
    address: str | None = None

    def __post_init__(self) -> None:
        from contactnet import registry
        from contactnet.sim.world import ENGINES

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
        if self.max_sessions is not None and not (
            isinstance(self.max_sessions, int) and not isinstance(self.max_sessions, bool)
            and 1 <= self.max_sessions <= 64
        ):
            fail("max_sessions", "None or a number of sessions in 1..64")
        if self.engine not in SESSION_ENGINES:
            fail("engine", f"one of {', '.join(SESSION_ENGINES)}")
        if self.address is not None and not (isinstance(self.address, str) and self.address.strip()):
            fail("address", "None or a Ray cluster address (host:port, auto, ray://host:port)")
        if self.address is not None and self.engine != "ray":
            fail("address", "None unless engine is 'ray' (a cluster address needs --engine ray)")
        if not (_finite(self.session_idle_s) and 1.0 <= self.session_idle_s <= 86400.0):
            fail("session_idle_s", "in [1, 86400] s")
        for field in ("viewer_start_delay_s", "loop_delay_s"):
            value = getattr(self, field)
            if not (_finite(value) and 0.0 <= value <= 600.0):
                fail(field, "in [0, 600] s")
        if not (_finite(self.scene_hz) and self.scene_hz > 0):
            fail("scene_hz", "a positive rate in Hz")
        low, high = RECORD_RATE_RANGE_HZ
        if not (_finite(self.record_hz) and low <= self.record_hz <= high):
            fail("record_hz", f"in [{low}, {high}] Hz")
        for field, names in (
            ("robot", registry.robot_names()),
            ("gait", registry.gait_names()),
            ("planner", registry.planner_names()),
            ("sim", ENGINES),
        ):
            if getattr(self, field) not in names:
                fail(field, f"one of {', '.join(names)}")
        if not isinstance(self.terrain, str) or not self.terrain:
            fail("terrain", "a terrain name or a JSON path")
        for field in ("terrains_dir", "recordings_dir", "models_dir"):
            value = getattr(self, field)
            if value is not None and not isinstance(value, Path):
                object.__setattr__(self, field, Path(value))
        if not isinstance(self.host, str) or not self.host or any(c in self.host for c in "/ #?@"):
            fail("host", "a host name or an IP address")
        if isinstance(self.allowed_hosts, str) or not all(_host_name_ok(h) for h in self.allowed_hosts):
            fail("allowed_hosts", "a tuple of host names or IP addresses")
        object.__setattr__(self, "allowed_hosts", tuple(self.allowed_hosts))
        if self.token is not None and not (isinstance(self.token, str) and 16 <= len(self.token) <= 256
                                           and self.token.isascii() and self.token.isprintable()):
            fail("token", "None or 16..256 printable ASCII characters")
        if self.terrains_dir is not None:
            from contactnet.terrain import terrains_dir

            if _inside(self.terrains_dir, terrains_dir()):
                fail("terrains_dir", "a folder of your own, not the shipped terrains (they are read-only)")

    @property
    def loopback(self) -> bool:
        """Is the tool bound to a loopback address only (then no access token is needed)?"""
        return is_loopback(self.host)

    def user_terrains_dir(self) -> Path:
        """Where the user's terrain files go (`terrains_dir`, else <data dir>/terrains)."""
        from contactnet.paths import default_data_dir

        return self.terrains_dir if self.terrains_dir is not None else default_data_dir() / "terrains"

    def recordings_folder(self) -> Path:
        """Where scene recordings go (`recordings_dir`, else <data dir>/recordings)."""
        from contactnet.paths import default_data_dir

        return self.recordings_dir if self.recordings_dir is not None else default_data_dir() / "recordings"


def _host_name_ok(host: object) -> bool:
    return isinstance(host, str) and bool(host) and (_is_ip(host.strip("[]")) or not any(c in host for c in "/ #?@:[]"))


def _is_ip(text: str) -> bool:
    import ipaddress

    try:
        ipaddress.ip_address(text)
    except ValueError:
        return False
    return True


def is_loopback(host: str) -> bool:
    """127.0.0.0/8, ::1 and localhost; not the wildcard addresses (0.0.0.0, ::), which listen everywhere."""
    import ipaddress

    if host.strip("[]").lower() in ("localhost", "localhost."):
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _inside(path: Path, folder: Path) -> bool:
    path, folder = Path(path).resolve(), Path(folder).resolve()
    return path == folder or folder in path.parents


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
    "allow_host": "allowed_hosts",
    "wait": "wait_for_viewer",
    "loop": "loop",
    "sim": "sim",
    "max_sessions": "max_sessions",
    "session_idle": "session_idle_s",
    "shared": "shared",
    "engine": "engine",
    "address": "address",
}


def settings_from_args(args: Any) -> ServeSettings:
    """ServeSettings from the ``serve`` subcommand's values (an argparse Namespace or a mapping) named as in
    `CLI_FIELDS`; values that are absent or None keep the defaults. ValueError (one line) if one is invalid."""
    values = args if isinstance(args, Mapping) else vars(args)
    given = {field: values[dest] for dest, field in CLI_FIELDS.items() if values.get(dest) is not None}
    if "recordings_dir" in given:
        given["recordings_dir"] = Path(given["recordings_dir"])
    if "allowed_hosts" in given:
        given["allowed_hosts"] = tuple(given["allowed_hosts"])
    return ServeSettings(**given)
