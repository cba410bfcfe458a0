"""Data generation (the paper's Sec. III-B): states a walking robot meets, with the ranking cost of
every candidate action.

An *episode* starts the robot (Solo12 by default) on flat ground in a random configuration (joint positions and
velocities perturbed around the stance) with a random reference velocity in (-0.1, 0.1) m/s for x
and y. Before each lift-off the oracle evaluates V for every candidate action and the cheapest is
executed in the PyBullet loop (plan + optimize + track): one *instance*, recorded as (u_r, V).
An episode ends after 30 instances or when the robot falls; a fall drops its last 3 instances.

Output: a directory of shards (`shard-00000.npz`: `u` (n, 14), `V` (n, N_a + 1): the N_a stepping actions, then
standing, `episode` (n,)), each
holding `episodes_per_shard` consecutive episodes, and `manifest.json`. Every episode is seeded
from (seed, episode index), so the dataset does not depend on how many workers made it. Shards and
the manifest are written atomically (``contactnet.atomic``): an interrupted run (Ctrl-C, kill) loses at most
the shards in progress, and running the same command again resumes where it stopped (``contactnet.jobs.runner``).

The manifest records what determines the data: the settings, the gait's full spec (its candidate grid,
timing and cost weights: ``gait_spec``, a digest of its repr) and the code (``code``:
`contactnet.jobs.runner.code_identity`); a resume with anything else is refused (a dataset is one artifact that
train reads whole: shards of two codes must not mix), and so is a directory whose manifest predates these
records. Every shard's size and sha256 are recorded when it is written; a resume verifies each listed shard
(size first, the hash when the size matches) and regenerates a damaged one with a warning on stderr, and
``contactnet train`` refuses it.
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

import contactnet
from contactnet.atomic import atomic_write_text, atomic_write_with
from contactnet.jobs.runner import Job, check_file, code_identity, differences, digest, file_sha256, run_jobs
from contactnet.motion.gait import GaitSpec
from contactnet.planning.network_input import INPUT_NAMES, network_input_of_context
from contactnet.planning.planner import PlanningContext
from contactnet.registry import DEFAULT_ROBOT, gait_by_name, gait_for, robot_names
from contactnet.sim.engines import ENGINES, engine_version

FORMAT = "contactnet-dataset-v1"


class DatasetDirError(ValueError):
    """The output directory holds something that is not this dataset (one-line message)."""


@dataclass(frozen=True)
class DatagenConfig:
    """The data-generation procedure (defaults: the paper's)."""

    gait: str
    robot: str = DEFAULT_ROBOT  # contactnet.registry name of the robot that walks
    episodes: int = 1500
    instances_per_episode: int = 30
    drop_on_fall: int = 3
    vel_max_m_s: float = 0.1
    joint_pos_noise_rad: float = 0.15  # uniform perturbation of each joint around the stance
    joint_vel_noise_rad_s: float = 0.5  # uniform initial joint velocities
    episodes_per_shard: int = 5
    seed: int = 0
    # Steps of each 3-step plan chosen by V. Only step 1 is recorded and executed (the robot re-plans at
    # every touchdown); 1 makes generation 3x cheaper, the later steps continue the cyclic order.
    oracle_evaluated_steps: int = 1
    sim: str = "pybullet"  # the physics engine the episodes run in (contactnet.sim.engines)

    def __post_init__(self) -> None:
        gait_by_name(self.gait)
        if self.sim not in ENGINES:
            raise ValueError(f"unknown physics engine {self.sim!r}: choose one of {', '.join(ENGINES)}")
        if self.robot not in robot_names():
            raise ValueError(f"unknown robot {self.robot!r}: choose one of {', '.join(robot_names())}")
        if not 1 <= self.episodes <= 10**6:
            raise ValueError(f"episodes must be in 1..1000000, got {self.episodes}")
        if not 1 <= self.instances_per_episode <= 1000:
            raise ValueError(f"instances_per_episode must be in 1..1000, got {self.instances_per_episode}")
        if not 1 <= self.oracle_evaluated_steps <= 3:
            raise ValueError(f"oracle_evaluated_steps must be in 1..3, got {self.oracle_evaluated_steps}")
        if not 1 <= self.episodes_per_shard <= 1000:
            raise ValueError(f"episodes_per_shard must be in 1..1000, got {self.episodes_per_shard}")

    @property
    def n_shards(self) -> int:
        return -(-self.episodes // self.episodes_per_shard)

    def shard_episodes(self, shard: int) -> range:
        start = shard * self.episodes_per_shard
        return range(start, min(start + self.episodes_per_shard, self.episodes))

    def settings(self) -> dict:
        """What must match for a directory to be resumed."""
        return asdict(self)

    def matches(self, settings: object) -> bool:
        """Whether a manifest's ``settings`` are these (a manifest written before ``robot`` existed is Solo12's, one
        written before ``sim`` existed PyBullet's)."""
        if not isinstance(settings, dict):
            return False
        return {"robot": DEFAULT_ROBOT, "sim": "pybullet", **settings} == self.settings()

    def inputs(self) -> dict:
        """Besides the settings, what determines the data: the gait's spec, the code and the engine's version."""
        from contactnet.registry import load_robot

        return {"gait_spec": digest(repr(gait_for(self.gait, load_robot(self.robot)))), "code": code_identity(),
                "sim_version": engine_version(self.sim)}


def shard_name(shard: int) -> str:
    return f"shard-{shard:05d}.npz"


class RecordingPlanner:
    """Wraps the oracle: records (u_r, V) at every plan, i.e. before every lift-off."""

    name = "recording"

    def __init__(self, oracle):  # noqa: ANN001 - contactnet.planning.oracle.OraclePlanner
        self.oracle = oracle
        self.inputs: list[np.ndarray] = []
        self.costs: list[np.ndarray] = []

    @property
    def last_candidates(self):  # noqa: ANN201 - the oracle's CandidateRanking
        return self.oracle.last_candidates

    def reset(self) -> None:
        self.inputs.clear()
        self.costs.clear()
        if hasattr(self.oracle, "reset"):
            self.oracle.reset()

    def plan(self, ctx: PlanningContext):
        steps = self.oracle.plan(ctx)
        self.inputs.append(network_input_of_context(ctx))
        self.costs.append(np.asarray(self.oracle.last_costs.V, dtype=np.float64))
        return steps


def make_oracle(gait: GaitSpec, robot, evaluated_steps: int = 1):  # noqa: ANN001 - contactnet.robots.Robot
    from contactnet.planning.oracle import OraclePlanner

    return OraclePlanner(gait, robot.description, evaluated_steps=evaluated_steps)


def run_episode(loco, recorder: RecordingPlanner, config: DatagenConfig, episode: int) -> dict:
    """One episode in an existing Locomotion (reset here); returns its arrays and facts."""
    rng = np.random.default_rng([config.seed, episode])
    robot = loco.robot
    joint_pos = robot.joint_standing + rng.uniform(-config.joint_pos_noise_rad, config.joint_pos_noise_rad, 12)
    joint_vel = rng.uniform(-config.joint_vel_noise_rad_s, config.joint_vel_noise_rad_s, 12)
    vel_cmd = rng.uniform(-config.vel_max_m_s, config.vel_max_m_s, 2)
    loco.set_command(*vel_cmd)
    loco.reset(joint_pos=joint_pos, joint_vel=joint_vel)
    recorder.reset()
    step_ticks = loco.ticks_per_step
    # Run until the instance after the last one would be planned: every recorded step was executed.
    while len(recorder.inputs) < config.instances_per_episode + 1 and loco.fall_reason is None:
        loco.advance(step_ticks)
    n = min(len(recorder.inputs), config.instances_per_episode)
    fell = loco.fall_reason is not None
    if fell:
        n = max(0, len(recorder.inputs) - config.drop_on_fall)
    return {
        "u": np.asarray(recorder.inputs[:n], dtype=np.float32).reshape(n, len(INPUT_NAMES)),
        "V": np.asarray(recorder.costs[:n], dtype=np.float32).reshape(n, recorder.oracle.cost.n_choices),
        "fell": fell,
    }


def make_shard(out_dir: str, config: DatagenConfig, shard: int) -> dict:
    """Generate one shard's episodes and write the shard file. Returns its counts, size and sha256."""
    return write_shard(Path(out_dir), _shard_job((config, shard)))


def write_shard(out_dir: Path, made: dict) -> dict:
    """Write a shard made by `_shard_job` (atomically) and return its stats: counts, size and sha256."""
    u, V, episode_ids = made.pop("arrays")
    path = out_dir / shard_name(made["shard"])
    atomic_write_with(path, lambda file: np.savez_compressed(file, u=u, V=V, episode=episode_ids))
    return {**made, "bytes": path.stat().st_size, "sha256": file_sha256(path)}


def shard_arrays(config: DatagenConfig, shard: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Run one shard's episodes: its ``u``, ``V``, ``episode`` arrays and how many episodes fell."""
    from contactnet.locomotion import Locomotion, LocomotionConfig
    from contactnet.robots import load_robot
    from contactnet.sim.world import SimConfig
    from contactnet.terrain import flat

    robot = load_robot(config.robot)
    gait = gait_for(config.gait, robot)  # sized to the robot (contactnet.motion.gait.SIZE_RULE)
    recorder = RecordingPlanner(make_oracle(gait, robot, config.oracle_evaluated_steps))
    us, vs, eps, falls = [], [], [], 0
    # at the nominal height and in the robot's own stance (the paper's data; a robot's default crouch and its stance on
    # terrain of one level, Robot.for_terrain, are choices of the walk, not of its data)
    loop_config = LocomotionConfig(crouch_m=0.0)
    with Locomotion(robot, flat(), gait, recorder, SimConfig(seed=config.seed + shard, engine=config.sim),
                    config=loop_config) as loco:
        for episode in config.shard_episodes(shard):
            result = run_episode(loco, recorder, config, episode)
            us.append(result["u"])
            vs.append(result["V"])
            eps.append(np.full(len(result["u"]), episode, dtype=np.int32))
            falls += result["fell"]
    return np.concatenate(us), np.concatenate(vs), np.concatenate(eps), falls


def read_manifest(out_dir: Path) -> dict | None:
    path = out_dir / "manifest.json"
    if not path.exists():
        return None
    try:
        manifest = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise DatasetDirError(f"{path}: unreadable manifest ({exc})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise DatasetDirError(f"{path}: not a {FORMAT} manifest")
    return manifest


def write_manifest(out_dir: Path, config: DatagenConfig, shards: dict[int, dict], wall_s: float) -> dict:
    gait = gait_by_name(config.gait)
    done = sorted(shards)
    manifest = {
        "format": FORMAT,
        "gait": config.gait,
        "robot": config.robot,
        "n_actions": gait.n_choices if gait.cost_weights.stand else gait.n_actions,  # V's columns: the choices
        "input_names": list(INPUT_NAMES),
        "shards": [shard_name(s) for s in done],
        "episodes": sum(len(config.shard_episodes(s)) for s in done),
        "episodes_planned": config.episodes,
        "instances": sum(shards[s]["instances"] for s in done),
        "falls": sum(shards[s]["falls"] for s in done),
        "complete": len(done) == config.n_shards,
        "seed": config.seed,
        "settings": config.settings(),
        "shard_stats": {shard_name(s): shards[s] for s in done},
        "wall_time_s": wall_s,
        "code_version": contactnet.__version__,
        **config.inputs(),
    }
    atomic_write_text(out_dir / "manifest.json", json.dumps(manifest, indent=1))
    return manifest


def generate(out_dir: str | Path, config: DatagenConfig, workers: int | None = None, progress: bool = True,
             engine: str = "local", address: str | None = None) -> dict:
    """Generate (or resume) a dataset in out_dir with `workers` processes (default: all cores; 1: in this
    process), run by ``contactnet.jobs.runner`` (``engine``, ``address``: see `contactnet.jobs.runner.run_jobs`); the
    shard files and the manifest are written by this process.

    Ctrl-C stops the workers at once; finished shards stay, listed in the manifest, and the next
    call with the same settings resumes with the missing shards.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise DatasetDirError(f"{out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    manifest = read_manifest(out)
    shards: dict[int, dict] = {}
    wall_before = 0.0
    if manifest is not None:
        if not config.matches(manifest.get("settings")):
            raise DatasetDirError(
                f"{out} holds a dataset made with other settings ({manifest.get('settings')}); "
                "use another --out, or the same settings to resume"
            )
        _check_inputs(out, manifest, config)
        shards = _verified_shards(out, manifest)
        wall_before = float(manifest.get("wall_time_s", 0.0))
    elif any(p for p in out.iterdir() if not p.name.startswith(".")):
        raise DatasetDirError(f"{out} is not empty and has no dataset manifest; choose an empty --out")
    t0 = time.perf_counter()
    previous = sum(s["instances"] for s in shards.values())
    new_instances = 0

    def store(job: Job, made: dict) -> dict:
        nonlocal new_instances
        stats = write_shard(out, made)  # here, not in the worker: a Ray cluster needs no shared file system
        shards[stats["shard"]] = stats
        new_instances += stats["instances"]
        elapsed = time.perf_counter() - t0
        write_manifest(out, config, shards, wall_before + elapsed)
        return {"instances": previous + new_instances, "per_s": f"{new_instances / elapsed:.1f}"}

    jobs = [Job(shard, (config, shard), size=len(config.shard_episodes(shard)))
            for shard in range(config.n_shards)]
    try:
        run_jobs(jobs, _shard_job, store, done=shards, workers=workers, progress=progress, unit="episode",
                 engine=engine, worker_init=_one_torch_thread, address=address)
    except BaseException:
        write_manifest(out, config, shards, wall_before + time.perf_counter() - t0)
        raise
    return write_manifest(out, config, shards, wall_before + time.perf_counter() - t0)


def _check_inputs(out: Path, manifest: dict, config: DatagenConfig) -> None:
    """Refuse to resume a dataset made by other code or another gait spec, or one that does not say."""
    if "code" not in manifest or "gait_spec" not in manifest:
        raise DatasetDirError(f"{out} holds a dataset made before datasets recorded the code that made them; "
                              "use another --out (train still reads it)")
    parts = []
    if manifest["gait_spec"] != config.inputs()["gait_spec"]:
        parts.append(f"another {config.gait!r} gait spec (grid, timing or cost weights)")
    if manifest["code"] != code_identity():
        parts.append(f"other code ({', '.join(differences(manifest['code'], code_identity()))} differ)")
    version = config.inputs()["sim_version"]
    if manifest.get("sim_version", version) != version:
        parts.append(f"{config.sim} {manifest['sim_version']} (this is {version})")
    if parts:
        raise DatasetDirError(f"{out} holds a dataset made with {' and '.join(parts)}; use another --out, "
                              "or the same code to resume")


def _verified_shards(out: Path, manifest: dict) -> dict[int, dict]:
    """The manifest's shards whose file has the size and sha256 recorded when it was written. The others
    are generated again, with one warning line on stderr."""
    shards: dict[int, dict] = {}
    bad: list[str] = []
    stats_of = manifest.get("shard_stats")
    for name, stats in (stats_of.items() if isinstance(stats_of, dict) else ()):
        recorded = isinstance(stats, dict) and "bytes" in stats and "sha256" in stats
        problem = check_file(out / name, stats["bytes"], stats["sha256"]) if recorded else "no size and sha256 recorded"
        if problem is None and isinstance(stats.get("shard"), int) and shard_name(stats["shard"]) == name:
            shards[stats["shard"]] = stats
        else:
            bad.append(f"{name}: {problem or 'not a shard of this dataset'}")
    if bad:
        more = f" (and {len(bad) - 3} more)" if len(bad) > 3 else ""
        print(f"contactnet: warning: {len(bad)} shard(s) listed in {out / 'manifest.json'} are damaged, "
              f"generating them again: {'; '.join(bad[:3])}{more}", file=sys.stderr)
    return shards


def _shard_job(job: tuple[DatagenConfig, int]) -> dict:
    """A worker's part of a shard: its arrays and counts (the caller writes the file)."""
    config, shard = job
    t0 = time.perf_counter()
    u, V, episode_ids, falls = shard_arrays(config, shard)
    return {"shard": shard, "instances": len(u), "falls": falls, "seconds": time.perf_counter() - t0,
            "arrays": (u, V, episode_ids)}


def _one_torch_thread() -> None:
    """Worker processes: one torch thread each (the workers already use every core); nothing without torch (the
    extra ``train``)."""
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)


def write_sample(src_dir: str | Path, dst_dir: str | Path, n_shards: int = 2) -> dict:
    """Copy the first ``n_shards`` finished shards of a dataset into ``dst_dir`` with a manifest of their
    own: the small committed sample (``data/sample/``) that tests train on."""
    src, dst = Path(src_dir), Path(dst_dir)
    manifest = read_manifest(src)
    if manifest is None:
        raise DatasetDirError(f"{src}: no dataset manifest")
    names = sorted(manifest["shard_stats"])[:n_shards]
    if len(names) < n_shards:
        raise DatasetDirError(f"{src}: only {len(names)} finished shards")
    dst.mkdir(parents=True, exist_ok=True)
    for name in names:
        (dst / name).write_bytes((src / name).read_bytes())
    stats = {name: manifest["shard_stats"][name] for name in names}
    settings = manifest["settings"]
    sample = {
        **manifest,
        "shards": names,
        "episodes": sum(len(range(s["shard"] * settings["episodes_per_shard"],
                                   min((s["shard"] + 1) * settings["episodes_per_shard"], settings["episodes"])))
                        for s in stats.values()),
        "instances": sum(s["instances"] for s in stats.values()),
        "falls": sum(s["falls"] for s in stats.values()),
        "complete": True,
        "shard_stats": stats,
        "sample_of": {"episodes_planned": manifest["episodes_planned"], "instances": manifest["instances"]},
    }
    atomic_write_text(dst / "manifest.json", json.dumps(sample, indent=1))
    return sample
