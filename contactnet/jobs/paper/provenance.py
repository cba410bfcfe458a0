"""What a result was made with: the code's version and the machine."""

from __future__ import annotations

import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path
from typing import Any

#: Packages whose versions the report names (the results' own and the tools').
PACKAGES = ("numpy", "torch", "pybullet", "pin", "example-robot-data", "casadi", "matplotlib", "tqdm", "ray")


def _git(root: Path, *args: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    if done.returncode != 0:
        return None
    return done.stdout.strip() or None


def code_version() -> dict[str, Any]:
    """``git describe`` and the commit of the checkout the package runs from (None when it is not a git
    checkout), the package version and the digest of its sources (`contactnet.jobs.runner.sources_digest`)."""
    import contactnet
    from contactnet.jobs.runner import sources_digest

    root = Path(contactnet.__file__).resolve().parent.parent
    return {"git_describe": _git(root, "describe", "--always", "--dirty", "--tags"),
            "git_commit": _git(root, "rev-parse", "HEAD"),
            "contactnet": contactnet.__version__, "sources": sources_digest()}


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _memory_gb() -> float | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return round(int(line.split()[1]) / 2**20, 1)
    except (OSError, ValueError, IndexError):
        pass
    return None


def machine() -> dict[str, Any]:
    """The CPU, its cores (all, and those this process may use), memory, OS, Python and package versions."""
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {"cpu": _cpu_model(), "cores": os.cpu_count(), "usable_cores": usable, "memory_gb": _memory_gb(),
            "os": platform.platform(), "python": platform.python_version(), "packages": versions}
