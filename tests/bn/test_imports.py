"""What ``import bayesmap.bn`` and the ``bayesmap`` command load: never the heavy libraries
they do not use (issue 15, fast start). Each case runs in a fresh interpreter and lists
``sys.modules``; the start-up times themselves are measured in benchmarks/bn_startup.py."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pgmpy
import pytest

ALARM = Path(pgmpy.__file__).parent / "utils" / "example_models" / "alarm.bif.gz"

NEVER = ("scipy", "matplotlib", "pandas", "pyarrow", "dask", "PIL", "skimage", "pydantic", "yaml")
"""Loaded by no ``bayesmap bn`` command that does not draw, learn from a table or batch.

(Typer converts option values through pydantic; ``bayesmap.cli._values`` converts the plain
types the commands use without it.)"""

OTHER_GROUPS = tuple(
    f"bayesmap.cli.{name}" for name in ("blackboard", "reproduce", "rover", "sonar", "sweep")
)
"""The command groups a ``bayesmap bn`` command has no use for."""


LOADED = """
import json, sys
{code}
print(json.dumps(sorted(name for name in sys.modules)))
"""


def loaded_modules(code: str) -> set[str]:
    """The modules a fresh interpreter holds after running ``code``."""
    result = subprocess.run(
        [sys.executable, "-c", LOADED.format(code=code)],
        capture_output=True,
        text=True,
        check=True,
    )
    return set(json.loads(result.stdout.splitlines()[-1]))


def command_modules(*args: str) -> set[str]:
    """The modules loaded by ``bayesmap ARGS`` run to its end (its exit caught)."""
    code = (
        "from bayesmap.cli import main\n"
        f"sys.argv = ['bayesmap', *{list(args)!r}]\n"
        "try:\n    main()\n"
        "except SystemExit as stop:\n    assert stop.code in (0, None), stop.code\n"
    )
    return loaded_modules(code)


ENGINE = (
    "bayesmap.bn.inference",
    "bayesmap.bn.plans",
    "bayesmap.bn.elimination",
    "bayesmap.bn.numbers",
    "bayesmap.bn.fixed_point",
    "bayesmap.bn.propositions",
    "bayesmap.bn.learning",
    "bayesmap.bn.cases",
    "bayesmap.bn.soft",
    "bayesmap.bn.sampling",
)
"""The engine and each feature's module: loaded by the first question that needs them."""

DEFERRED_STDLIB = ("pathlib", "urllib.parse", "ipaddress", "heapq", "importlib.util")
"""Standard modules numpy does not load and a plain ``import bayesmap.bn`` has no use for."""

RAIN = """
from bayesmap.bn import BayesNet
net = BayesNet("rain")
net.add_variable("Rain", ["no", "yes"], cpt=[0.8, 0.2])
net.add_variable("Wet", ["no", "yes"], parents=["Rain"], cpt=[[0.9, 0.1], [0.1, 0.9]])
"""


def test_import_bayesmap_bn_loads_only_numpy_and_the_model():
    modules = loaded_modules("import bayesmap.bn")
    heavy = {*NEVER, "pydantic", "rich", "typer", "yaml", "lxml", "numpy.random", "bayesmap._io"}
    assert not heavy & modules
    assert "bayesmap.bn.model" in modules
    assert "bayesmap.bn.io" not in modules  # the file formats load on first use
    assert not {*ENGINE, *DEFERRED_STDLIB, "opt_einsum"} & modules


def test_building_a_network_loads_no_engine_and_its_first_question_loads_it():
    built = loaded_modules(RAIN)
    assert not {*ENGINE, "opt_einsum"} & built
    question = 'assert round(net.posterior("Rain", {"Wet": "yes"})["yes"], 4) == 0.6923\n'
    asked = loaded_modules(RAIN + question)
    assert {"bayesmap.bn.inference", "bayesmap.bn.plans", "bayesmap.bn.propositions"} <= asked
    # learning and tables of cases wait for their own first use; opt_einsum for a plan
    # that needs it:
    assert not {"bayesmap.bn.learning", "bayesmap.bn.cases", "pathlib"} & asked
    assert "opt_einsum.contract" not in asked


def test_lazy_exports_resolve_to_the_modules_names():
    modules = loaded_modules(
        "import bayesmap.bn as bn\n"
        "from bayesmap.bn.io import read\n"
        "from bayesmap.bn.fixed_point import QFormat\n"
        "from bayesmap.bn.propositions import V\n"
        "assert bn.read is read and bn.QFormat is QFormat and bn.V is V\n"
        "assert set(bn.__all__) <= set(dir(bn))\n"
    )
    assert "bayesmap.bn.io" in modules


def test_an_unknown_name_is_an_attribute_error():
    import bayesmap.bn as bn

    with pytest.raises(AttributeError, match="no_such_name"):
        bn.no_such_name  # noqa: B018


@pytest.mark.parametrize("args", [("--help",), ("--version",), ("bn", "--help")])
def test_the_command_line_starts_without_the_engine_or_the_experiments(args):
    modules = command_modules(*args)
    assert not {*NEVER, "bayesmap.bn", "bayesmap.experiments", "opt_einsum"} & modules
    assert not {"numpy", "rich", "typer.rich_utils", *OTHER_GROUPS} & modules
    if args[0].startswith("--"):
        assert "bayesmap.cli.bn" not in modules


def test_a_bn_question_loads_the_engine_but_no_heavy_library():
    modules = command_modules("bn", "query", str(ALARM), "-t", "HYPOVOLEMIA", "-e", "BP=LOW")
    assert "bayesmap.bn.inference" in modules
    assert not {*NEVER, "lxml", *OTHER_GROUPS} & modules


@pytest.mark.parametrize(
    "args",
    [
        ("bn", "info", str(ALARM), "--json"),
        ("bn", "query", str(ALARM), "-t", "HYPOVOLEMIA", "-e", "BP=LOW", "--json"),
    ],
)
def test_a_json_answer_loads_no_console_library(args):
    modules = command_modules(*args)
    assert not {*NEVER, "rich", *OTHER_GROUPS} & modules


@pytest.mark.parametrize("command", ["info", "convert"])
def test_describing_or_converting_a_network_loads_no_inference_engine(command, tmp_path):
    args = ("bn", "info", str(ALARM), "--json")
    if command == "convert":
        args = ("bn", "convert", str(ALARM), str(tmp_path / "alarm.xml"))
    modules = command_modules(*args)
    assert "bayesmap.bn.model" in modules
    assert not {*ENGINE, "opt_einsum"} & modules
