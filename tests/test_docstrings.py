"""Every runnable example in bayesmap's docstrings gives what it shows (DESIGN convention 11)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import bayesmap

MODULES = sorted(m.name for m in pkgutil.walk_packages(bayesmap.__path__, "bayesmap."))


def test_the_walk_finds_the_packages() -> None:
    for name in ("bayesmap.bn.model", "bayesmap.blackboard.mapper", "bayesmap.sonar.traits"):
        assert name in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(
        importlib.import_module(name),
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
        report=True,
    )
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
