"""The paper's experiments (Sec. IV), run in PyBullet: `contactnet experiment NAME --out DIR`.

- ``stepping_stones``: walk at vx = 0.05 m/s across the 8 stones (Fig. 2, 4).
- ``narrow_stones``: the 3 narrow stones where the fixed cyclic gait fails and the acyclic ContactNet
  gait succeeds (Fig. 6).
- ``narrow_map``: the narrow-stones scene over a grid of bar widths x last gaps (all three bars as
  wide, the gap before the last bar varied): where a fixed leg order stops crossing and where the
  acyclic ContactNet does. ``success.png`` is then one success map per planner.
- ``random``: the 1.5 x 0.5 m field of 300 squares with ``removed`` squares missing, one terrain per
  seed (Fig. 5, Table I); walk and trot.

Beyond the paper (terrain with heights; walk and trot):

- ``stairs``: up 3 steps and down 3 (5 cm risers, 20 cm treads).
- ``raised_stones``: the shipped stepping stones with tops spread over +-6 cm, 5 seeds by default (the seed is
  the noise's: with ``--noise`` each seed is another run on the same stones; ``simulate --seed`` builds other
  spreads of heights).
- ``random_heights``: the random field with each square's top at a random height within +-``height_m``
  (default 3 cm), ``removed`` squares missing, one terrain per seed, 20 seeds by default.
- ``ramps``: sloped tops, the shipped ramps (10 and 15 degrees up and down, 10 degrees across the walking
  direction; ``contactnet.terrain.ramps``), ContactNet and the fixed gait.

Beyond the paper's figures, its push experiment (Sec. IV), measured, and a robot that is not quite the model:

- ``push``: walk and trot at vx = 0.05 m/s on ``push_field`` (10 x 10 cm holes); each trial pushes the base once,
  at a start time and in a direction drawn at random (``contactnet.jobs.pushes``: the protocol), with a sustained
  force of ``forces_n`` newtons for 1 s or an impulse of ``impulses_ns`` newton-seconds over 0.1 s; ``trials``
  pushes per gait and magnitude (10 by default). A trial runs ``PUSH_SETTLE_S`` past the push's end; success = no
  fall by then.
- ``robustness``: walk and trot on the random field (``removed`` squares missing, ``trials`` seeds) and across the
  stepping stones, each with every model mismatch of ``ROBUSTNESS_CASES`` (``contactnet.sim.mismatch``: a
  heavier robot, a payload off the centre, less friction, weaker motors, noisy base sensors, a late control
  loop) unknown to the planner and the controller, and the nominal robot beside them.

Every experiment takes one model mismatch for all its trials (``mismatch``; neutral by default).

Every trial is one `Locomotion` run (the same loop as `contactnet simulate`) until the goal, a fall or a
time limit (the time to cross at the commanded speed, times 1.5, plus 10 s). Trials run in worker
processes (``contactnet.jobs.runner``); each finished trial is appended to ``DIR/trials.jsonl`` at once, so an
interrupted experiment resumes with the trials still missing. At the end: ``summary.json``, a table on stdout, and
``success.png`` (the success rates, looked at before they are quoted). A record is the trial's `simulate --json`
summary (without the gait sequence) plus the trial, its time limit, the time of every planner call and optimizer
solve in ms (``planner_ms_samples``, ``trajopt_ms_samples``) and the trial's wall time in its worker
(``trial_wall_s``). `open_batch`, `log_record` and `close_batch` are `run_experiment`'s steps, for a caller that runs
several experiment folders in one job run (``contactnet.jobs.paper``).

Resume is keyed on everything that determines a trial's result (`trial_inputs`): the trial's settings
(terrain, removed squares, seed, gait, planner, robot, vx, noise, bar width and gap), the terrain's
content, the gait's spec, the model's content hash (`contactnet.planning.network.LoadedModel.identity`: its
recorded hash, else the file's sha256; not its path) and the code (`contactnet.jobs.runner.code_identity`). Each
logged record carries its inputs and their digest (``fingerprint``); a record is reused only when its
fingerprint is the trial's now. Any other record of the trial (other models, other code, or a log written
before records had fingerprints) is kept in the log but not reused: the trial runs again, with one line
on stderr saying why. ``DIR/experiment.json`` (the folder's header) names the experiment and the
fingerprints of its last run; a folder of another experiment is refused.
"""

from __future__ import annotations

import functools
import json
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from contactnet.atomic import atomic_write_text
from contactnet.jobs.pushes import (
    FORCE_DURATION_S,
    SETTLE_S,
    PushSizes,
    force_xy,
    push_window_s,
    sample_moments,
)
from contactnet.jobs.runner import Job, code_identity, differences, digest, run_jobs
from contactnet.jobs.summary import plot_success, summarize
from contactnet.robots import DEFAULT_ROBOT
from contactnet.sim.mismatch import ModelMismatch
from contactnet.sim.world import ENGINES as SIM_ENGINES

if TYPE_CHECKING:
    from contactnet.jobs.trace import LoopTrace

HEADER_FORMAT = "contactnet-experiment-v1"
EXPERIMENTS = ("stepping_stones", "narrow_stones", "narrow_map", "random", "stairs", "raised_stones", "random_heights",
               "push", "robustness", "stone_grid", "ramps")
DEFAULT_PLANNERS = {
    "stepping_stones": ("contactnet", "fixed", "heuristic"),
    "narrow_stones": ("contactnet", "fixed", "heuristic"),
    "narrow_map": ("contactnet", "fixed"),
    "random": ("contactnet", "fixed", "heuristic"),
    "stairs": ("contactnet", "fixed"),
    "raised_stones": ("contactnet", "fixed"),
    "random_heights": ("contactnet", "fixed"),
    "push": ("contactnet",),
    "robustness": ("contactnet",),
    "stone_grid": ("contactnet", "fixed", "heuristic"),
    "ramps": ("contactnet", "fixed"),
}
DEFAULT_GAITS = {"stepping_stones": ("walk",), "narrow_stones": ("walk",), "narrow_map": ("walk",),
                 "random": ("walk", "trot"), "stairs": ("walk", "trot"), "raised_stones": ("walk", "trot"),
                 "random_heights": ("walk", "trot"), "push": ("walk", "trot"),
                 "robustness": ("walk", "trot"), "stone_grid": ("walk", "trot"),
                 "ramps": ("walk", "trot")}
DEFAULT_TRIALS = {"random": 20, "random_heights": 20, "raised_stones": 5, "push": 10, "robustness": 20}  # 1 elsewhere
FIELDS = ("random", "random_heights")  # one generated terrain per (removed, seed)
DEFAULT_HEIGHT_M = 0.03  # random_heights: each top within +-3 cm
PUSH_DURATION_S = FORCE_DURATION_S
PUSH_SETTLE_S = SETTLE_S  # a push trial runs this long after the push ends
#: The robustness experiment's model mismatches, each alone (the nominal robot first).
ROBUSTNESS_CASES = (
    ModelMismatch(),
    ModelMismatch(mass_scale=1.2),
    ModelMismatch(payload_kg=0.5, payload_offset_xy_m=(0.05, 0.0)),
    ModelMismatch(friction=0.5),
    ModelMismatch(torque_scale=0.8),
    ModelMismatch(orientation_noise_rad=0.01, lin_vel_noise_m_s=0.05, ang_vel_noise_rad_s=0.05),
    ModelMismatch(delay_ms=3.0),
)
# The narrow_map grid: bar width 3-7 cm (the candidate spacing is 5 cm), last gap 12-24 cm.
NARROW_MAP_WIDTHS_CM = (3.0, 4.0, 5.0, 6.0, 7.0)
NARROW_MAP_GAPS_CM = (12.0, 15.0, 18.0, 21.0, 24.0)


class ExperimentError(ValueError):
    """A bad experiment request or output directory (one-line message)."""


@dataclass(frozen=True)
class Trial:
    """One run: a terrain, a gait, a planner, a seed (sim noise and, for ``random``, the terrain), a robot."""

    experiment: str
    terrain: str
    removed: int | None
    seed: int
    gait: str
    planner: str
    vx: float = 0.05
    noise: float = 0.0
    model_dir: str | None = None
    bar_width_m: float | None = None  # narrow_map: all three bars this wide
    last_gap_m: float | None = None  # narrow_map: the gap before the last bar
    robot: str = DEFAULT_ROBOT  # contactnet.registry name
    height_m: float | None = None  # random_heights: each square's top within +-height_m
    push_t0_s: float | None = None  # push: when the push starts ...
    push_force_xy: tuple[float, float] | None = None  # ... its force (N, world) ...
    push_duration_s: float = PUSH_DURATION_S  # ... for this long
    observer: bool = True  # the disturbance observer on (contactnet.planning.observer; on by default)
    retarget: bool = False  # swing retargeting on (contactnet.planning.retarget; off by default)
    mismatch: ModelMismatch = ModelMismatch()  # how the simulated robot differs from the model (neutral: not at all)
    sim: str = "pybullet"  # the physics engine (contactnet.sim.engines; the command line passes the installed one)
    scale: float | None = None  # the scene's size against the paper's; None: the robot's (registry.terrain_for)
    crouch_m: float | None = None  # the CoM reference this much below the nominal; None: the robot's default
    # for the gait and terrain (LocomotionConfig.crouch_m)
    foot_hold: bool = True  # a lost stance foot held where it stood (contactnet.motion.foot_hold; on by default)

    @property
    def key(self) -> str:
        """Names the trial in ``trials.jsonl``; the robot only when it is not Solo12, the height only on
        random_heights, a push's duration only when not 1 s, the observer only when off, retargeting only when on
        and the mismatch only when there is one; the engine only when it is not PyBullet; a crouch only when given; the
        foot hold only when off."""
        removed = "" if self.removed is None else f"/{self.removed}"
        height = "" if self.height_m is None else f"/h{self.height_m:g}"
        robot = "" if self.robot == DEFAULT_ROBOT else f"/{self.robot}"
        push = ""
        if self.push_force_xy is not None:
            push = f"/push{self.push_force_xy[0]:g},{self.push_force_xy[1]:g}@{self.push_t0_s:g}"
            push += "" if self.push_duration_s == PUSH_DURATION_S else f"x{self.push_duration_s:g}s"
        mismatch = "" if self.mismatch.neutral else f"/{self.mismatch.label()}"
        scale = "" if self.scale is None else f"/x{self.scale:g}"
        return (f"{self.terrain}{removed}{height}{push}/seed{self.seed}/{self.gait}/{self.planner}/noise{self.noise:g}"
                f"{robot}{'' if self.observer else '/no-observer'}{'/retarget' if self.retarget else ''}{mismatch}"
                f"{'' if self.sim == 'pybullet' else '/' + self.sim}{scale}"
                f"{'' if self.crouch_m is None else f'/crouch{self.crouch_m:g}'}{'' if self.foot_hold else '/no-foot-hold'}")


def trials_of(name: str, trials: int | None = None, gaits: tuple[str, ...] | None = None,
              planners: tuple[str, ...] | None = None, removed: tuple[int, ...] = (80,), noise: float = 0.0,
              vx: float = 0.05, model_dir: str | None = None,
              widths_cm: tuple[float, ...] | None = None, gaps_cm: tuple[float, ...] | None = None,
              robot: str = DEFAULT_ROBOT, height_m: float = DEFAULT_HEIGHT_M,
              forces_n: tuple[float, ...] = (5.0,), observer: bool = True, impulses_ns: tuple[float, ...] = (),
              push_seed: int = 0, mismatch: ModelMismatch | None = None, retarget: bool = False,
              sims: tuple[str, ...] = ("pybullet",), scale: float | None = None, crouch_m: float | None = None,
              foot_hold: bool = True) -> list[Trial]:
    """The trials of experiment ``name`` with ``robot`` (default: 1 trial per setting on the fixed scenes and
    on every cell of ``narrow_map``'s ``widths_cm`` x ``gaps_cm`` grid, 5 seeds on ``raised_stones``, 20 on
    ``random`` and ``random_heights``, whose tops spread over +-``height_m``; on ``push``, 10 sampled pushes
    (``push_seed``) per force of ``forces_n`` and impulse of ``impulses_ns``; on ``robustness``, 20 seeds of the
    random field and the stepping stones per case of ``ROBUSTNESS_CASES``). Every trial's robot differs from the
    model by ``mismatch`` (neutral by default; on ``robustness``: the cases', unless given); ``observer``,
    ``retarget`` and ``foot_hold`` turn those parts of the stack on or off in every trial; every trial runs in each
    engine of ``sims`` (same seeds, terrains and pushes); ``scale``: every scene that size against the paper's (default: the robot's,
    ``registry.terrain_for``)."""
    if name not in EXPERIMENTS:
        raise ExperimentError(f"unknown experiment {name!r}: choose one of {', '.join(EXPERIMENTS)}")
    gaits = gaits or DEFAULT_GAITS[name]
    planners = planners or DEFAULT_PLANNERS[name]
    n = trials or DEFAULT_TRIALS.get(name, 1)
    out = []
    for gait in gaits:
        for planner in planners:
            if name in FIELDS:
                height = height_m if name == "random_heights" else None
                out += [Trial(name, name, k, seed, gait, planner, vx, noise, model_dir, robot=robot, height_m=height)
                        for k in removed for seed in range(n)]
            elif name == "push":
                moments = sample_moments(n, push_seed, push_window_s(vx))
                out += [Trial(name, "push_field", None, k, gait, planner, vx, noise, model_dir, robot=robot,
                              push_t0_s=t0, push_force_xy=force_xy(force, angle), push_duration_s=duration)
                        for force, duration in PushSizes(tuple(forces_n), tuple(impulses_ns), push_seed).pushes()
                        for k, (t0, angle) in enumerate(moments)]
            elif name == "robustness":
                for case in (ROBUSTNESS_CASES if mismatch is None else (mismatch,)):
                    out += [Trial(name, "random", k, seed, gait, planner, vx, noise, model_dir, robot=robot,
                                  mismatch=case) for k in removed for seed in range(n)]
                    stones = min(n, 5) if case.sensor_noise or noise else 1  # one scene: one run unless noisy
                    out += [Trial(name, "stepping_stones", None, seed, gait, planner, vx, noise, model_dir, robot=robot,
                                  mismatch=case) for seed in range(stones)]
            elif name == "narrow_map":
                from contactnet.terrain import narrow_stones

                for width_cm in widths_cm or NARROW_MAP_WIDTHS_CM:
                    for gap_cm in gaps_cm or NARROW_MAP_GAPS_CM:
                        width_m, gap_m = round(width_cm / 100, 6), round(gap_cm / 100, 6)
                        terrain = narrow_stones(width_m, gap_m).name
                        out += [Trial(name, terrain, None, seed, gait, planner, vx, noise, model_dir, width_m, gap_m,
                                      robot=robot) for seed in range(n)]
            else:
                out += [Trial(name, name, None, seed, gait, planner, vx, noise, model_dir, robot=robot)
                        for seed in range(n)]
    if mismatch is not None and name != "robustness":
        out = [replace(t, mismatch=mismatch) for t in out]
    if not sims or any(sim not in SIM_ENGINES for sim in sims):
        raise ValueError(f"unknown physics engine in {sims!r}: choose among {', '.join(SIM_ENGINES)}")
    out = [replace(t, sim=sim) for sim in dict.fromkeys(sims) for t in out]
    if scale is not None:
        out = [replace(t, scale=float(scale)) for t in out]
    if crouch_m is not None:
        out = [replace(t, crouch_m=float(crouch_m)) for t in out]
    if not foot_hold:
        out = [replace(t, foot_hold=False) for t in out]
    return [replace(t, observer=observer, retarget=retarget) for t in out] if not observer or retarget else out


def run_trial(trial: Trial, trace: LoopTrace | None = None) -> dict:
    """Run one trial in this process and return its record (the trial, the simulate summary, facts); ``trace``: sampled
    on the way (the same run: ``contactnet.jobs.trace``)."""
    from contactnet.locomotion import Locomotion, LocomotionConfig
    from contactnet.motion.foot_hold import FootHoldConfig
    from contactnet.planning.observer import DEFAULT_OBSERVER
    from contactnet.planning.retarget import RetargetConfig
    from contactnet.registry import gait_for, load_robot, make_planner, model_path
    from contactnet.sim.world import SimConfig

    t0 = time.perf_counter()
    terrain = _terrain(trial.terrain, trial.removed, trial.seed, trial.bar_width_m, trial.last_gap_m, trial.height_m,
                       trial.robot, trial.scale)
    robot = load_robot(trial.robot).for_terrain(terrain, trial.gait)  # its stance here (Robot.for_terrain)
    gait = gait_for(trial.gait, robot)
    model = None if trial.model_dir is None else model_path(trial.robot, trial.gait, Path(trial.model_dir))
    planner = make_planner(trial.planner, gait, robot, model=model)
    distance = max(terrain.goal_x - terrain.start_xy[0], 0.0)
    limit_s = 1.5 * distance / max(abs(trial.vx), 1e-3) + 10.0
    sim_config = SimConfig(joint_vel_noise_var=trial.noise, seed=trial.seed, mismatch=trial.mismatch, engine=trial.sim)
    loop_config = LocomotionConfig(observer=DEFAULT_OBSERVER if trial.observer else None,
                                   retarget=RetargetConfig() if trial.retarget else None, crouch_m=trial.crouch_m,
                                   foot_hold=FootHoldConfig() if trial.foot_hold else None)
    with Locomotion(robot, terrain, gait, planner, sim_config, config=loop_config, vel_cmd_xy=(trial.vx, 0.0)) as loco:
        if trial.push_force_xy is not None:  # success: no fall until the push has settled
            from contactnet.sim.world import Push

            loco.push(Push(trial.push_t0_s, trial.push_duration_s, (*trial.push_force_xy, 0.0)))
            limit_s = trial.push_t0_s + trial.push_duration_s + PUSH_SETTLE_S
        summary = loco.run(limit_s) if trace is None else trace.run(loco, limit_s)
        samples = {"planner_ms_samples": _ms_samples(loco.planner_times_s),
                   "trajopt_ms_samples": _ms_samples(loco.trajopt_times_s)}
    if trial.push_force_xy is not None:
        summary["success"] = not summary["fell"]
    summary.pop("gait_sequence", None)  # long; the table does not need it
    return {"key": trial.key, "trial": asdict(trial), "time_limit_s": limit_s, **summary, **samples,
            "robot_mass_kg": robot.mass_kg, "mismatch_label": trial.mismatch.label(),
            "trial_wall_s": time.perf_counter() - t0}


def _ms_samples(times_s: list[float]) -> list[float]:
    """Every call's time in ms to the microsecond (the report's time distributions)."""
    return [round(1e3 * t, 3) for t in times_s]


def _terrain(name: str, removed: int | None, seed: int, bar_width_m: float | None, last_gap_m: float | None,
             height_m: float | None = None, robot: str = DEFAULT_ROBOT, scale: float | None = None):
    from contactnet.terrain import narrow_stones, resolve

    if bar_width_m is not None or last_gap_m is not None:  # narrow_map's bars and gaps: the sizes asked for
        return narrow_stones(bar_width_m, last_gap_m)
    # The seed draws the fields' terrains; on the scenes it seeds only the noise (the shipped terrain every time).
    seed = seed if name in FIELDS else 0
    if robot == DEFAULT_ROBOT and scale is None:  # the paper's scenes, as every Solo12 trial has always had them
        return resolve(name, removed=removed, seed=seed, height_m=height_m)
    from contactnet.registry import load_robot, terrain_for

    return terrain_for(name, load_robot(robot), removed=removed, seed=seed, height_m=height_m, scale=scale)


@functools.lru_cache(maxsize=64)
def _terrain_inputs(*args: object) -> dict:
    terrain = _terrain(*args)  # type: ignore[arg-type]
    return {"name": terrain.name, "sha256": digest(terrain.to_dict())}


@functools.lru_cache(maxsize=64)
def _gait_digest(gait: str, robot: str) -> str:
    """The digest of the gait as the trial's robot walks it (sized to it: Solo12's is the paper's spec)."""
    from contactnet.registry import gait_for, load_robot

    return digest(repr(gait_for(gait, load_robot(robot))))


@functools.lru_cache(maxsize=64)
def _model_identity(path: str, stamp: tuple[int, int]) -> str:
    from contactnet.planning.network import load_model

    return load_model(path).identity


def trial_inputs(trial: Trial) -> dict:
    """Everything that determines ``trial``'s result, as plain values (see the module docstring). Raises
    ModelFileError when the trial's planner needs a model file that is missing or bad."""
    from contactnet.registry import model_path, planner_entry
    from contactnet.sim.engines import engine_version

    model = None
    if planner_entry(trial.planner).needs_model:
        path = model_path(trial.robot, trial.gait, None if trial.model_dir is None else Path(trial.model_dir))
        try:
            stat = path.stat()
            stamp = (stat.st_mtime_ns, stat.st_size)
        except OSError:
            stamp = (0, 0)  # load_model names the problem
        model = _model_identity(str(path), stamp)
    settings = asdict(trial)
    del settings["model_dir"]  # where the model lies does not matter, its content does
    if settings["observer"]:
        del settings["observer"]  # on, the default: named only when off
    if not settings["retarget"]:
        del settings["retarget"]  # as before the part existed (older logs resume)
    if trial.mismatch.neutral:
        del settings["mismatch"]
    if trial.scale is None:
        del settings["scale"]  # the robot's: named by the robot (older logs resume)
    if settings["crouch_m"] is None:
        del settings["crouch_m"]  # the robot's default (named by the code), as before the option existed
    if settings["foot_hold"]:
        del settings["foot_hold"]  # on, the default: named only when off
    del settings["sim"]  # named with its version below
    terrain = _terrain_inputs(trial.terrain, trial.removed, trial.seed, trial.bar_width_m, trial.last_gap_m,
                              trial.height_m, trial.robot, trial.scale)
    return {"trial": settings, "terrain": terrain, "gait": _gait_digest(trial.gait, trial.robot),
            "model": model, "code": code_identity(), "sim": f"{trial.sim} {engine_version(trial.sim)}"}


def _one_torch_thread() -> None:
    """Worker processes: one torch thread each (the workers already use every core); nothing without torch (the
    extra ``train``)."""
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)


def read_log(path: Path) -> list[dict]:
    """The trial records in the log, in order. A last line cut by a kill is dropped (that trial runs again)
    and the log rewritten without it; a bad line elsewhere is an error (the file is not ours)."""
    records: list[dict] = []
    if not path.exists():
        return records
    lines = path.read_text().splitlines()
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
            if not isinstance(record["key"], str):
                raise TypeError
            records.append(record)
        except (json.JSONDecodeError, KeyError, TypeError):
            if number < len(lines):
                raise ExperimentError(f"{path}: line {number} is not a trial record") from None
            atomic_write_text(path, "".join(f"{kept}\n" for kept in lines[:-1]))
    return records


def _reusable(log: Path, records: list[dict], inputs: dict[str, dict], fingerprints: dict[str, str]) -> dict:
    """The logged records whose fingerprint is their trial's now (the last one of each trial). One line on
    stderr when other records of these trials are not reused, naming what changed."""
    done: dict[str, dict] = {}
    stale: dict[str, dict] = {}
    for record in records:
        key = record["key"]
        if key in fingerprints:
            (done if record.get("fingerprint") == fingerprints[key] else stale)[key] = record
    rerun = [key for key in stale if key not in done]
    changed: set[str] = set()
    for key in rerun:
        old = stale[key].get("inputs")
        changed.update(differences(old, inputs[key]) if isinstance(old, dict) else ["?"])
    if rerun:
        words = {"trial": "settings", "terrain": "terrain", "gait": "gait spec", "model": "model", "code": "code"}
        why = [f"with other {', '.join(words.get(c, c) for c in sorted(changed - {'?'}))}"] if changed - {"?"} else []
        why += ["logged before trials recorded their inputs"] if "?" in changed else []
        print(f"contactnet: {len(rerun)} trial(s) in {log} were run {' or '.join(why)}: not reused, running them "
              "again", file=sys.stderr)
    return done


def _check_header(out: Path, name: str) -> None:
    path = out / "experiment.json"
    if not path.exists():
        return
    try:
        header = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        raise ExperimentError(f"{path}: unreadable experiment header") from None
    if not isinstance(header, dict) or header.get("format") != HEADER_FORMAT:
        raise ExperimentError(f"{path}: not a {HEADER_FORMAT} header")
    if header.get("experiment") != name:
        raise ExperimentError(f"{out} holds the experiment {str(header.get('experiment'))[:40]!r}, not {name!r}; "
                              "use another --out")


@dataclass
class Batch:
    """One experiment folder open for running: its trials, what determines each (``inputs``) and their
    ``fingerprints``, and the records already done (reused from the log, then each new one as it comes)."""

    name: str
    out: Path
    trials: list[Trial]
    inputs: dict[str, dict]
    fingerprints: dict[str, str]
    done: dict[str, dict]

    @property
    def log(self) -> Path:
        return self.out / "trials.jsonl"


def open_batch(name: str, out_dir: str | Path, trials: list[Trial]) -> Batch:
    """Check ``out_dir`` (refused when it holds another experiment), write its header naming ``trials``'
    fingerprints and read the logged records that can be reused."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ExperimentError(f"{out} exists and is not a directory")
    if len({t.key for t in trials}) != len(trials):
        raise ExperimentError("two trials have the same key")
    inputs = {t.key: trial_inputs(t) for t in trials}
    fingerprints = {key: digest(value) for key, value in inputs.items()}
    out.mkdir(parents=True, exist_ok=True)
    _check_header(out, name)
    log = out / "trials.jsonl"
    done = _reusable(log, read_log(log), inputs, fingerprints)
    atomic_write_text(out / "experiment.json", json.dumps(
        {"format": HEADER_FORMAT, "experiment": name, "code": code_identity(), "trials": fingerprints}, indent=1))
    return Batch(name, out, list(trials), inputs, fingerprints, done)


def log_record(batch: Batch, record: dict) -> dict:
    """Append a finished trial's ``record`` (from `run_trial`) to the batch's log with its inputs and
    fingerprint, at once; returns the stored record."""
    key = record["key"]
    record = {**record, "fingerprint": batch.fingerprints[key], "inputs": batch.inputs[key]}
    with open(batch.log, "a") as file:
        file.write(json.dumps(record) + "\n")
    batch.done[key] = record
    return record


def close_batch(batch: Batch, wall_s: float) -> dict:
    """The summary of a batch whose trials are all done: summary.json and success.png; returns the summary."""
    records = [batch.done[t.key] for t in batch.trials]
    summary = summarize(batch.name, records, wall_s)
    atomic_write_text(batch.out / "summary.json", json.dumps(summary, indent=1))
    plot_success(summary, batch.out / "success.png")
    if any(r["trial"].get("push_force_xy") is not None for r in records):
        from contactnet.jobs.pushes import plot_polar

        plot_polar(records, batch.out / "push_polar.png")
    return summary


def run_experiment(name: str, out_dir: str | Path, trials: list[Trial], workers: int | None = None,
                   progress: bool = True, engine: str = "local", address: str | None = None) -> dict:
    """Run (or resume) ``trials`` into ``out_dir`` with ``workers`` processes (default: all cores; 1: in this
    process), run by ``contactnet.jobs.runner`` (``engine``, ``address``: see `contactnet.jobs.runner.run_jobs`); returns
    the summary (also written to summary.json). The progress bar shows trials/s, the ETA and the successes
    so far (of the trials done, the reused ones included)."""
    batch = open_batch(name, out_dir, trials)
    done = batch.done
    t0 = time.perf_counter()
    tally = {"ok": sum(bool(done[t.key]["success"]) for t in trials if t.key in done),
             "done": sum(t.key in done for t in trials)}

    def append(job: Job, record: dict) -> dict:
        record = log_record(batch, record)
        tally["ok"] += bool(record["success"])
        tally["done"] += 1
        return {"successes": f"{tally['ok']}/{tally['done']}",
                "last": f"{record['key']}: {'ok' if record['success'] else 'fail'}"}

    run_jobs([Job(t.key, t) for t in trials], run_trial, append, done=dict(done), workers=workers,
             progress=progress, unit="trial", engine=engine, worker_init=_one_torch_thread, address=address)
    return close_batch(batch, time.perf_counter() - t0)
