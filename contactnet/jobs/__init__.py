"""Batch jobs: resumable work, run by a local process pool or Ray.

- ``runner``: `Job`, `run_jobs`, the engines and the resume keys (`code_identity`);
- ``ray_engine``: the Ray engine (imported only when chosen);
- ``datagen``, ``train``: the network's dataset and training;
- ``experiment``: the paper's experiments, one resumable batch per folder; ``pushes``: the sampled-push
  protocol; ``summary``: a batch's table and plots; ``outcome``: a trial's outcome in words; ``replay``: one
  stored trial run again;
- ``paper/``: the paper's whole evaluation and its report.
"""

from __future__ import annotations

from contactnet import lazy_exports

_EXPORTS = {
    "Job": "contactnet.jobs.runner",
    "run_jobs": "contactnet.jobs.runner",
    "code_identity": "contactnet.jobs.runner",
    "ENGINES": "contactnet.jobs.runner",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
