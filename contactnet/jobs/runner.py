"""One resumable job runner for the long commands (``contactnet datagen``, ``contactnet experiment``).

A caller describes its work as `Job`s with stable keys, reads from its own files which keys are already
done, and hands `run_jobs` a picklable job function and a result callback; the callback stores each result
(atomically, or appended to a log) as soon as it arrives, so an interrupted run loses only the jobs in
progress and the same call resumes with the missing ones::

    done = keys_found_in_my_files()
    run_jobs([Job(key, args) for key, args in ...], work, on_result, done=done, workers=4)

The *engine* runs the missing jobs; the results always come back to this process, where the callback
stores them (workers compute, they never write the caller's files). ``"local"`` (the default, needing
nothing) is a ``spawn`` process pool on this machine: workers ignore SIGINT, so Ctrl-C reaches the parent
only, which stops the pool at once, keeps what the callback stored and re-raises KeyboardInterrupt (the
command then prints how to resume). With one worker the jobs run in this process, one after the other.
``"ray"`` (`contactnet.jobs.ray_engine`, the optional extra ``contactnet[ray]``) runs them as Ray tasks on an
existing cluster (``address`` or ``RAY_ADDRESS``) or on a local Ray started for the run; the same Ctrl-C
and error behaviour (the outstanding tasks are cancelled). A new engine is a function with the signature of
`_local_engine` registered in ``_ENGINES``.

Resume keys: a stored result is reused only when everything that determines it is unchanged. The callers
describe those inputs as plain values and compare `digest`s; `code_identity` is the code's part (the
contactnet version, a hash of its sources' syntax trees, Python and the numerical packages); files a resume
or a reader trusts are checked against the size and sha256 recorded when they were written (`check_file`).
"""

from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import json
import os
import platform
import signal
import threading
from collections.abc import Callable, Hashable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: ``engine(call, items, workers, worker_init, address)``: apply ``call`` to every item (in any order) and
#: yield its results as they arrive; stop all work when the generator is closed or an exception passes
#: through it. ``workers``: at most this many at once (None: the engine's default), never more than the items.
Engine = Callable[[Callable[[Any], Any], Sequence[Any], int | None, Callable[[], None] | None, str | None],
                  Iterator[Any]]


@dataclass(frozen=True)
class Job:
    """One unit of work: ``key`` names it across runs (resume), ``args`` is what the job function gets
    (picklable), ``size`` how many progress units it counts for (e.g. the episodes of a shard)."""

    key: Hashable
    args: Any
    size: int = 1


def run_jobs(
    jobs: Sequence[Job],
    work: Callable[[Any], Any],
    on_result: Callable[[Job, Any], Any],
    done: Iterable[Hashable] = (),
    workers: int | None = None,
    progress: bool = True,
    unit: str = "job",
    engine: str = "local",
    worker_init: Callable[[], None] | None = None,
    address: str | None = None,
) -> int:
    """Run the ``jobs`` whose key is not in ``done``; returns how many ran.

    ``work(job.args)`` runs in a worker (a module-level function: it is pickled); ``on_result(job, result)``
    runs in this process as each job finishes, in completion order; a mapping it returns is shown after the
    progress bar (any other return value is ignored). ``workers``: processes (default: the CPU count; never
    more than the jobs to run); 1 runs the jobs in this process (local engine). ``worker_init()`` (picklable)
    runs once in each worker process, not when the jobs run in this process. ``engine``: one of `ENGINES`;
    ``address``: the Ray cluster of the ``ray`` engine (see `contactnet.jobs.ray_engine`). The progress bar (tqdm
    on stderr: done/total in ``unit``s, rate, ETA; ``progress=False`` hides it) counts every job's ``size``,
    the done ones included.

    Ctrl-C (or any error) stops the running jobs; the results already passed to ``on_result`` stay, and the
    exception is re-raised.
    """
    from tqdm import tqdm

    check_engine(engine, address)
    keys = [job.key for job in jobs]
    if len(set(keys)) != len(keys):
        raise ValueError("run_jobs: job keys must be unique")
    done = set(done)
    todo = [job for job in jobs if job.key not in done]
    n_workers = None if workers is None else max(1, min(workers, len(todo) or 1))
    with tqdm(total=sum(job.size for job in jobs), initial=sum(job.size for job in jobs if job.key in done),
              unit=unit, disable=not progress, dynamic_ncols=True) as bar:
        if not todo:
            return 0
        call = functools.partial(_call_indexed, work)
        items = list(enumerate(job.args for job in todo))
        with contextlib.closing(_ENGINES[engine](call, items, n_workers, worker_init, address)) as results:
            for index, result in results:
                job = todo[index]
                shown = on_result(job, result)
                bar.update(job.size)
                if isinstance(shown, Mapping) and shown:
                    bar.set_postfix(shown)
    return len(todo)


def check_engine(engine: str, address: str | None = None) -> None:
    """Fail now, in one line, when ``engine`` cannot run: an unknown name (ValueError), an ``address``
    without the ``ray`` engine (ValueError), Ray not installed (`contactnet.jobs.ray_engine.EngineUnavailable`)."""
    if engine not in _ENGINES:
        raise ValueError(f"unknown job engine {engine!r}: choose one of {', '.join(_ENGINES)}")
    if address is not None and engine != "ray":
        raise ValueError(f"--address {address}: a cluster address needs --engine ray")
    if engine == "ray":
        from contactnet.jobs.ray_engine import cluster_address, import_ray

        import_ray(local=cluster_address(address) is None)


def _call_indexed(work: Callable[[Any], Any], item: tuple[int, Any]) -> tuple[int, Any]:
    index, args = item
    return index, work(args)


def _worker_start(worker_init: Callable[[], None] | None) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    if worker_init is not None:
        worker_init()


@contextlib.contextmanager
def _sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT while worker processes start (they inherit it: no Ctrl-C traceback from a starting
    worker); only the main thread may touch signal handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _local_engine(call: Callable[[Any], Any], items: Sequence[Any], workers: int | None,
                  worker_init: Callable[[], None] | None, address: str | None = None) -> Iterator[Any]:
    """This machine: one worker runs in this process, more in a ``spawn`` process pool (a clean interpreter
    per worker, safe with PyBullet and threads); default: the CPU count."""
    workers = max(1, min(workers or os.cpu_count() or 1, len(items)))
    if workers == 1:
        for item in items:
            yield call(item)
        return
    import multiprocessing

    with _sigint_ignored():
        pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_worker_start,
                                                         initargs=(worker_init,))
    try:
        yield from pool.imap_unordered(call, items)
        pool.close()
    except BaseException:  # Ctrl-C, an error in a job, or the caller stopped listening (GeneratorExit)
        pool.terminate()
        raise
    finally:
        pool.join()


# ---- resume keys -------------------------------------------------------------------------------
#: Packages whose version can change a simulated or generated result.
RESULT_PACKAGES = ("numpy", "torch", "pybullet", "pin", "example-robot-data", "casadi", "piqp", "numba")
#: Package sources that cannot change a result: the command line, the benchmarks and the paper run (its plan
#: is in the trials' settings; the rest writes reports).
_NOT_RESULT_SOURCES = ("cli/", "__main__.py", "bench/", "jobs/paper/")


def digest(value: Any) -> str:
    """sha256 (hex) of a JSON-able value written canonically (sorted keys, no spaces)."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _without_docstrings(tree: ast.AST) -> ast.AST:
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and body
                and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                and isinstance(body[0].value.value, str)):
            node.body = body[1:] or [ast.Pass()]
    return tree


@functools.cache
def sources_digest() -> str:
    """sha256 of the contactnet package's code, comments, docstrings and layout left out (so that editing
    them does not invalidate results), the command line and benchmarks too (they cannot change a result)."""
    import contactnet

    root = Path(contactnet.__file__).resolve().parent
    total = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        name = path.relative_to(root).as_posix()
        if name.startswith(_NOT_RESULT_SOURCES):
            continue
        try:
            source = path.read_bytes()
        except OSError:  # removed while we list: not part of the code
            continue
        try:
            code = ast.dump(_without_docstrings(ast.parse(source)))
        except (SyntaxError, ValueError):  # half-written by an editor: its bytes then
            code = hashlib.sha256(source).hexdigest()
        total.update(f"{name}\0{code}\0".encode())
    return total.hexdigest()


@functools.cache
def code_identity() -> dict[str, Any]:
    """The code part of a resume key: ``{"contactnet": version, "sources": sources_digest(), "python": ...,
    "packages": {name: version}}``. ``__version__`` alone is not enough: it is not bumped for every change."""
    from importlib import metadata

    import contactnet

    packages = {}
    for name in RESULT_PACKAGES:
        try:
            packages[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            packages[name] = None
    return {"contactnet": contactnet.__version__, "sources": sources_digest(),
            "python": platform.python_version(), "packages": packages}


def differences(old: Any, new: Mapping[str, Any]) -> list[str]:
    """The top-level names whose values differ between two inputs dicts (for one-line messages)."""
    if not isinstance(old, Mapping):
        return sorted(new)
    return sorted(name for name in {*old, *new} if old.get(name) != new.get(name))


def file_sha256(path: str | os.PathLike) -> str:
    total = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(1 << 20):
            total.update(chunk)
    return total.hexdigest()


def check_file(path: str | os.PathLike, size: Any, sha256: Any) -> str | None:
    """None when the file has the recorded ``size`` (checked first) and ``sha256``, else the problem in a
    few words. A value not recorded (None) is not checked."""
    try:
        actual = os.stat(path).st_size
    except FileNotFoundError:
        return "missing"
    except OSError as exc:
        return f"unreadable ({type(exc).__name__})"
    if size is not None and actual != size:
        return f"{actual} bytes where {size} were written ({'truncated' if actual < size else 'changed'})"
    if sha256 is not None:
        try:
            found = file_sha256(path)
        except OSError as exc:
            return f"unreadable ({type(exc).__name__})"
        if found != sha256:
            return f"sha256 {found[:12]}... where {str(sha256)[:12]}... was written (changed)"
    return None


def _ray_engine(call: Callable[[Any], Any], items: Sequence[Any], workers: int | None,
                worker_init: Callable[[], None] | None, address: str | None = None) -> Iterator[Any]:
    """Ray tasks (`contactnet.jobs.ray_engine`, imported only here: the package works without Ray); the workers
    must run this code (`code_identity`), else they refuse."""
    from contactnet.jobs.ray_engine import ray_engine

    return ray_engine(call, items, workers, worker_init, address, identity=code_identity)


_ENGINES: dict[str, Engine] = {"local": _local_engine, "ray": _ray_engine}

ENGINES = tuple(_ENGINES)  #: the engines ``run_jobs`` knows

__all__ = ["ENGINES", "RESULT_PACKAGES", "Job", "check_engine", "check_file", "code_identity", "differences",
           "digest", "file_sha256", "run_jobs", "sources_digest"]
