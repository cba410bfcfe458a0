"""The resumable job runner: skips the done keys, reports every result once (in this process or from a spawn
pool), keeps finished results when a job fails, and stops cleanly on a real Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import default_sigint

from contactnet.jobs.runner import ENGINES, Job, run_jobs


def test_in_process_runs_the_missing_jobs_in_order():
    seen = []
    ran = run_jobs([Job(k, k * 10) for k in "abcd"], str.upper, lambda job, r: seen.append((job.key, r)),
                   done={"b"}, workers=1, progress=False)
    assert ran == 3 and seen == [("a", "A" * 10), ("c", "C" * 10), ("d", "D" * 10)]
    assert run_jobs([Job("a", "x")], str.upper, lambda job, r: seen.append(r), done=["a"], progress=False) == 0
    assert len(seen) == 3


def test_a_pool_reports_every_result_once():
    seen = {}
    jobs = [Job(i, float(i), size=2) for i in range(7)]
    ran = run_jobs(jobs, abs, lambda job, r: seen.setdefault(job.key, r), done={0, 3}, workers=3, progress=False)
    assert ran == 5 and seen == {i: float(i) for i in (1, 2, 4, 5, 6)}


def test_errors_keep_finished_results_and_bad_calls_are_refused():
    seen = []
    with pytest.raises(ValueError, match="could not convert"):
        run_jobs([Job(1, "1.5"), Job(2, "nan?"), Job(3, "3")], float, lambda job, r: seen.append(r), workers=1,
                 progress=False)
    assert seen == [1.5]
    with pytest.raises(ValueError, match="unique"):
        run_jobs([Job(1, "1"), Job(1, "2")], float, lambda job, r: None, progress=False)
    with pytest.raises(ValueError, match="unknown job engine 'moon'"):
        run_jobs([Job(1, "1")], float, lambda job, r: None, engine="moon", progress=False)
    assert ENGINES == ("local", "ray")


SCRIPT = """
import sys, time
from contactnet.jobs.runner import Job, run_jobs

jobs = [Job(i, 0.05 if i < 2 else 60.0) for i in range(6)]
try:
    run_jobs(jobs, time.sleep, lambda job, r: print("done", job.key, flush=True), workers=2, progress=False)
except KeyboardInterrupt:
    print("interrupted", flush=True)
    sys.exit(130)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="process groups and SIGINT")
def test_ctrl_c_stops_the_pool_at_once_without_worker_tracebacks():
    process = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, start_new_session=True, preexec_fn=default_sigint)
    lines = []
    deadline = time.monotonic() + 60
    while len(lines) < 2 and time.monotonic() < deadline:
        line = process.stdout.readline()
        assert line, process.communicate()
        lines.append(line.strip())
    assert sorted(lines) == ["done 0", "done 1"]
    time.sleep(0.5)  # both workers are in their 60 s jobs
    start = time.monotonic()
    os.killpg(process.pid, signal.SIGINT)  # Ctrl-C reaches the whole process group, workers included
    out, err = process.communicate(timeout=30)
    assert process.returncode == 130 and out.strip() == "interrupted", (out, err)
    assert time.monotonic() - start < 20 and "Traceback" not in err, err


def test_resume_key_helpers(tmp_path):
    import ast

    from contactnet.jobs import runner as jobs
    a = "def f(x):\n    '''doc'''\n    return x + 1  # note\n"
    b = "def f(x):\n    '''other words'''\n\n    return x + 1\n"
    c = "def f(x):\n    return x + 2\n"
    dump = [ast.dump(jobs._without_docstrings(ast.parse(s))) for s in (a, b, c)]
    assert dump[0] == dump[1] != dump[2]  # comments, docstrings and layout do not change the code's digest
    identity = jobs.code_identity()
    assert identity["sources"] == jobs.sources_digest() and len(identity["sources"]) == 64
    assert set(identity["packages"]) == set(jobs.RESULT_PACKAGES) and identity["packages"]["torch"]
    # every part left out of the digest exists (the command line became a package once, and "cli.py" left it in)
    import contactnet

    root = Path(contactnet.__file__).resolve().parent
    for excluded in jobs._NOT_RESULT_SOURCES:
        assert (root / excluded.rstrip("/")).exists(), f"{excluded} is not a part of the package"
    assert jobs.digest({"b": 1, "a": [1.5]}) == jobs.digest({"a": [1.5], "b": 1}) != jobs.digest({"a": [1.5]})
    assert jobs.differences({"a": 1, "b": 2}, {"a": 1, "b": 3, "c": 0}) == ["b", "c"]
    path = tmp_path / "f.bin"
    path.write_bytes(b"hello")
    size, sha = 5, jobs.file_sha256(path)
    assert jobs.check_file(path, size, sha) is None and jobs.check_file(path, None, None) is None
    assert jobs.check_file(tmp_path / "none", size, sha) == "missing"
    path.write_bytes(b"hell")
    assert jobs.check_file(path, size, sha) == "4 bytes where 5 were written (truncated)"
    path.write_bytes(b"jello")
    assert jobs.check_file(path, size, sha).endswith("was written (changed)")
