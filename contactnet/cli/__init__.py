"""`contactnet ...`: the command line. Every subcommand of the design is here; user mistakes end in
one line on stderr and exit code 2, never a traceback. ``types``: the argument types that check an option's value."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path

from app.live.settings import SESSION_ENGINES, VELOCITY_LIMIT_M_S
from contactnet import registry
from contactnet.cli.mismatch import add_mismatch_arguments, mismatch_of
from contactnet.cli.robot import add_robot_parser
from contactnet.cli.terrain import add_terrain_parser
from contactnet.cli.trace import add_trace_arguments, trace_of, write_trace
from contactnet.cli.types import (
    HEIGHT_HELP,
    ROBOT_METAVAR,
    SCALE_HELP,
    SIM_HELP,
    UserError,
    bounded_float,
    bounded_int,
    choices,
    number_list,
    positive_int,
    robot_argument,
    sim_of,
)
from contactnet.sim.world import ENGINES as SIM_ENGINES

EXIT_USER_ERROR = 2


USER_ERROR_CLASSES = (
    ("contactnet.terrain", "TerrainError"),
    ("contactnet.robots.description", "RobotDataError"),
    ("contactnet.jobs.datagen", "DatasetDirError"),
    ("contactnet.jobs.train", "DatasetError"),
    ("contactnet.planning.network", "ModelFileError"),
    ("contactnet.jobs.experiment", "ExperimentError"),
    ("contactnet.jobs.ray_engine", "EngineUnavailable"),
    ("contactnet.extras", "MissingExtra"),
    ("contactnet.sim.engines", "EngineMissing"),
)


def _user_errors() -> tuple[type[BaseException], ...]:
    """The exception classes that mean a user mistake. Only modules already imported can have raised
    one, so this imports nothing (printing an error must not import e.g. the training modules, which pull in torch)."""
    found = [getattr(sys.modules[module], name) for module, name in USER_ERROR_CLASSES if module in sys.modules]
    return (UserError, *found)


# ---- subcommands -------------------------------------------------------------------------------
def _sims_of(args: argparse.Namespace) -> tuple[str, ...]:
    """``experiment --sim``: the engines to run every trial in (default: the default engine, as `sim_of`), each
    installed (else one line now, not one per trial in the workers)."""
    from contactnet.sim.world import default_engine, engine_installed

    if args.sim is None:
        sim_of(args)
    sims = (args.sim,) if isinstance(args.sim, str) else tuple(dict.fromkeys(args.sim))
    missing = [sim for sim in sims if not engine_installed(sim)]
    if missing:
        raise UserError(f"--sim {','.join(missing)}: not installed here (the installed default is {default_engine()})")
    return sims


def session_counts(text: str) -> str:
    """``--sessions``: comma-separated counts in 1..16."""
    parts = text.split(",")
    if not all(p.strip().isdigit() and 1 <= int(p) <= 16 for p in parts):
        raise argparse.ArgumentTypeError(f"expected comma-separated session counts in 1..16, got {text!r}")
    return ",".join(str(int(p)) for p in parts)


def cmd_bench(args: argparse.Namespace) -> int:
    from contactnet.bench import format_table, run, takes_runs

    if args.sessions is not None and args.what != "live":
        raise UserError("--sessions is an option of bench live")
    if args.runs is not None and not takes_runs(args.what):
        raise UserError("--runs is an option of bench sim")
    if args.what == "live":  # the web tool's benchmarks live with the web tool
        from app.bench.live import bench_live, bench_sessions

        rows = bench_sessions(args.sessions) if args.sessions is not None else bench_live()
    elif args.what == "upload":
        from app.bench.upload import bench_upload

        rows = bench_upload()
    else:
        rows = run(args.what, robot_name=args.robot, runs=args.runs)
    if args.json:
        print(json.dumps({"benchmark": args.what, "rows": rows}, indent=2))
    else:
        print(format_table(rows))
    return 0


def make_planner(name: str, gait, robot, model: str | Path | None = None):  # noqa: ANN001
    """``registry.make_planner`` with its mistakes (unknown name) as one-line user errors."""
    try:
        return registry.make_planner(name, gait, robot, model=model)
    except ValueError as exc:
        if type(exc) is ValueError:  # not a ModelFileError or TerrainError (subclasses print as they are)
            raise UserError(str(exc)) from None
        raise


def cmd_simulate(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from contactnet.locomotion import Locomotion, LocomotionConfig
    from contactnet.motion.foot_hold import FootHoldConfig
    from contactnet.planning.observer import DEFAULT_OBSERVER
    from contactnet.planning.retarget import RetargetConfig
    from contactnet.sim.world import Push, SimConfig

    try:
        pushes = [Push.parse(text) for text in args.push]
    except ValueError as exc:
        raise UserError(str(exc)) from None
    robot = registry.load_robot(args.robot)
    if args.crouch is not None:
        _check_crouch(args.crouch, robot)
    terrain = registry.terrain_for(args.terrain, robot, removed=args.removed, seed=args.seed, height_m=args.height,
                                   scale=args.terrain_scale)
    robot = robot.for_terrain(terrain, args.gait)  # its stance for this terrain and gait (Robot.for_terrain)
    gait = registry.gait_for(args.gait, robot)  # sized to the robot (contactnet.motion.gait.SIZE_RULE)
    planner = make_planner(args.planner, gait, robot, model=args.model)
    sim_config = SimConfig(joint_vel_noise_var=args.noise, seed=args.seed, mismatch=mismatch_of(args),
                           engine=sim_of(args))
    trace = trace_of(args)  # a bad trace file fails now, before the simulation
    if trace is not None and args.record:
        raise UserError("--trace / --trace-plot and --record: one at a time (each drives the loop its own way)")
    with contextlib.ExitStack() as stack:
        recording = None
        if args.record:  # the scene over time, as the web tool draws it (app/recordings/recorder.py)
            from app.recordings.recorder import FileRecording, RecordingPathError

            try:  # checks the path now: a bad one fails before the simulation, not after it
                recording = stack.enter_context(FileRecording(args.record))
            except RecordingPathError as exc:
                raise UserError(str(exc)) from None
        loop_config = LocomotionConfig(observer=DEFAULT_OBSERVER if args.observer else None,
                                       retarget=RetargetConfig() if args.retarget else None, crouch_m=args.crouch,
                                       foot_hold=FootHoldConfig() if args.foot_hold else None)
        loco = stack.enter_context(Locomotion(robot, terrain, gait, planner, sim_config, config=loop_config,
                                              vel_cmd_xy=(args.vx, args.vy)))
        for push in pushes:
            loco.push(push)
        chunk_s = recording.period_s if recording else 0.32
        if recording:
            recording.add(loco)
        if trace is not None:
            try:
                trace.run(loco, args.duration)
            finally:  # interrupted too: the samples so far are written
                write_trace(trace, args, f"simulate {args.robot} {args.gait} {args.planner} on {args.terrain}")
        else:
            with tqdm(total=round(args.duration, 2), unit="sim s", file=sys.stderr, disable=None, leave=False) as bar:
                while loco.t_s < args.duration - 1e-9 and not loco.done:
                    before = loco.t_s
                    loco.run_for(min(chunk_s, args.duration - loco.t_s))
                    if recording:
                        recording.add(loco)
                    bar.update(round(loco.t_s - before, 3))
        result = loco.summary()
        if recording:
            where = recording.save()
            note = " (stopped recording at its limit)" if recording.full else ""
            print(f"recording: {where} ({recording.size_bytes / 1e6:.2f} MB, {recording.frames} frames, "
                  f"{recording.duration_s:.1f} s{note})", file=sys.stderr if args.json else sys.stdout)
    if args.json:
        print(json.dumps(result))
    else:
        outcome = "SUCCESS" if result["success"] else ("FELL: " + str(result["fall_reason"]) if result["fell"] else "did not reach the goal")
        print(
            f"{outcome}; x = {result['reached_x']:.3f} m after {result['sim_time_s']:.2f} s simulated "
            f"({result['sim_time_s'] / max(result['wall_time_s'], 1e-9):.1f}x real time), {result['steps']} steps; "
            f"planner {result['planner_ms']['median']:.3f} ms, optimizer {result['trajopt_ms']['median']:.2f} ms (medians)"
        )
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    from app.api.server import serve
    from app.live.settings import settings_from_args
    from contactnet.terrain import resolve

    resolve(args.terrain)  # a bad terrain is a one-line user error before anything starts
    sim_of(args)
    if args.engine is not None or args.address is not None:
        args.engine = args.engine or "local"
        _check_engine(args)  # e.g. --engine ray without Ray installed: one line, before anything starts
    try:
        settings = settings_from_args(args)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    return serve(settings)


def _check_engine(args: argparse.Namespace) -> None:
    """``--engine`` / ``--address`` fail now, in one line (e.g. Ray not installed), before any work."""
    from contactnet.jobs.runner import check_engine

    try:
        check_engine(args.engine, args.address)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def cmd_datagen(args: argparse.Namespace) -> int:
    from contactnet.jobs.datagen import DatagenConfig, generate

    _check_engine(args)
    config = DatagenConfig(gait=args.gait, robot=args.robot, episodes=args.episodes, seed=args.seed,
                           episodes_per_shard=args.episodes_per_shard,
                           instances_per_episode=args.instances_per_episode, sim=sim_of(args))
    try:
        manifest = generate(args.out, config, workers=args.workers, progress=not args.quiet,
                            engine=args.engine, address=args.address)
    except KeyboardInterrupt:
        print(f"contactnet: interrupted; finished shards are kept in {args.out}: run the same command to resume",
              file=sys.stderr)
        return 130
    rate = manifest["instances"] / max(manifest["wall_time_s"], 1e-9)
    print(
        f"{args.out}: {manifest['episodes']} episodes, {manifest['instances']} instances "
        f"({manifest['falls']} episodes ended in a fall), {manifest['wall_time_s'] / 60:.1f} min, "
        f"{rate:.2f} instances/s"
    )
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    from contactnet.jobs.train import train_command

    return train_command(
        args.gait, args.data, args.out, robot=args.robot, epochs=args.epochs, batch_size=args.batch_size, lr=args.lr,
        seed=args.seed, split=args.split, threads=args.threads, max_minutes=args.max_minutes,
        save_partial=args.save_partial, progress=not args.quiet, mirror=args.mirror,
    )


def _section_names(text: str) -> tuple[str, ...]:
    """``--sections``: comma-separated folders of the paper's plan (imported only when the option is given)."""
    from contactnet.jobs.paper.plan import PAPER_SECTIONS

    return choices("--sections", tuple(s.folder for s in PAPER_SECTIONS))(text)


def _check_crouch(crouch_m: float, robot) -> None:  # noqa: ANN001 - a contactnet.robots Robot
    """--crouch against the robot's deepest (``RobotDescription.check_crouch``), as a one-line error."""
    try:
        robot.description.check_crouch(crouch_m)
    except ValueError as exc:
        raise UserError(f"--crouch: {exc}") from None


def cmd_experiment(args: argparse.Namespace) -> int:
    from contactnet.jobs.experiment import DEFAULT_HEIGHT_M, run_experiment, trials_of
    from contactnet.jobs.summary import format_summary

    _check_engine(args)
    sims = _sims_of(args)
    if args.name in ("paper", "frontier"):
        from contactnet.jobs.paper.run import paper_command

        if len(sims) > 1:
            raise UserError(f"experiment {args.name} runs in one engine: give each --sim its own --out")
        args.sim = sims[0]
        return paper_command(args, args.name)
    if args.scale is not None or args.report_only or args.sections is not None:
        raise UserError("--scale, --sections and --report-only are options of experiment paper and frontier")
    model_dir = args.model_dir
    if model_dir is not None and not Path(model_dir).is_dir():
        raise UserError(f"--model-dir {model_dir}: not a directory")
    mismatch = mismatch_of(args)
    try:
        trials = trials_of(args.name, args.trials, args.gaits, args.planners, args.removed or (80,), args.noise,
                           model_dir=model_dir, widths_cm=args.widths_cm, gaps_cm=args.gaps_cm, robot=args.robot,
                           height_m=DEFAULT_HEIGHT_M if args.height is None else args.height,
                           forces_n=() if args.force is None and args.impulse else (args.force or (5.0,)),
                           impulses_ns=args.impulse or (), push_seed=args.push_seed, observer=args.observer,
                           retarget=args.retarget, mismatch=None if args.name == "robustness" and mismatch.neutral else mismatch,
                           sims=sims, scale=args.terrain_scale, vx=args.vx, crouch_m=args.crouch, foot_hold=args.foot_hold)
    except ValueError as exc:
        if type(exc) is ValueError:
            raise UserError(str(exc)) from None
        raise
    if args.crouch is not None:  # a crouch too deep for the robot fails now, not in a worker
        _check_crouch(args.crouch, registry.load_robot(args.robot))
    if any(registry.planner_entry(t.planner).needs_model for t in trials):  # a bad model fails now, not in a worker
        robot = registry.load_robot(args.robot)
        for gait in {t.gait for t in trials}:
            model = None if model_dir is None else registry.model_path(args.robot, gait, Path(model_dir))
            make_planner("contactnet", registry.gait_for(gait, robot), robot, model=model)
    try:
        summary = run_experiment(args.name, args.out, trials, workers=args.workers, progress=not args.quiet,
                                 engine=args.engine, address=args.address)
    except KeyboardInterrupt:
        print(f"contactnet: interrupted; finished trials are kept in {args.out}: run the same command to resume",
              file=sys.stderr)
        return 130
    print(format_summary(summary))
    print(f"wrote {Path(args.out) / 'summary.json'} and {Path(args.out) / 'success.png'}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from contactnet.jobs.paper.run import report_command

    return report_command(Path(args.dir))


def cmd_replay(args: argparse.Namespace) -> int:
    from contactnet.jobs.outcome import outcome
    from contactnet.jobs.replay import replay

    trace = trace_of(args)
    try:
        stored, now = replay(args.dir, args.key, trace=trace)
    finally:  # interrupted too: the samples so far are written
        if trace is not None:
            write_trace(trace, args, f"replay {args.key}")
    if args.json:
        print(json.dumps({"key": args.key, "stored": stored, "now": now}, indent=1, default=str))
    else:
        print(f"{args.key}\n  stored: {outcome(stored)} (x {stored['reached_x']:.2f} m)\n"
              f"  now:    {outcome(now)} (x {now['reached_x']:.2f} m)")
    return 0


# ---- parser ------------------------------------------------------------------------------------
OBSERVER_HELP = ("estimate a push from the body's momentum, cancel it and lean the capture step into it "
                 "(contactnet.planning.observer; on by default, --no-observer turns it off)")
RETARGET_HELP = ("rank a swinging leg's landing again when the measured velocity leaves the command "
                 "(contactnet.planning.retarget; off by default)")
FOOT_HOLD_HELP = "hold a lost stance foot that slid toward its top's edge where it stood (contactnet.motion.foot_hold)"
CROUCH_HELP = ("walk with the CoM this much below the robot's nominal height, all the time (metres, at most a "
               "third of it): a push moves the balancing centre of pressure less; 0: the nominal height; default: "
               "the robot's walk_crouch_m or trot_crouch_m for that gait on terrain of one level, else 0")


def _engine_arguments(parser: argparse.ArgumentParser) -> None:
    from contactnet.jobs.runner import ENGINES

    parser.add_argument("--engine", choices=ENGINES, default="local",
                        help="local: a process pool on this machine (default); ray: Ray tasks (pip install "
                             "contactnet[ray]) on --address, else $RAY_ADDRESS, else a local Ray of --workers "
                             "CPUs")
    parser.add_argument("--address", metavar="A",
                        help="an existing Ray cluster (host:port, auto, ray://host:port)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="contactnet",
        description="ContactNet: acyclic contact planning for quadrupeds (Solo12, Go2), simulated in PyBullet.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    serve = sub.add_parser("serve", help="start the web tool (FastAPI + viser)")
    serve.add_argument("--host", default="127.0.0.1")
    serve.add_argument("--port", type=bounded_int("--port", 1, 65535), default=8000, help="web page and REST API")
    serve.add_argument("--viser-port", type=bounded_int("--viser-port", 1, 65535), default=8080,
                       help="3D view (viser takes the next free port if busy)")
    serve.add_argument("--terrain", default="stepping_stones", help="terrain name or JSON path")
    serve.add_argument("--robot", type=robot_argument, metavar=ROBOT_METAVAR, default=registry.DEFAULT_ROBOT)
    serve.add_argument("--gait", choices=registry.gait_names(), default="walk")
    serve.add_argument("--sim", choices=SIM_ENGINES, help=SIM_HELP)
    serve.add_argument("--planner", choices=registry.planner_names(), default="contactnet",
                       help="falls back to heuristic when the planner's model is missing")
    serve.add_argument("--vx", type=bounded_float("--vx", -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S), default=0.05,
                       help="m/s")
    serve.add_argument("--recordings", metavar="DIR",
                       help="folder of scene recordings (default: $CONTACTNET_DATA/recordings, else "
                            "~/.local/share/contactnet/recordings)")
    serve.add_argument("--allow-host", action="append", metavar="NAME",
                       help="another name the tool answers to (besides 127.0.0.1, localhost, ::1, --host); repeatable")
    serve.add_argument("--no-wait", dest="wait", action="store_false", default=None,
                       help="start walking at once (default: wait until a browser opens the 3D view or a "
                            "client sends POST /api/pause {\"paused\": false})")
    serve.add_argument("--no-loop", dest="loop", action="store_false", default=None,
                       help="stay at the end of a run (default: the next run starts a few seconds after the "
                            "goal or a fall)")
    serve.add_argument("--max-sessions", type=bounded_int("--max-sessions", 1, 64), default=None, metavar="N",
                       help="a robot per visitor: at most N live sessions at once (default: as many as one process "
                            "runs in real time, see docs/web-tool.md)")
    serve.add_argument("--session-idle", type=bounded_float("--session-idle", 1.0, 86400.0), default=None,
                       metavar="S", help="reclaim a visitor's session S seconds after its page closed (default 120)")
    serve.add_argument("--shared", action="store_true", default=None,
                       help="one robot for everyone: every visitor drives the default session")
    serve.add_argument("--engine", choices=SESSION_ENGINES, default=None,
                       help="where visitors' simulations run: local, threads of the server (default); ray, a Ray "
                            "actor per session (pip install contactnet[ray]) on --address, else $RAY_ADDRESS, else a "
                            "local Ray of this machine's CPUs; the server only streams their snapshots")
    serve.add_argument("--address", metavar="A",
                       help="--engine ray: an existing Ray cluster (host:port, auto, ray://host:port)")
    serve.set_defaults(func=cmd_serve)

    sim = sub.add_parser("simulate", help="run one simulation headless")
    sim.add_argument("--terrain", required=True, help="terrain name or JSON path ('random' with --removed)")
    sim.add_argument("--removed", type=int, default=None, help="squares removed from the random field")
    sim.add_argument("--height", type=bounded_float("--height", 0.0, 0.5), default=None, metavar="H",
                     help=HEIGHT_HELP)
    sim.add_argument("--seed", type=int, default=0)
    sim.add_argument("--terrain-scale", type=bounded_float("--terrain-scale", 0.1, 10.0), default=None, metavar="S",
                     help=SCALE_HELP)
    sim.add_argument("--gait", choices=registry.gait_names(), required=True)
    sim.add_argument("--planner", choices=registry.planner_names(), required=True)
    sim.add_argument("--robot", type=robot_argument, metavar=ROBOT_METAVAR, default=registry.DEFAULT_ROBOT)
    sim.add_argument("--model", metavar="FILE.pt", help="model of contactnet/fixed (default: the shipped one)")
    sim.add_argument("--vx", type=bounded_float("--vx", -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S), default=0.05,
                     help="m/s")
    sim.add_argument("--vy", type=bounded_float("--vy", -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S), default=0.0,
                     help="m/s")
    sim.add_argument("--duration", type=bounded_float("--duration", 0.1, 3600), default=60.0, help="s")
    sim.add_argument("--noise", type=bounded_float("--noise", 0.0, 1.0), default=0.0,
                     help="variance of joint-velocity noise, (rad/s)^2")
    sim.add_argument("--push", action="append", default=[], metavar="T0,DURATION,FX,FY")
    sim.add_argument("--observer", action=argparse.BooleanOptionalAction, default=True, help=OBSERVER_HELP)
    sim.add_argument("--retarget", action="store_true", help=RETARGET_HELP)
    sim.add_argument("--foot-hold", action=argparse.BooleanOptionalAction, default=True, help=FOOT_HOLD_HELP)
    sim.add_argument("--crouch", type=bounded_float("--crouch", 0.0, 1.0), default=None, metavar="M", help=CROUCH_HELP)
    add_mismatch_arguments(sim)
    sim.add_argument("--sim", choices=SIM_ENGINES, help=SIM_HELP)
    sim.add_argument("--record", metavar="FILE.viser")
    add_trace_arguments(sim)
    sim.add_argument("--json", action="store_true")
    sim.set_defaults(func=cmd_simulate)

    datagen = sub.add_parser("datagen", help="generate a training dataset")
    datagen.add_argument("--gait", choices=registry.gait_names(), required=True)
    datagen.add_argument("--robot", type=robot_argument, metavar=ROBOT_METAVAR, default=registry.DEFAULT_ROBOT)
    datagen.add_argument("--episodes", type=positive_int("--episodes", 10**6), default=1500)
    datagen.add_argument("--out", required=True)
    datagen.add_argument("--workers", type=positive_int("--workers", 256))
    datagen.add_argument("--seed", type=int, default=0)
    datagen.add_argument("--sim", choices=SIM_ENGINES, help=SIM_HELP)
    datagen.add_argument("--episodes-per-shard", type=positive_int("--episodes-per-shard", 1000), default=5)
    datagen.add_argument("--instances-per-episode", type=positive_int("--instances-per-episode", 1000), default=30,
                         help="the paper's 30; fewer for quick trials")
    datagen.add_argument("--quiet", action="store_true", help="no progress bar")
    _engine_arguments(datagen)
    datagen.set_defaults(func=cmd_datagen)

    train = sub.add_parser("train", help="train a ContactNet model")
    train.add_argument("--gait", choices=registry.gait_names(), required=True)
    train.add_argument("--robot", type=robot_argument, metavar=ROBOT_METAVAR, default=None,
                       help="the robot the dataset must have been made with (default: the dataset's)")
    train.add_argument("--data", required=True)
    train.add_argument("--out", required=True)
    train.add_argument("--epochs", type=positive_int("--epochs", 10**6), default=1000)
    train.add_argument("--batch-size", type=positive_int("--batch-size", 10**5), default=100)
    train.add_argument("--lr", type=bounded_float("--lr", 1e-7, 1.0), default=1e-3)
    train.add_argument("--seed", type=int, default=0)
    train.add_argument("--split", choices=["episode", "instance"], default="episode",
                       help="70/30 split by whole episodes (default) or by instances (the paper's)")
    train.add_argument("--mirror", action="store_true",
                       help="train on every training instance and its left-right mirror image (twice the data; "
                            "the test split stays as generated)")
    train.add_argument("--threads", type=positive_int("--threads", 256), default=1)
    train.add_argument("--max-minutes", type=bounded_float("--max-minutes", 0.01, 10**5), default=None)
    train.add_argument("--save-partial", action="store_true", help="on Ctrl-C, save the model trained so far")
    train.add_argument("--quiet", action="store_true", help="no progress bar")
    train.set_defaults(func=cmd_train)

    experiment = sub.add_parser("experiment", help="run one of the paper's experiments")
    experiment.add_argument("name", choices=["stepping_stones", "narrow_stones", "narrow_map", "random", "stairs",
                                             "raised_stones", "random_heights", "push", "robustness", "stone_grid",
                                             "ramps", "paper", "frontier"],
                            help="paper: the paper's whole Sec. IV (every experiment, its numbers of trials) and "
                                 "the frontier, and a report in DIR; frontier: beyond the paper, the random field "
                                 "at n = 110..200 and narrow_map down to 2 cm bars and up to 30 cm gaps, and its "
                                 "report in DIR")
    experiment.add_argument("--scale", type=bounded_float("--scale", 1e-6, 1.0), default=None,
                            help="paper, frontier: run this share of every batch (at least 1 trial per cell; "
                                 "default 1)")
    experiment.add_argument("--report-only", action="store_true",
                            help="paper, frontier: write DIR's report from its stored trials, run nothing")
    experiment.add_argument("--sections", type=_section_names, default=None, metavar="NAME,...",
                            help="paper, frontier: run only these sections of the plan (their folders: fig5, "
                                 "table2, push, ..., frontier, frontier_narrow); the report still covers the "
                                 "whole plan, from the trials stored so far")
    experiment.add_argument("--trials", type=positive_int("--trials", 10**5),
                            help="seeds per setting (default: 20 on random and random_heights, 5 on raised_stones, "
                                 "1 on the others; frontier: seeds per point of the field, default 100, the "
                                 "oracle and narrow_map's cells in proportion)")
    experiment.add_argument("--workers", type=positive_int("--workers", 256))
    experiment.add_argument("--out", required=True)
    experiment.add_argument("--robot", type=robot_argument, metavar=ROBOT_METAVAR, default=registry.DEFAULT_ROBOT)
    experiment.add_argument("--gaits", type=choices("--gaits", registry.gait_names()), default=None,
                            help="comma-separated (default: walk; walk,trot on random and the terrains with "
                                 "heights; frontier: walk,trot on the field, walk on the bars)")
    experiment.add_argument("--planners", type=choices("--planners", registry.planner_names()), default=None,
                            help="comma-separated (default: contactnet,fixed,heuristic; contactnet,fixed on the "
                                 "terrains with heights; frontier: contactnet,fixed,heuristic,oracle on the field, "
                                 "contactnet,fixed on the bars)")
    experiment.add_argument("--removed", type=number_list("--removed", 0, 300, int), default=None,
                            help="squares removed on random and random_heights, comma-separated (default 80; "
                                 "frontier: 110,125,...,200)")
    experiment.add_argument("--terrain-scale", type=bounded_float("--terrain-scale", 0.1, 10.0), default=None,
                            metavar="S", help=SCALE_HELP)
    experiment.add_argument("--vx", type=bounded_float("--vx", -VELOCITY_LIMIT_M_S, VELOCITY_LIMIT_M_S), default=0.05,
                            metavar="M_S", help="the commanded forward velocity (default 0.05 m/s, the paper's)")
    experiment.add_argument("--height", type=bounded_float("--height", 0.0, 0.5), default=None, metavar="H",
                            help=HEIGHT_HELP)
    experiment.add_argument("--force", type=number_list("--force", 0.1, 100.0), default=None, metavar="N,...",
                            help="push: sustained pushes of N newtons for 1 s, comma-separated (default 5 unless "
                                 "--impulse); --trials pushes each, at random moments and directions")
    experiment.add_argument("--impulse", type=number_list("--impulse", 0.01, 10.0), default=None, metavar="NS,...",
                            help="push: impulses of NS newton-seconds over 0.1 s, comma-separated")
    experiment.add_argument("--push-seed", type=bounded_int("--push-seed", 0, 2**31 - 1), default=0,
                            help="push: the seed of the push moments and directions (not the terrain's)")
    experiment.add_argument("--noise", type=bounded_float("--noise", 0.0, 1.0), default=0.0,
                            help="joint-velocity noise variance")
    experiment.add_argument("--widths-cm", type=number_list("--widths-cm", 1.0, 20.0), default=None,
                            help="narrow_map: bar widths, comma-separated (default 3,4,5,6,7; frontier: 2,...,7)")
    experiment.add_argument("--gaps-cm", type=number_list("--gaps-cm", 0.0, 40.0), default=None,
                            help="narrow_map: gaps before the last bar, comma-separated (default 12,15,18,21,24; "
                                 "frontier: 12,15,...,30)")
    experiment.add_argument("--model-dir", metavar="DIR", help="walk.pt / trot.pt to use (default: the shipped ones)")
    experiment.add_argument("--observer", action=argparse.BooleanOptionalAction, default=True, help=OBSERVER_HELP)
    experiment.add_argument("--retarget", action="store_true", help=RETARGET_HELP)
    experiment.add_argument("--foot-hold", action=argparse.BooleanOptionalAction, default=True, help=FOOT_HOLD_HELP)
    experiment.add_argument("--crouch", type=bounded_float("--crouch", 0.0, 1.0), default=None, metavar="M",
                            help=CROUCH_HELP)
    add_mismatch_arguments(experiment)
    experiment.add_argument("--sim", type=choices("--sim", SIM_ENGINES), metavar="|".join(SIM_ENGINES),
                            help=SIM_HELP + "; comma-separated: every trial in each engine, on the same seeds "
                                 "(not with paper)")
    experiment.add_argument("--quiet", action="store_true", help="no progress bar")
    _engine_arguments(experiment)
    experiment.set_defaults(func=cmd_experiment)

    report = sub.add_parser("report", help="write the report of an `experiment paper` folder from its stored trials")
    report.add_argument("dir", metavar="DIR")
    report.set_defaults(func=cmd_report)

    again = sub.add_parser("replay", help="run one stored experiment trial again and compare its outcome")
    again.add_argument("dir", metavar="DIR", help="the experiment's --out folder (a paper run's too)")
    again.add_argument("key", metavar="KEY", help="the trial's key, as in DIR's trials.jsonl")
    again.add_argument("--json", action="store_true", help="both records whole")
    add_trace_arguments(again)
    again.set_defaults(func=cmd_replay)

    bench = sub.add_parser("bench", help="speed benchmarks (tables; --json for machines)")
    bench.add_argument("what", choices=["planner", "trajopt", "sim", "cost", "terrain", "locomotion", "live", "upload"])
    bench.add_argument("--robot", type=robot_argument, metavar=ROBOT_METAVAR, default=None,
                       help="the robot of the benchmarks that run one (default solo12)")
    bench.add_argument("--sessions", metavar="N[,N...]", type=session_counts, default=None,
                       help="bench live: N visitors' sessions at once (each count a row: all in real time?)")
    bench.add_argument("--runs", type=bounded_int("--runs", 1, 100), default=None, metavar="N",
                       help="bench sim: N runs of each row (default 5 standing, 3 of the whole stack; 1 for a look)")
    bench.add_argument("--json", action="store_true")
    bench.set_defaults(func=cmd_bench)

    add_terrain_parser(sub)

    add_robot_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)  # argparse itself exits 2 with a one-line message on bad options
    try:
        return int(args.func(args) or 0)
    except _user_errors() as exc:
        print(f"contactnet: error: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print("contactnet: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
