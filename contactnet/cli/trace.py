"""The options ``--trace``, ``--trace-plot``, ``--trace-from`` and ``--trace-every-ms`` of ``simulate`` and ``replay``: a
run's trace (``contactnet.jobs.trace``) checked before the run and written after it."""

from __future__ import annotations

import argparse
import sys

from contactnet.cli.types import UserError, bounded_float, bounded_int


def add_trace_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--trace", metavar="FILE.csv", help="write the run's trace: the body against its plan and "
                        "each foot's planned, commanded and measured force (contactnet.jobs.trace)")
    parser.add_argument("--trace-plot", metavar="FILE.png", help="draw the trace (.png, .svg or .pdf)")
    parser.add_argument("--trace-from", type=bounded_float("--trace-from", 0.0, 3600.0), default=0.0, metavar="S",
                        help="trace from this simulated time on (s; default 0)")
    parser.add_argument("--trace-every-ms", type=bounded_int("--trace-every-ms", 1, 1000), default=10, metavar="MS",
                        help="one sample every this many ms of simulated time (default 10)")


def trace_of(args: argparse.Namespace):  # noqa: ANN202 - a LoopTrace or None
    """The trace the options ask for (None without --trace or --trace-plot); its files checked now."""
    if not (args.trace or args.trace_plot):
        return None
    from contactnet.jobs.trace import PLOT_SUFFIXES, LoopTrace, TraceConfig, TraceError, check_output

    try:
        if args.trace:
            check_output(args.trace, (".csv",))
        if args.trace_plot:
            check_output(args.trace_plot, PLOT_SUFFIXES)
        return LoopTrace(TraceConfig(every_ms=args.trace_every_ms, from_s=args.trace_from))
    except TraceError as exc:
        raise UserError(str(exc)) from None


def write_trace(trace, args: argparse.Namespace, title: str) -> None:  # noqa: ANN001 - a LoopTrace
    """The trace's files, and a line on stderr saying where."""
    from contactnet.jobs.trace import TraceError

    if not trace.rows:  # e.g. the run ended before --trace-from: no files rather than empty ones
        print(f"trace: no samples (nothing ran from {trace.config.from_s:g} s on); no file written", file=sys.stderr)
        return
    try:
        written = [str(trace.write_csv(args.trace))] if args.trace else []
        if args.trace_plot:
            written.append(str(trace.plot(args.trace_plot, title)))
    except TraceError as exc:
        raise UserError(str(exc)) from None
    print(f"trace: {', '.join(written)} ({len(trace.rows)} samples)", file=sys.stderr)


__all__ = ["add_trace_arguments", "trace_of", "write_trace"]
