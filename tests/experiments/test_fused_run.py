"""The fused whisker mapper on generated worlds it has never seen (generalisation tests)."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.experiments.blackboard_world import catalogue_of
from bayesmap.experiments.fused_run import fused_metrics, fused_params, run_fused
from bayesmap.experiments.table_metrics import MatchTolerance
from bayesmap.sim.whisker_worlds import generate_world
from bayesmap.sim.whiskers import condition


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3001])
def test_fused_map_of_a_fresh_stress_world_holds_every_table_and_no_phantom(seed: int) -> None:
    """A stress world from a seed the benchmark does not use (tables by walls, close pairs,
    two sizes), whole tour, `normal` sensor: every table found, of the right type, and
    nothing else."""
    world_file = generate_world(np.random.default_rng(seed))
    world = world_file.world()
    sensor = condition("normal")
    sensor_seed, chain_seed = np.random.SeedSequence(seed).spawn(2)
    result = run_fused(
        world,
        world_file.robot_poses(),
        catalogue_of(world_file),
        sensor,
        fused_params(sensor),
        np.random.default_rng(sensor_seed),
        np.random.default_rng(chain_seed),
        label="normal",
    )
    metrics = fused_metrics(result, world, MatchTolerance(angle_scale=0.6))
    assert metrics["fused_precision"] >= 0.97
    assert metrics["fused_recall"] >= 0.97
    assert metrics["fused_wall_phantoms"] == 0
    assert metrics["type_accuracy"] >= 0.95
