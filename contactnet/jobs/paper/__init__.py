"""The paper's whole evaluation (Sec. IV) in one resumable command, and its report.

- `plan`: the sections (one `contactnet.jobs.experiment` batch each) and their trials at a scale;
- `run`: ``contactnet experiment paper --out DIR`` runs every section's missing trials in one job run;
- `results`, `report`, `plots`: ``DIR/report.md`` and the self-contained ``DIR/report.html`` from the stored
  trials (``contactnet report DIR``), each result beside the paper's numbers;
- `frontier`: the report's section beyond the paper (``contactnet experiment frontier`` runs it alone); `markdown`:
  the report's tables and the text being written, shared by `report` and `frontier`;
- `stats` (Wilson intervals, the difference of two rates), `provenance` (code version, machine), `layout`
  (``DIR/paper.json``).

Only the plan decides a trial's result, and the plan is in each trial's settings: this package is left out of
the code part of the trials' resume keys (`contactnet.jobs.runner.sources_digest`), so changing the report keeps the
trials.
"""
