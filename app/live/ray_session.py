"""A live session in a Ray actor (``contactnet serve --engine ray [--address A]``): the simulation runs in a Ray
worker (this machine's local Ray, or any node of a cluster), the web process only forwards commands and receives
snapshots (docs/sessions-on-ray.md).

- `SessionActor` (in the worker) holds an ordinary `LiveSession`: physics, planner, controller, pacing, the
  terrain's edit history, runs, compare mode. It answers `latest` (the newest `LiveView`, pickled, when newer than
  the caller's) and `call` (apply one command, then hand back the view that shows its effect).
- `RaySession` (in the web process) is its `SessionBackend`: a poll thread asks for the latest view at the scene's
  rate (``settings.scene_hz``), so `view` never blocks; one dispatch thread sends the commands in the order they
  were submitted (as the session's own queue would). The static parts cross only when they change (the terrain
  and its dict form: its version; the gait: its name): every other view comes without them and is completed here
  (`ViewPacket`). What crossed is counted in `transfer` (bytes per view: the figures of docs/sessions-on-ray.md).
  While a command is awaited, polls take no view with a new terrain or gait: the command's answer brings it.
- A lost actor (its worker or node died): the poll or the command sees Ray's error, the session says so in one
  line (`lost`, the view's status error, every later command's RuntimeError: a 503), and the visit pool reclaims
  the visit (`app.api.visits`).

Ray itself (started, joined or left running) is the caller's: `app.api.server.ContactnetApp` opens it with
`contactnet.jobs.ray_engine.session`.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import pickle
import queue
import socket
import threading
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

from app.live.backend import wait_view
from app.live.commands import Command, check_command
from app.live.pacing import PacingStats
from app.live.planners import PlannerFactory, default_planner_factory
from app.live.session import LiveSession
from app.live.settings import ServeSettings
from app.live.view import LiveView
from contactnet.motion.gait import GaitSpec
from contactnet.records import Snapshot
from contactnet.terrain import Terrain

log = logging.getLogger("contactnet.app.ray_session")

#: A poll that gets no answer for this long (the worker hangs, the network is cut) counts as a lost actor.
POLL_TIMEOUT_S = 30.0
#: The PacingStats fields copied from the actor with every view (the web side's `RaySession.stats`).
_STATS = ("running_wall_s", "running_sim_s", "lag_resets", "behind_s", "longest_stall_s")


@dataclass(frozen=True)
class ViewPacket:
    """What crosses from the actor per view: the LiveView without its static parts (``terrain``, ``terrain_dict``
    and ``gait`` None), which come in `terrain` and `gait` only when the receiver's are older (`Known`); and the
    pacing figures."""

    view: LiveView
    terrain: tuple[Terrain, dict[str, Any] | None] | None
    gait: GaitSpec | None
    stats: tuple[float, ...]


#: What the receiver has of a session's static parts: (terrain version, gait name); (-1, "") at first.
Known = tuple[int, str]
NOTHING_KNOWN: Known = (-1, "")


@dataclass
class TransferStats:
    """Views received by the web process and their pickled sizes (bytes)."""

    views: int = 0
    bytes_total: int = 0
    bytes_max: int = 0
    bytes_last: int = 0
    with_terrain: int = 0  #: views that carried the terrain (its version changed)

    def add(self, size: int, terrain: bool) -> None:
        self.views += 1
        self.bytes_total += size
        self.bytes_max = max(self.bytes_max, size)
        self.bytes_last = size
        self.with_terrain += terrain

    @property
    def bytes_mean(self) -> float:
        return self.bytes_total / self.views if self.views else 0.0


def _without_ranking(snapshot: Snapshot | None) -> Snapshot | None:
    """The snapshot without the planner's lazy `CandidateRanking` (it holds functions, which do not pickle, and
    a copy of the terrain): the web side reads the ranking as the view's `CandidateView`, made in the actor."""
    if snapshot is None or snapshot.candidates is None:
        return snapshot
    return dataclasses.replace(snapshot, candidates=None)


def pack(view: LiveView, stats: PacingStats, known: Known = NOTHING_KNOWN) -> bytes:
    """``view`` pickled for a receiver that has the static parts ``known`` (its terrain's version, its gait's
    name): the terrain and the gait cross only when they changed."""
    terrain = None if view.terrain_version == known[0] else (view.terrain, view.terrain_dict)
    gait = None if view.gait.name == known[1] else view.gait
    compare = view.compare
    if compare is not None:
        compare = tuple(dataclasses.replace(robot, snapshot=_without_ranking(robot.snapshot)) for robot in compare)
    light = dataclasses.replace(view, terrain=None, terrain_dict=None, gait=None,
                                snapshot=_without_ranking(view.snapshot), compare=compare)
    figures = tuple(float(getattr(stats, name)) for name in _STATS)
    return pickle.dumps(ViewPacket(light, terrain, gait, figures), protocol=pickle.HIGHEST_PROTOCOL)


class SessionActor:
    """One `LiveSession` in a Ray worker (made a Ray actor by `RaySession.start`; see the module docstring)."""

    def __init__(self, settings: ServeSettings, terrain: Terrain, terrain_label: str | None,
                 planner_factory: PlannerFactory):
        self._session = LiveSession(settings, terrain, terrain_label, planner_factory=planner_factory)

    def start(self, timeout: float) -> dict[str, Any]:
        """Start the session; where it runs (pid, host) and its id."""
        self._session.start(timeout)
        return {"pid": os.getpid(), "host": socket.gethostname(), "session_id": self._session.session_id}

    def latest(self, seq: int, known: Known, carry_static: bool = True) -> bytes | None:
        """The newest view (`pack`ed for a receiver that has ``known``) when its seq differs from ``seq``, else
        None. With ``carry_static`` False (the receiver awaits a command's answer, which brings them) a view
        whose terrain or gait the receiver lacks is not sent either."""
        view = self._session.view
        if view is None or view.seq == seq:
            return None
        if not carry_static and (view.terrain_version != known[0] or view.gait.name != known[1]):
            return None
        return pack(view, self._session.stats, known)

    def call(self, command: Command, timeout: float, known: Known) -> tuple[Any, bytes | None]:
        """Apply ``command`` (its errors raised as themselves); its result and the view that shows its effect."""
        result = self._session.call(command, timeout)
        view = self._session.view
        return result, None if view is None else pack(view, self._session.stats, known)

    def stop(self) -> None:
        self._session.stop()


class RaySession:
    """The web side of a `SessionActor`: a `app.live.backend.SessionBackend` (see the module docstring).

    ``num_cpus``: the CPUs Ray reserves for the actor (a session takes about a third of a core:
    `app.api.visits.SESSION_CPU_CORES`)."""

    def __init__(
        self,
        settings: ServeSettings,
        terrain: Terrain,
        terrain_label: str | None = None,
        *,
        planner_factory: PlannerFactory = default_planner_factory,
        num_cpus: float = 1.0,
    ):
        self.settings = settings
        self.stats = PacingStats()
        self.transfer = TransferStats()
        self.session_id = ""
        self.worker_pid: int | None = None  #: the actor's process (on `worker_host`)
        self.worker_host: str | None = None
        self.poll_period_s = 1.0 / settings.scene_hz
        self._args = (settings, terrain, terrain_label, planner_factory)
        self._num_cpus = num_cpus
        self._actor: Any = None
        self._view: LiveView | None = None
        self._terrain: tuple[int, Terrain, dict[str, Any] | None] | None = None  # (version, terrain, its dict)
        self._gait: GaitSpec | None = None
        self._install_lock = threading.Lock()
        self._commanding = threading.Event()  # a command's answer (with the view that shows it) is awaited
        self._commands: queue.Queue[tuple[Command, float, Future] | None] = queue.Queue()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._lost: str | None = None

    # ---- life -----------------------------------------------------------------------------------------
    def start(self, timeout: float = 60.0) -> RaySession:
        import ray

        actor_class = ray.remote(SessionActor).options(num_cpus=self._num_cpus, max_concurrency=4)
        self._actor = actor_class.remote(*self._args)
        try:
            info = ray.get(self._actor.start.remote(timeout), timeout=timeout + 30.0)
        except Exception as exc:
            self._kill()
            raise RuntimeError(f"the live session's Ray actor failed to start: {_one_line(_cause(exc))}") from exc
        self.worker_pid, self.worker_host, self.session_id = info["pid"], info["host"], info["session_id"]
        self._poll()  # the first view, before anyone reads `view`
        for name, target in (("ray-session-poll", self._poll_loop), ("ray-session-commands", self._dispatch_loop)):
            thread = threading.Thread(target=target, name=name, daemon=True)
            thread.start()
            self._threads.append(thread)
        return self

    def stop(self, timeout: float = 10.0) -> None:
        if self._actor is None:
            return
        self._stop.set()
        self._commands.put(None)
        for thread in self._threads:
            thread.join(timeout)
        self._threads = []
        if self._lost is None:
            import ray

            try:
                ray.get(self._actor.stop.remote(), timeout=timeout)
            except Exception as exc:  # noqa: BLE001 - killed below either way
                log.warning("stopping the live session's actor: %s", _one_line(exc))
        self._kill()

    def _kill(self) -> None:
        import ray

        actor, self._actor = self._actor, None
        if actor is not None:
            try:
                ray.kill(actor)
            except Exception as exc:  # noqa: BLE001 - already gone, or Ray shut down
                log.debug("ray.kill: %s", exc)

    # ---- the SessionBackend side ------------------------------------------------------------------------
    @property
    def view(self) -> LiveView | None:
        return self._view

    @property
    def alive(self) -> bool:
        return self._actor is not None and not self._stop.is_set() and self._lost is None

    @property
    def lost(self) -> str | None:
        return self._lost

    def submit(self, command: Command) -> Future:
        future: Future = Future()
        try:
            check_command(command)
        except ValueError as exc:
            future.set_exception(exc)
            return future
        if not self.alive:
            future.set_exception(RuntimeError(self._lost or "the live session is not running"))
            return future
        self._commands.put((command, 30.0, future))
        return future

    def call(self, command: Command, timeout: float = 30.0) -> Any:
        check_command(command)  # ValueError: a value the session must never see
        future: Future = Future()
        if not self.alive:
            raise RuntimeError(self._lost or "the live session is not running")
        self._commands.put((command, timeout, future))
        return future.result(timeout + 5.0)

    def wait_view(self, predicate: Callable[[LiveView], bool], timeout: float = 10.0) -> LiveView:
        return wait_view(self, predicate, timeout)

    # ---- the threads ------------------------------------------------------------------------------------
    def _known(self) -> Known:
        return (-1 if self._terrain is None else self._terrain[0], "" if self._gait is None else self._gait.name)

    def _poll(self) -> None:
        import ray

        seq = -1 if self._view is None else self._view.seq
        # during a command, a view with a new terrain or gait waits for the command's answer: polls asked with
        # the old `known` would each carry the terrain again (only one already in flight still may)
        carry_static = not self._commanding.is_set()
        try:
            data = ray.get(self._actor.latest.remote(seq, self._known(), carry_static), timeout=POLL_TIMEOUT_S)
        except ray.exceptions.GetTimeoutError:
            self._lose(f"no answer for {POLL_TIMEOUT_S:g} s")
            return
        except ray.exceptions.RayError as exc:
            self._lose(_one_line(_cause(exc)), exc)
            return
        if data is not None:
            self._install(data)

    def _poll_loop(self) -> None:
        while not self._stop.wait(self.poll_period_s) and self._lost is None:
            self._poll()

    def _dispatch_loop(self) -> None:
        import ray

        while True:
            item = self._commands.get()
            if item is None:
                break
            command, timeout, future = item
            if not self.alive:
                future.set_exception(RuntimeError(self._lost or "the live session is not running"))
                continue
            self._commanding.set()
            try:
                ref = self._actor.call.remote(command, timeout, self._known())
                result, data = ray.get(ref, timeout=timeout + 5.0)
            except ray.exceptions.GetTimeoutError:
                future.set_exception(TimeoutError("the live session did not answer in time"))
            except ray.exceptions.RayTaskError as exc:
                future.set_exception(_cause(exc))
            except ray.exceptions.RayError as exc:  # the actor died
                self._lose(_one_line(exc), exc)
                future.set_exception(RuntimeError(self._lost or "the live session is not running"))
            else:
                if data is not None:
                    self._install(data)
                future.set_result(result)
            finally:
                self._commanding.clear()
        while not self._commands.empty():  # stopped: refuse what is left
            item = self._commands.get_nowait()
            if item is not None:
                item[2].set_exception(RuntimeError("the live session is not running"))

    def _install(self, data: bytes) -> None:
        """Make the packed view `view` (unless a newer one is there already), its terrain completed."""
        packet: ViewPacket = pickle.loads(data)  # noqa: S301 - our own actor's bytes (Ray itself pickles too)
        with self._install_lock:
            if packet.terrain is not None:
                self._terrain = (packet.view.terrain_version, *packet.terrain)
            if packet.gait is not None:
                self._gait = packet.gait
            self.transfer.add(len(data), packet.terrain is not None)
            current = self._view
            if current is not None and current.seq >= packet.view.seq:
                return
            for name, value in zip(_STATS, packet.stats, strict=True):
                setattr(self.stats, name, int(value) if name == "lag_resets" else value)
            _, terrain, terrain_dict = self._terrain
            self._view = dataclasses.replace(packet.view, terrain=terrain, terrain_dict=terrain_dict, gait=self._gait)

    def _lose(self, why: str, exc: BaseException | None = None) -> None:
        """The actor is gone: say so once, in the view too (the page's status line shows the error)."""
        with self._install_lock:
            if self._lost is not None or self._stop.is_set():
                return
            where = f" on {self.worker_host}" if self.worker_host else ""
            self._lost = f"the live session's simulation (a Ray actor{where}) was lost: {why}"
            log.error("%s%s", self._lost, f"\n{exc}" if exc is not None else "")
            view = self._view
            if view is not None:
                status = dataclasses.replace(view.status, error=self._lost, running=False, real_time_factor=0.0)
                self._view = dataclasses.replace(view, seq=view.seq + 1, status=status)


def _cause(exc: BaseException) -> BaseException:
    """A Ray task's own exception (what the session raised), else ``exc``."""
    cause = getattr(exc, "cause", None)
    return cause if isinstance(cause, BaseException) else exc


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return (text[0] if text else type(exc).__name__)[:300]
