"""Shared by the sonar tests: the data folder and its recording scripts."""

from __future__ import annotations

import importlib.util
from dataclasses import replace
from pathlib import Path
from types import ModuleType

import pytest

from bayesmap.sonar.pipeline import PIPELINES

DATA = Path(__file__).parent / "data"


def pipelines_as_recorded(monkeypatch: pytest.MonkeyPatch) -> None:
    """Give ``default`` and ``streaming`` the symmetric occupied arc they had when the golden
    maps were recorded (before ``sigma_front``), so the records still pin every other step
    of the computation bit for bit."""
    for name in ("default", "streaming"):
        monkeypatch.setitem(PIPELINES, name, replace(PIPELINES[name], sigma_front=None))


def recorder(name: str) -> ModuleType:
    """The script ``tests/sonar/data/NAME.py`` that wrote a golden record, as a module."""
    spec = importlib.util.spec_from_file_location(name, DATA / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
