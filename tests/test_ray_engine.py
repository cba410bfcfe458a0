"""The ``ray`` engine of the job runner (`--engine ray`, contactnet/jobs/ray_engine.py) on a real local Ray: every
missing job runs once and its result reaches its own key whatever the completion order, done keys are
skipped, worker_init runs in the Ray workers, a job's error comes back as itself, workers running other code
refuse; the same experiment summary and the same dataset as the local engine (slow: real PyBullet trials);
Ctrl-C keeps what was stored; without Ray, one line saying how to install it."""

from __future__ import annotations

import functools
import json
import operator
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from helpers import default_sigint

from contactnet.cli import EXIT_USER_ERROR, main
from contactnet.jobs.ray_engine import EngineUnavailable, ray_engine, session
from contactnet.jobs.runner import ENGINES, Job, run_jobs

#: Per-trial fields that are timings (they differ between any two runs); everything else must match.
TIMINGS = ("wall_time_s", "planner_ms", "trajopt_ms", "planner_ms_median", "planner_ms_mean", "planner_ms_samples",
           "trajopt_ms_samples", "trial_wall_s")


@pytest.fixture(scope="module")
def local_ray():
    """One local Ray of 2 CPUs for the module (started as the engine starts it): the engine uses a Ray
    already initialised and leaves it running, so Ray starts once here, not once per batch."""
    with session(workers=2) as ray:
        assert ray.get_runtime_context().gcs_address.startswith("127.0.0.1:")  # loopback only
        yield ray
    assert not ray.is_initialized()


def _shell(script: str) -> list[str]:
    return ["sh", "-c", script]


def test_jobs_reach_their_keys_in_completion_order_and_done_keys_are_skipped(local_ray, tmp_path):
    # Job 0 waits for the file job 3 writes (at most 300 s: a loaded machine can be slow to start Ray workers), then
    # 3 s more, so it finishes after job 3 on any machine (without the pause both could be ready at the same poll of
    # the engine, which then hands them over in submission order: 0 first, seen once under load).
    marker, ran = tmp_path / "three", tmp_path / "ran"
    jobs = [Job(0, _shell(f"for i in $(seq 3000); do [ -e {marker} ] && break; sleep 0.1; done; sleep 3; echo 0"))]
    jobs += [Job(k, _shell(f"touch {ran}{k}; echo {k}")) for k in (1, 2, 4)]
    jobs.insert(3, Job(3, _shell(f"touch {marker}; echo 3")))
    seen = []
    count = run_jobs(jobs, subprocess.check_output, lambda job, out: seen.append((job.key, out)), done={2},
                     workers=2, engine="ray", progress=False)
    assert count == 4 and dict(seen) == {0: b"0\n", 1: b"1\n", 3: b"3\n", 4: b"4\n"}
    order = [key for key, _ in seen]
    assert order.index(3) < order.index(0) and len(order) == 4
    assert not (tmp_path / "ran2").exists() and (tmp_path / "ran1").exists()
    assert "ray" in ENGINES and "local" in ENGINES


def test_worker_init_runs_in_the_ray_workers(local_ray):
    init = functools.partial(sys.setrecursionlimit, 4321)
    seen = {}
    run_jobs([Job(k, sys.getrecursionlimit) for k in range(3)], operator.call,
             lambda job, value: seen.setdefault(job.key, value), workers=2, engine="ray", worker_init=init,
             progress=False)
    assert seen == {0: 4321, 1: 4321, 2: 4321} and sys.getrecursionlimit() != 4321


def test_a_job_error_comes_back_as_itself_and_keeps_the_results_before_it(local_ray):
    seen = []
    with pytest.raises(ValueError, match="could not convert") as caught:
        run_jobs([Job(1, "1.5"), Job(2, "nan?"), Job(3, "3")], float, lambda job, r: seen.append(r),
                 workers=1, engine="ray", progress=False)
    assert seen == [1.5] and isinstance(caught.value.__cause__, local_ray.exceptions.RayTaskError)


def test_workers_running_other_code_refuse(local_ray):
    # The identity differs between this process and any worker (its pid): as if a node had other code.
    with pytest.raises(EngineUnavailable, match="runs other code than this process"):
        list(ray_engine(abs, [1.0], 1, None, identity=os.getpid))


def test_without_ray_one_line_says_how_to_install_it(tmp_path, monkeypatch, capsys):
    out = tmp_path / "e"
    assert main(["experiment", "push", "--out", str(out), "--address", "127.0.0.1:1"]) == EXIT_USER_ERROR
    needs_ray = "contactnet: error: --address 127.0.0.1:1: a cluster address needs --engine ray"
    assert capsys.readouterr().err.strip() == needs_ray
    monkeypatch.setitem(sys.modules, "ray", None)  # what `import ray` does where Ray is not installed
    for command in (["experiment", "push"], ["datagen", "--gait", "walk"]):
        assert main([*command, "--engine", "ray", "--out", str(out)]) == EXIT_USER_ERROR
        assert capsys.readouterr().err.strip() == \
            "contactnet: error: --engine ray needs Ray: pip install contactnet[ray]"
    assert not out.exists()


def _without_timings(value):
    if isinstance(value, dict):
        return {k: _without_timings(v) for k, v in value.items() if k not in TIMINGS}
    if isinstance(value, list):
        return [_without_timings(v) for v in value]
    return value


@pytest.mark.slow
def test_an_experiment_on_ray_gives_the_summary_and_trials_of_the_local_engine(local_ray, tmp_path):
    from contactnet.jobs.experiment import Trial, run_experiment

    # Short push trials (pushed at 0.2 s, 4 s to settle): two stand their push (one with joint noise, so the
    # seed matters), one falls.
    push = functools.partial(Trial, "push", "push_field", None, gait="walk", planner="contactnet",
                             push_t0_s=0.2)
    trials = [push(0, push_force_xy=(0.5, 0.0)), push(1, noise=0.01, push_force_xy=(0.0, -1.0)),
              push(2, push_force_xy=(0.0, 150.0))]
    local = run_experiment("push", tmp_path / "local", trials, workers=1, progress=False)  # default engine
    ray = run_experiment("push", tmp_path / "ray", trials, workers=2, progress=False, engine="ray")
    assert _without_timings(ray["rows"]) == _without_timings(local["rows"])

    def records(folder):
        lines = (tmp_path / folder / "trials.jsonl").read_text().splitlines()
        return {record["key"]: _without_timings(record) for record in map(json.loads, lines)}

    assert records("ray") == records("local") and len(records("ray")) == 3
    assert sorted(r["success"] for r in records("ray").values()) == [False, True, True]


@pytest.mark.slow
def test_datagen_on_ray_writes_the_local_engine_dataset_and_resumes(local_ray, tmp_path):
    from contactnet.jobs.datagen import DatagenConfig, generate, shard_name

    config = DatagenConfig(gait="walk", episodes=2, instances_per_episode=3, episodes_per_shard=1, seed=5)
    generate(tmp_path / "local", config, workers=1, progress=False)
    manifest = generate(tmp_path / "ray", config, workers=2, progress=False, engine="ray")
    assert manifest["complete"] and manifest["shards"] == [shard_name(0), shard_name(1)]

    def arrays(folder, shard):
        with np.load(tmp_path / folder / shard_name(shard)) as data:
            return {key: data[key].copy() for key in data.files}

    for shard in (0, 1):
        local, ray = arrays("local", shard), arrays("ray", shard)
        assert local.keys() == ray.keys() and all(np.array_equal(local[k], ray[k]) for k in local)
    # Resume on Ray: only the lost shard is made again, the same.
    kept = (tmp_path / "ray" / shard_name(0)).stat().st_mtime_ns
    (tmp_path / "ray" / shard_name(1)).unlink()
    assert generate(tmp_path / "ray", config, workers=2, progress=False, engine="ray")["complete"]
    assert (tmp_path / "ray" / shard_name(0)).stat().st_mtime_ns == kept
    assert all(np.array_equal(v, arrays("local", 1)[k]) for k, v in arrays("ray", 1).items())


SCRIPT = """
import sys, time
from contactnet.jobs.runner import Job, run_jobs

jobs = [Job(i, 0.05 if i < 2 else 60.0) for i in range(6)]
try:
    run_jobs(jobs, time.sleep, lambda job, r: print("done", job.key, flush=True), workers=2, progress=False,
             engine="ray")
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(130)
"""


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="process groups and SIGINT")
def test_ctrl_c_stops_the_ray_tasks_and_keeps_what_was_stored():
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    process = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True, preexec_fn=default_sigint, env=env)
    lines = []
    deadline = time.monotonic() + 120
    while len(lines) < 2 and time.monotonic() < deadline:
        line = process.stdout.readline()
        assert line, process.communicate()
        lines.append(line.strip())
    assert sorted(lines) == ["done 0", "done 1"]
    time.sleep(0.5)  # both workers are in their 60 s jobs
    os.killpg(process.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group, Ray's processes included
    out, err = process.communicate(timeout=60)  # long before the 60 s jobs would end
    assert process.returncode == 130 and out.strip() == "interrupted", (out, err)
    assert "Traceback" not in err, err
