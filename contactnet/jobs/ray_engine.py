"""The ``ray`` engine of `contactnet.jobs.runner`: the jobs run as Ray tasks, on an existing Ray cluster or on a
local Ray started for the run (``pip install contactnet[ray]``; nothing else here needs Ray).

- Where (`session`): a Ray already initialised in this process, as it is; else the cluster at ``address``
  (``--address``) or ``$RAY_ADDRESS`` (``host:port``, ``auto``, ``ray://host:port``; a cluster with token
  authentication also needs Ray's ``RAY_AUTH_MODE=token`` and its token); else a local Ray started with
  ``workers`` CPUs (default: this machine's), no dashboard, quiet logs, on the loopback interface only (Ray's
  own local-only switch, read when Ray is imported: it holds when this module imports Ray first; Ray adds a
  token of its own and sends no usage report). Only what was started for the batch is stopped at its end (a
  local Ray shut down, a cluster disconnected from); a caller holding a `session` around several batches
  starts Ray once.
- What: each job is one task of one CPU (``workers`` also caps how many run at once on a cluster). A
  worker process runs ``worker_init`` once, before its first job. Every worker checks once that its code
  (``identity()``: the contactnet sources and the numerical packages, `contactnet.jobs.runner.code_identity`) is
  the driver's, so that a result is never stored under the fingerprint of code that did not make it: a
  cluster must have the same contactnet installed on every node.
- Stopping: Ctrl-C, an error in a job (re-raised as the job's own exception, the remote traceback
  chained) or the caller closing the generator cancels every task not yet returned (``force``: the
  workers running them are killed); the results already yielded were stored by the caller.

Storage stays in the caller's process (`contactnet.jobs.runner.run_jobs`' ``on_result``): workers only compute
and return, so a cluster needs no shared file system.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import json
import logging
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Any

INSTALL_HINT = "--engine ray needs Ray: pip install contactnet[ray]"
#: Ray's switch that keeps a local Ray on 127.0.0.1 (it is on for macOS and Windows); read by ``import ray``.
_LOCAL_ONLY_ENV = {"RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}


class EngineUnavailable(RuntimeError):
    """The engine cannot run here (Ray is not installed): one line saying how to get it."""


def cluster_address(address: str | None) -> str | None:
    """The cluster to connect to: ``address``, else ``$RAY_ADDRESS``, else None (a local Ray)."""
    return address or os.environ.get("RAY_ADDRESS") or None


def import_ray(local: bool = True) -> Any:
    """The ``ray`` module, imported with the loopback-only switch when it is first imported for a local
    Ray; `EngineUnavailable` when Ray is not installed."""
    if sys.modules.get("ray") is not None:  # imported already (with or without the switch)
        return sys.modules["ray"]
    saved = {name: os.environ.get(name) for name in _LOCAL_ONLY_ENV}
    if local:
        os.environ.update({name: value for name, value in _LOCAL_ONLY_ENV.items() if saved[name] is None})
    try:
        import ray
    except ImportError:
        raise EngineUnavailable(INSTALL_HINT) from None
    finally:
        for name, value in saved.items():  # Ray read it at import: our environment is left as it was
            if value is None:
                os.environ.pop(name, None)
    return ray


@contextlib.contextmanager
def session(address: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """Ray for the length of the block (yields the ``ray`` module): a Ray already initialised in this process
    as it is, else the cluster at ``address`` / ``$RAY_ADDRESS``, else a local Ray of ``workers`` CPUs
    (default: this machine's) on the loopback only. Only what it started is stopped (a local Ray) or left (a
    cluster) at the end. `ray_engine` opens one per batch; a caller that runs several batches opens one
    around them, so that Ray starts once."""
    address = cluster_address(address)
    ray = import_ray(local=address is None)
    if ray.is_initialized():
        yield ray
        return
    quiet = {"include_dashboard": False, "logging_level": logging.ERROR, "log_to_driver": False}
    if address is None:
        ray.init(num_cpus=workers or os.cpu_count() or 1, **quiet)
    else:
        ray.init(address=address, **quiet)
    try:
        yield ray
    finally:
        ray.shutdown()


def ray_engine(call: Callable[[Any], Any], items: Sequence[Any], workers: int | None,
               worker_init: Callable[[], None] | None, address: str | None = None,
               identity: Callable[[], Any] | None = None) -> Iterator[Any]:
    """Apply ``call`` to every item as Ray tasks (at most ``workers`` at once) and yield the results as they
    arrive (see the module)."""
    with session(address, workers) as ray:
        task = ray.remote(num_cpus=1)(_run_job)
        expected = json.dumps(identity(), sort_keys=True) if identity is not None else ""
        queue = iter(items)
        pending: set[Any] = set()
        try:
            for item in itertools.islice(queue, workers or len(items)):
                pending.add(task.remote(call, item, worker_init, identity, expected))
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                pending.difference_update(ready)
                for item in itertools.islice(queue, len(ready)):
                    pending.add(task.remote(call, item, worker_init, identity, expected))
                for ref in ready:
                    yield _get(ray, ref)
        finally:  # Ctrl-C, an error, or the caller stopped listening: no task is left running
            for ref in pending:
                ray.cancel(ref, force=True)


def _get(ray: Any, ref: Any) -> Any:
    """The task's result; a job's exception is re-raised as itself (the remote traceback chained)."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayTaskError as exc:
        cause = getattr(exc, "cause", None)
        if isinstance(cause, BaseException) and not isinstance(cause, ray.exceptions.RayError):
            raise cause from exc
        raise


def _run_job(call: Callable[[Any], Any], item: Any, worker_init: Callable[[], None] | None,
             identity: Callable[[], Any] | None, expected: str) -> Any:
    """One job in a Ray worker; the worker's first job checks its code and runs ``worker_init``."""
    _prepare_worker(worker_init, identity, expected)
    return call(item)


@functools.cache
def _prepare_worker(worker_init: Callable[[], None] | None, identity: Callable[[], Any] | None,
                    expected: str) -> None:
    """Once per worker process: refuse code other than the driver's (``expected``: its ``identity()`` as
    JSON), then run ``worker_init``."""
    if identity is not None:
        mine, theirs = identity(), json.loads(expected)
        if json.dumps(mine, sort_keys=True) != expected:
            import socket

            differ = sorted(k for k in {*mine, *theirs} if mine.get(k) != theirs.get(k)) \
                if isinstance(mine, dict) and isinstance(theirs, dict) else ["code"]
            raise EngineUnavailable(
                f"the Ray worker on {socket.gethostname()} runs other code than this process "
                f"({', '.join(differ)} differ): install the same contactnet and packages on every node")
    if worker_init is not None:
        worker_init()
