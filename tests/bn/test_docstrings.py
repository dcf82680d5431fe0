"""The runnable examples in the engine's docstrings."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "bayesmap.bn",
    "bayesmap.bn.model",
    "bayesmap.bn.forms",
    "bayesmap.bn.fixed_point",
    "bayesmap.bn.naive_bayes",
    "bayesmap.bn.propositions",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name))
    assert result.failed == 0
