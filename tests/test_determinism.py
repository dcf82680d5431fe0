"""The same seed gives the same numbers: every paper experiment, run twice at a tiny size.

:func:`tiny_numbers` is also how a change that must not alter behaviour is checked across
commits: ``python tests/test_determinism.py numbers.json`` writes the numbers of every
experiment (metrics without wall-clock times, and digests of every saved array), and two
such files, written before and after the change, compare equal when it kept behaviour.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bayesmap.experiments import blackboard, rover, sonar
from bayesmap.sim.sonar_log import Realism

TINY: dict[str, Any] = {
    "rover": lambda: rover.Config(max_steps=40, runs=("obstacles-flat", "empty-random")),
    "sonar": lambda: sonar.Config(
        worlds=("sonar-clutter-v2",),
        runs=1,
        pipelines=("default", "elfes", "ros"),
        resolution=0.2,
        realism=Realism(ring_rate=2.0, stops=1, people=1),
    ),
    "blackboard": lambda: blackboard.Config(
        poses=4,
        conditions=("normal", "noisy"),
        fused_mapper={"burn_in": 20, "explore": 40, "anneal": 20, "samples": 40},
    ),
}
"""Experiment name → its tiny configuration (default seed)."""

MODULES = {"rover": rover, "sonar": sonar, "blackboard": blackboard}

CLOCK_WORDS = ("seconds", "wall_s", "_ms", "time")
"""Keys holding wall-clock measurements, which differ from run to run by nature."""


def _without_clocks(value: Any) -> Any:
    if isinstance(value, dict):
        return {
            k: _without_clocks(v)
            for k, v in value.items()
            if not any(word in k for word in CLOCK_WORDS)
        }
    if isinstance(value, list):
        return [_without_clocks(v) for v in value]
    return value


def _digest(path: Path) -> dict[str, str]:
    with np.load(path) as arrays:
        return {
            name: hashlib.sha256(np.ascontiguousarray(arrays[name]).tobytes()).hexdigest()
            for name in sorted(arrays.files)
        }


def tiny_numbers(name: str, out_dir: Path) -> dict[str, Any]:
    """Every metric (clocks left out) and every saved array's digest of a tiny run of ``name``."""
    MODULES[name].run(TINY[name](), out_dir)
    numbers: dict[str, Any] = {}
    for path in sorted(out_dir.rglob("*")):
        key = path.relative_to(out_dir).as_posix()
        if path.suffix == ".json" and path.name != "manifest.json":
            # as JSON text, so that NaN compares equal to NaN
            text = json.dumps(_without_clocks(json.loads(path.read_text())), sort_keys=True)
            numbers[key] = json.loads(text)
        elif path.suffix == ".npz":
            numbers[key] = _digest(path)
    return numbers


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TINY))
def test_one_seed_gives_the_same_numbers_twice(name: str, tmp_path: Path) -> None:
    first = tiny_numbers(name, tmp_path / "first")
    again = tiny_numbers(name, tmp_path / "again")
    assert first, f"{name} wrote no metrics"
    assert json.dumps(first, sort_keys=True) == json.dumps(again, sort_keys=True)


if __name__ == "__main__":  # write the numbers of every experiment, to compare commits
    import tempfile

    with tempfile.TemporaryDirectory() as scratch:
        snapshot = {name: tiny_numbers(name, Path(scratch) / name) for name in sorted(TINY)}
    Path(sys.argv[1]).write_text(json.dumps(snapshot, sort_keys=True, indent=1))
