"""Ctrl-C around C extensions that call back into Python and swallow what it raises.

Python runs its SIGINT handler (which raises KeyboardInterrupt) in the main thread at the next bytecode it
executes, wherever that is. When that bytecode belongs to a Python callback of a C extension, the extension
may treat the exception as a failed attempt and clear it: casadi's SWIG wrappers try each overload of a call
and call ``DM_from_array`` to test an argument, pybind11's type casters (piqp) convert scipy matrices, numba
boxes arrays through a Python helper. The interrupt is then lost: a Ctrl-C'd ``contactnet datagen`` once went
on to finish every episode (the signal landed in ``srbd_problem`` while casadi stated the MPC's QP).

`sigint_deferred` wraps such calls: a SIGINT that arrives inside is recorded, not raised, and the handler that
was installed (Python's, which raises KeyboardInterrupt, or a caller's own) runs as soon as the block ends, in
this module's Python code where nothing can swallow it. The calls it wraps take milliseconds, so the Ctrl-C
comes that much later; outside the main thread, or with no Python SIGINT handler installed (ignored, the
system default), it does nothing.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType


@contextlib.contextmanager
def sigint_deferred() -> Iterator[None]:
    """Run the block with SIGINT recorded instead of handled; the installed handler runs when it ends (also
    when the block raises: a Ctrl-C then wins, the block's exception as its context)."""
    if threading.current_thread() is not threading.main_thread():  # only the main thread handles signals
        yield
        return
    previous = signal.getsignal(signal.SIGINT)
    if not callable(previous):  # SIG_IGN, SIG_DFL or a handler installed outside Python: nothing to defer
        yield
        return
    received: list[FrameType | None] = []
    signal.signal(signal.SIGINT, lambda _signum, frame: received.append(frame))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if received:
            previous(signal.SIGINT, received[0])


__all__ = ["sigint_deferred"]
