"""The fused whisker mapper on generated worlds it has never seen (generalisation tests)."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.experiments.blackboard_world import fused_world_run
from bayesmap.sim.whisker_worlds import generate_world


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3001])
def test_fused_map_of_a_fresh_stress_world_holds_every_table_and_no_phantom(seed: int) -> None:
    """A stress world from a seed the benchmark does not use (tables by walls, close pairs,
    two sizes), whole tour, `normal` sensor: every table found, of the right type, and
    nothing else; every found table's existence probability is well above one half."""
    _, _, metrics = fused_world_run(generate_world(np.random.default_rng(seed)), "normal", seed)
    assert metrics["fused_precision"] >= 0.97
    assert metrics["fused_recall"] >= 0.97
    assert metrics["fused_wall_phantoms"] == 0
    assert metrics["type_accuracy"] >= 0.95
    assert min(metrics["fused_existence"]) > 0.5
