"""Every subpackage names its public API in ``__all__``, and each name resolves."""

from __future__ import annotations

import importlib
import pkgutil
import subprocess
import sys

import pytest

import bayesmap


def _packages(path: list[str], prefix: str) -> list[str]:
    """Every subpackage below ``path`` (nested ones too), by name under ``bayesmap.``."""
    found = []
    for info in pkgutil.iter_modules(path):
        if info.ispkg and not info.name.startswith("_"):
            name = prefix + info.name
            found.append(name)
            module = importlib.import_module(f"bayesmap.{name}")
            found += _packages(list(module.__path__), name + ".")
    return found


PACKAGES = tuple(_packages(list(bayesmap.__path__), ""))


@pytest.mark.parametrize("name", PACKAGES)
def test_every_exported_name_resolves(name: str) -> None:
    package = importlib.import_module(f"bayesmap.{name}")
    assert package.__all__, f"bayesmap.{name} exports nothing"
    for export in package.__all__:
        assert getattr(package, export) is not None


def test_unknown_names_are_attribute_errors() -> None:
    sim = importlib.import_module("bayesmap.sim")
    with pytest.raises(AttributeError, match="no attribute 'nowhere'"):
        _ = sim.nowhere


def test_importing_the_packages_loads_neither_matplotlib_nor_the_simulators() -> None:
    code = (
        "import sys, bayesmap, bayesmap.viz, bayesmap.sim, bayesmap.sonar, bayesmap.sensing\n"
        "loaded = [m for m in ('matplotlib', 'bayesmap.sim.whiskers', 'bayesmap.sonar.bags')"
        " if m in sys.modules]\n"
        "print(','.join(loaded))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


@pytest.mark.parametrize("name", ("sonar", "sensing", "sim", "viz"))
def test_a_lazy_package_lists_the_same_names_it_loads(name: str) -> None:
    """``__all__`` stays a literal list (ruff and mypy read it); it must name exactly the
    names the package loads on first use."""
    package = importlib.import_module(f"bayesmap.{name}")
    assert sorted(package.__all__) == dir(package)
