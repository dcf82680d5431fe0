"""The paper experiments behind ``bayesmap reproduce``.

Each experiment is one module here exposing

- ``Config``: a frozen pydantic model of every setting, with the paper's defaults;
- ``run(config, out_dir, *, progress=None, command=None) -> ExperimentResult``: runs the
  experiment, writes its figures, maps and metrics into a fresh folder that becomes
  ``out_dir`` with a ``manifest.json`` once complete (:func:`run_in_folder`), and reports
  progress through the optional :data:`ProgressHook`.

:data:`EXPERIMENTS` maps each experiment's name to its module; ``reproduce`` runs them
in this order.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from bayesmap.errors import ConfigError
from bayesmap.experiments._common import ExperimentResult, ProgressHook, run_in_folder

EXPERIMENTS: dict[str, str] = {
    "rover": "bayesmap.experiments.rover",
    "sonar": "bayesmap.experiments.sonar",
    "blackboard": "bayesmap.experiments.blackboard",
}


def load(name: str) -> ModuleType:
    """Import the module of experiment ``name``; raise :class:`ConfigError` if unknown."""
    if name not in EXPERIMENTS:
        known = ", ".join(EXPERIMENTS) or "none"
        raise ConfigError(f"unknown experiment {name!r}; choose from: {known}")
    return importlib.import_module(EXPERIMENTS[name])


__all__ = ["EXPERIMENTS", "ExperimentResult", "ProgressHook", "load", "run_in_folder"]
