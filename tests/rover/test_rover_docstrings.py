"""The runnable examples in the docstrings of the rover's sensing, grid and decision modules."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "bayesmap.sensing.ir",
    "bayesmap.sensing.fusion",
    "bayesmap.grid.entropy",
    "bayesmap.grid.occupancy",
    "bayesmap.rover.decisions",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name))
    assert result.attempted > 0
    assert result.failed == 0
