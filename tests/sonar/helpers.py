"""Shared by the sonar tests: the data folder and its recording scripts."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

DATA = Path(__file__).parent / "data"


def recorder(name: str) -> ModuleType:
    """The script ``tests/sonar/data/NAME.py`` that wrote a golden record, as a module."""
    spec = importlib.util.spec_from_file_location(name, DATA / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
