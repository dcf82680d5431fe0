"""Experiment sweeps on Dask, their tables and their report.

``sweeps`` sits above :mod:`bayesmap.experiments` and below the CLI: it expands a grid of
worlds × seeds × conditions into tasks (:mod:`~bayesmap.sweeps.grid`), runs each task's
``run(config)`` in this process, on a ``distributed.LocalCluster`` or on a scheduler
(:mod:`~bayesmap.sweeps.runner`), gathers the metrics the runs wrote into tidy tables with
bootstrap intervals and paired comparisons (:mod:`~bayesmap.sweeps.aggregate`) and renders
them as one self-contained HTML page (:mod:`~bayesmap.sweeps.report`). Workers receive
configs and seeds, never live objects. What an experiment may expose to be swept over
worlds is written in :mod:`~bayesmap.sweeps.protocol`.
"""

from __future__ import annotations

from bayesmap.sweeps.grid import SweepPlan, Task, expand
from bayesmap.sweeps.runner import SweepOutcome, run_sweep

__all__ = ["SweepOutcome", "SweepPlan", "Task", "expand", "run_sweep"]
