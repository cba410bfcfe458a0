"""`contactnet experiment paper --out DIR`: the paper's Sec. IV in one resumable run.

Every section of the plan (`contactnet.jobs.paper.plan`) is a `contactnet.jobs.experiment` batch in its own folder of
DIR (``fig5/``, ``table2/``, ``push/``, ...: its ``experiment.json``, ``trials.jsonl``, ``summary.json`` and
``success.png``), opened with `open_batch` (which reuses the logged trials whose fingerprint is unchanged).
The trials of all sections missing so far run in one `run_jobs` call, so one progress bar shows the whole
(trials done / total, ETA, successes so far and trials/s of this run) and the workers stay busy from the
first trial to the last. They run seed by seed (every section's seed 0 first), so an interrupted run has
touched every section. ``DIR/paper.json`` (the folder's header) holds the scale, the sections and one entry
per invocation (command, start, wall and CPU time, trials run, load average, code version, machine); each trial
record names the invocation that ran it (``paper_run``: its index there). The report
(`contactnet.jobs.paper.report`) is written at the end and again by ``contactnet report DIR``.

``contactnet experiment frontier --out DIR`` runs the plan's frontier sections alone (`FRONTIER_SECTIONS`) the same
way, into the same layout (``paper.json`` names the plan: ``"plan": "frontier"``), with a report of that section
only. ``experiment paper`` may later run in the same DIR (the frontier is part of its plan: its trials are reused);
``experiment frontier`` is refused in a DIR of the paper's run (it would hide the paper's sections from the report).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import UTC, datetime
from pathlib import Path

from contactnet.atomic import atomic_write_text
from contactnet.jobs.experiment import (
    ExperimentError,
    Trial,
    _one_torch_thread,
    close_batch,
    log_record,
    open_batch,
    run_trial,
)
from contactnet.jobs.paper.layout import HEADER_FORMAT, HEADER_NAME, read_header
from contactnet.jobs.paper.plan import FRONTIER_SEEDS, PAPER_SECTIONS, Section, frontier_sections, plan_trials
from contactnet.jobs.paper.provenance import code_version, machine
from contactnet.jobs.runner import ENGINES, Job, run_jobs
from contactnet.registry import DEFAULT_ROBOT
from contactnet.sim.engines import engine_version

PLANS = ("paper", "frontier")  # paper: the paper's Sec. IV and the frontier; frontier: the frontier alone


def _cpu_s() -> float:
    """CPU seconds used so far by this process and its finished child processes (the local engine's workers,
    counted once the pool has been joined; a Ray cluster's workers are not children: not counted)."""
    import resource

    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _load_average() -> float | None:
    """The machine's 1-minute load average (other work slows the trials down), None where unknown."""
    try:
        return round(os.getloadavg()[0], 2)
    except (AttributeError, OSError):
        return None


def _order(trial: Trial) -> tuple[int, float]:
    """Seed by seed (push: push time by push time) across all sections."""
    return trial.seed, trial.push_t0_s or 0.0


def run_paper(out_dir: str | Path, scale: float = 1.0, workers: int | None = None, engine: str = "local",
              progress: bool = True, model_dir: str | None = None, address: str | None = None,
              sections: tuple[Section, ...] = PAPER_SECTIONS, command: str = "", report: bool = True,
              sim: str = "pybullet", plan: str = "paper", robot: str = DEFAULT_ROBOT,
              only: tuple[str, ...] | None = None) -> dict:
    """Run (or resume) the ``sections`` at ``scale`` into ``out_dir`` with ``workers`` processes on ``engine``
    (Ray: on the cluster at ``address``, else a local one) and write the report; returns ``{"trials", "ran", "wall_s", "summaries": {folder: summary}}``. On Ctrl-C
    the finished trials stay logged, the run is recorded in paper.json and KeyboardInterrupt is re-raised.
    ``plan`` ("paper" or "frontier") names the plan in paper.json: the report's title and parts follow it.
    ``robot``: every trial's (its scenes at its size, its pushes and payloads the same fraction of its weight:
    `contactnet.jobs.paper.plan.RobotSizing`). ``only``: the folders of the sections to run now (default all);
    paper.json and the report still list every section, with the trials stored so far."""
    if engine not in ENGINES:
        raise ExperimentError(f"unknown engine {engine!r}: choose one of {', '.join(ENGINES)}")
    if plan not in PLANS:
        raise ExperimentError(f"unknown plan {plan!r}: choose one of {', '.join(PLANS)}")
    out = Path(out_dir)
    header = read_header(out) or {"format": HEADER_FORMAT, "runs": []}
    if header.get("sim", "pybullet") != sim and header["runs"]:
        raise ExperimentError(f"{out} holds a run in {header.get('sim', 'pybullet')}: give the {sim} run another --out")
    if header.get("robot", DEFAULT_ROBOT) != robot and header["runs"]:
        raise ExperimentError(f"{out} holds a run of {header.get('robot', DEFAULT_ROBOT)}: give the {robot} run "
                              "another --out")
    if plan == "frontier" and header.get("plan", "paper") == "paper" and header["runs"]:
        raise ExperimentError(f"{out} holds the paper's run (the frontier is one of its sections: experiment paper "
                              "runs it there); give experiment frontier another --out")
    unknown = sorted(set(only or ()) - {s.folder for s in sections})
    if unknown:
        raise ExperimentError(f"experiment {plan} has no section {unknown[0]!r}: choose from "
                              f"{', '.join(s.folder for s in sections)}")
    try:
        planned = plan_trials(sections, scale, model_dir, sim, robot)
    except ValueError as exc:
        raise ExperimentError(str(exc)) from None
    batches = {s.folder: open_batch(s.experiment, out / s.folder, planned[s.folder]) for s in sections
               if only is None or s.folder in only}
    header.update(plan=plan, scale=scale, model_dir=model_dir, sim=sim, sim_version=engine_version(sim), robot=robot,
                  sections=[{"folder": s.folder, "experiment": s.experiment, "title": s.title,
                             "trials": len(planned[s.folder]), "trials_full": len(s.trials(1.0, model_dir, sim, robot))}
                            for s in sections])
    atomic_write_text(out / HEADER_NAME, json.dumps(header, indent=1))

    jobs = sorted((Job((folder, t.key), t) for folder, batch in batches.items() for t in batch.trials),
                  key=lambda job: _order(job.args))
    done = {(folder, key) for folder, batch in batches.items() for key in batch.done}
    tally = {"ok": sum(bool(r["success"]) for b in batches.values() for r in b.done.values()),
             "finished": len(done), "ran": 0}
    started = datetime.now(UTC).isoformat(timespec="seconds")
    load_before = _load_average()
    code, computer = code_version(), machine()  # now: the checkout may change while the trials run
    run_index = len(header["runs"])
    cpu0, t0 = _cpu_s(), time.perf_counter()

    def on_result(job: Job, record: dict) -> dict:
        record = log_record(batches[job.key[0]], {**record, "paper_run": run_index})
        tally["ok"] += bool(record["success"])
        tally["finished"] += 1
        tally["ran"] += 1
        rate = tally["ran"] / max(time.perf_counter() - t0, 1e-9)
        return {"ok": f"{tally['ok']}/{tally['finished']}", "rate": f"{rate:.3f} trials/s"}

    interrupted = True
    try:
        run_jobs(jobs, run_trial, on_result, done=done, workers=workers, progress=progress, unit="trial",
                 engine=engine, worker_init=_one_torch_thread, address=address)
        interrupted = False
    finally:  # also after Ctrl-C: the report counts this run's wall time and trials
        wall_s = time.perf_counter() - t0
        cpu_s = _cpu_s() - cpu0
        header["runs"].append({
            "command": command, "started_utc": started, "wall_s": wall_s, "cpu_s": cpu_s, "trials_run": tally["ran"],
            "trials_reused": len(done), "trials_planned": len(jobs), "scale": scale,
            "workers": workers or os.cpu_count(), "engine": engine, "interrupted": interrupted,
            **({"sections": list(only)} if only is not None else {}),
            "load_average": {"start": load_before, "end": _load_average()},
            "code": code, "machine": computer})
        atomic_write_text(out / HEADER_NAME, json.dumps(header, indent=1))
    summaries = {folder: close_batch(batch, wall_s) for folder, batch in batches.items()}
    if report:
        from contactnet.jobs.paper.report import write_report

        write_report(out)
    return {"trials": len(jobs), "ran": tally["ran"], "wall_s": wall_s, "summaries": summaries}


# ---- the command line's part (contactnet.cli calls these) --------------------------------------
#: experiment options that the paper's plan fixes, with their defaults
_FIXED_BY_THE_PLAN = {"trials": None, "gaits": None, "planners": None, "removed": None, "height": None,
                      "force": None, "impulse": None, "push_seed": 0, "noise": 0.0, "widths_cm": None,
                      "gaps_cm": None, "mass_scale": 1.0, "payload": None, "friction": None,
                      "torque_scale": 1.0, "orientation_noise": 0.0, "velocity_noise": 0.0, "gyro_noise": 0.0,
                      "delay_ms": 0.0, "observer": True, "retarget": False, "crouch": None, "foot_hold": True,
                      "terrain_scale": None, "vx": 0.05}  # the plan runs the defaults (any --sim)
#: ... and those the frontier's plan lets one choose (its own defaults otherwise)
_FRONTIER_OPTIONS = ("trials", "gaits", "planners", "removed", "widths_cm", "gaps_cm")


def _command(args: argparse.Namespace, scale: float, plan: str = "paper") -> str:
    words = ["contactnet", "experiment", plan, "--out", str(args.out)]
    if plan == "frontier" and getattr(args, "trials", None) is not None:
        words += ["--trials", str(args.trials)]
    else:
        words += ["--scale", f"{scale:g}"]
    defaults = {"engine": "local", "sim": "pybullet", "robot": DEFAULT_ROBOT}  # not written when they are these
    for option in (*(_FRONTIER_OPTIONS[1:] if plan == "frontier" else ()), "sections", "workers", "engine",
                   "address", "model_dir", "sim", "robot"):
        value = getattr(args, option, None)
        if isinstance(value, tuple | list):
            value = ",".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
        if value is not None and value != defaults.get(option):
            words += [f"--{option.replace('_', '-')}", str(value)]
    return " ".join(words)


def paper_command(args: argparse.Namespace, plan: str = "paper") -> int:
    """``contactnet experiment paper --out DIR [--scale S] [--sections F,...] [--workers N] [--model-dir D]
    [--report-only]``; with
    ``plan="frontier"``, ``contactnet experiment frontier --out DIR [--scale S | --trials N] [--gaits G]
    [--planners P] [--removed N,...] [--widths-cm W,...] [--gaps-cm G,...]`` (``--trials N``: N seeds per point of
    the field, the other cells in proportion: scale N / 100)."""
    free = _FRONTIER_OPTIONS if plan == "frontier" else ()
    bad = [name for name, default in _FIXED_BY_THE_PLAN.items()
           if name not in free and getattr(args, name, default) != default]
    if bad:
        option = bad[0].replace("_", "-")
        option = f"no-{option}" if _FIXED_BY_THE_PLAN[bad[0]] is True else option  # a switch that is on by default
        raise ExperimentError(f"experiment {plan} runs {'the paper' if plan == 'paper' else 'its plan'}'s own "
                              f"settings: drop --{option}")
    out = Path(args.out)
    if args.report_only:
        return report_command(out)
    if args.model_dir is not None and not Path(args.model_dir).is_dir():
        raise ExperimentError(f"--model-dir {args.model_dir}: not a directory")
    sections = PAPER_SECTIONS
    scale = 1.0 if args.scale is None else args.scale
    if plan == "frontier":
        trials = getattr(args, "trials", None)
        if trials is not None and args.scale is not None:
            raise ExperimentError("experiment frontier: give --scale or --trials, not both")
        scale = scale if trials is None else trials / FRONTIER_SEEDS
        sections = frontier_sections(args.gaits, args.planners, args.removed, args.widths_cm, args.gaps_cm)
    engine = getattr(args, "engine", None) or "local"
    try:
        result = run_paper(out, scale, workers=args.workers, engine=engine, progress=not args.quiet,
                           model_dir=args.model_dir, command=_command(args, scale, plan), sections=sections,
                           address=getattr(args, "address", None), sim=getattr(args, "sim", None) or "pybullet",
                           plan=plan, robot=getattr(args, "robot", None) or DEFAULT_ROBOT,
                           only=getattr(args, "sections", None))
    except KeyboardInterrupt:
        print(f"contactnet: interrupted; finished trials are kept in {out}: run the same command to resume "
              f"(contactnet report {out} writes the report of the trials so far)", file=sys.stderr)
        return 130
    for folder, summary in result["summaries"].items():
        rows = summary["rows"]
        print(f"{folder:16s} {sum(r['successes'] for r in rows):5d} / {sum(r['trials'] for r in rows):5d} successes")
    rate = result["ran"] / max(result["wall_s"], 1e-9)
    print(f"{result['ran']} trials run of {result['trials']} in {result['wall_s'] / 60:.1f} min ({rate:.3f} trials/s); "
          f"wrote {out / 'report.md'} and {out / 'report.html'}")
    return 0


def report_command(out: Path) -> int:
    """``contactnet report DIR``: the report of the trials stored in DIR, nothing run."""
    from contactnet.jobs.paper.report import write_report

    md, html = write_report(out)
    print(f"wrote {md} and {html}")
    return 0
