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

from bayesmap._typing import ProgressHook
from bayesmap.errors import ConfigError
from bayesmap.experiments._common import ExperimentResult, run_in_folder

EXPERIMENTS: dict[str, str] = {
    "rover": "bayesmap.experiments.rover",
    "sonar": "bayesmap.experiments.sonar",
    "blackboard": "bayesmap.experiments.blackboard",
}


def load(name: str) -> ModuleType:
    """Import the module of experiment ``name``; raise :class:`ConfigError` if unknown.

    ``name`` is a key of :data:`EXPERIMENTS` or, for an experiment outside bayesmap, the
    dotted path of an importable module exposing ``Config`` and ``run``.
    """
    known = ", ".join(EXPERIMENTS) or "none"
    if name in EXPERIMENTS:
        return importlib.import_module(EXPERIMENTS[name])
    if "." in name:
        try:
            module = importlib.import_module(name)
        except ImportError as error:
            raise ConfigError(f"cannot import experiment module {name!r}: {error}") from None
        if callable(getattr(module, "run", None)) and hasattr(module, "Config"):
            return module
        raise ConfigError(f"module {name!r} is not an experiment: it needs Config and run")
    raise ConfigError(f"unknown experiment {name!r}; choose from: {known} (or a module path)")


__all__ = ["EXPERIMENTS", "ExperimentResult", "ProgressHook", "load", "run_in_folder"]
