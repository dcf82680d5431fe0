"""The explorer with its decision network run through generated C: the same headings."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from bayesmap._rng import spawn
from bayesmap.experiments.rover import Config
from bayesmap.grid import OccupancyGrid
from bayesmap.rover.explorer import Explorer
from bayesmap.rover.native import compiled_evaluator
from bayesmap.rover.targets import EntropyTarget
from bayesmap.sim import rover as sim_rover
from bayesmap.sim.world2d import BoxWorld, box_world

pytestmark = pytest.mark.skipif(
    shutil.which("cc") is None and shutil.which("gcc") is None,
    reason="no C compiler (cc or gcc) on PATH",
)


def random_field(seed: int) -> BoxWorld:
    """A field of random boxes (a world the rover was never tuned on)."""
    rng = np.random.default_rng(seed)
    width, height = rng.uniform(8.0, 14.0, size=2)
    corners = rng.uniform([2.0, 2.0], [width - 2.0, height - 2.0], size=(5, 2))
    sizes = rng.uniform(0.4, 1.2, size=(5, 2))
    return BoxWorld(f"random-field-{seed}", width, height, np.hstack([corners, corners + sizes]))


def lockstep(world: BoxWorld, max_steps: int, seed: int, tmp_path) -> int:
    """Drive one simulated run; the engine and the C explorer see the same observations and
    must choose the same heading and command every cycle. Returns the cycles run."""
    config = Config(seed=seed, max_steps=max_steps)
    params, sim_params = config.rover_params(), config.sim_params()
    _, sensor_rng, drive_rng = spawn(seed, 3)
    explorers = [
        Explorer(
            OccupancyGrid(world.width, world.height, config.resolution, prior=config.prior),
            params,
            EntropyTarget(params),
            evaluator,
        )
        for evaluator in (None, compiled_evaluator(params, "double", tmp_path, flags=("-O0",)))
    ]
    state = sim_rover.initial(config.start, sim_params, rng=drive_rng)
    for step in range(max_steps):
        observation = sim_rover.observe(world, state, sim_params, rng=sensor_rng)
        engine, native = (e.step(observation.raw, observation.pose) for e in explorers)
        assert native.heading == engine.heading, f"cycle {step}"
        assert native.command == engine.command, f"cycle {step}"
        np.testing.assert_allclose(native.p_move, engine.p_move, rtol=0, atol=1e-12)
        if explorers[0].done or engine.target is None:
            return step + 1
        state = sim_rover.transition(state, engine.command, sim_params, rng=drive_rng)
    return max_steps


def test_generated_code_steers_like_the_engine_on_a_random_field(tmp_path):
    assert lockstep(random_field(5), 60, seed=5, tmp_path=tmp_path) > 0


@pytest.mark.slow
def test_a_full_run_with_generated_code_takes_the_engines_headings(tmp_path):
    cycles = lockstep(box_world("rover-field-obstacles-v1"), 5000, seed=2016, tmp_path=tmp_path)
    assert cycles > 100
