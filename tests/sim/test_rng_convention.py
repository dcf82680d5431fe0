"""The simulators' randomness convention (``bayesmap.sim``'s docstring): whatever draws a
whole world takes a seed or a generator and draws the same from both; per-step models take
the caller's generator."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from bayesmap.sim import (
    ir,
    polygons,
    rover,
    rover_worlds,
    sonar_worlds,
    tables_world,
    whisker_worlds,
    whiskers,
)


def _whisker_world(rng: Any) -> Any:
    return whisker_worlds.generate_world(rng).to_json()


def _sonar_world(rng: Any) -> Any:
    return sonar_worlds.to_json(sonar_worlds.generate_world(rng))


def _rover_world(rng: Any) -> Any:
    return rover_worlds.generate_world(rng, size=20.0).to_json()


def _building(rng: Any) -> Any:
    return sonar_worlds.to_json(polygons.random_building(rng))


@pytest.mark.parametrize("draw", [_whisker_world, _sonar_world, _rover_world, _building])
def test_a_world_generator_draws_the_same_from_a_seed_and_from_its_generator(
    draw: Callable[[Any], Any],
) -> None:
    seeded = draw(7)
    assert seeded == draw(np.random.default_rng(7))
    assert seeded != draw(8)


@pytest.mark.parametrize(
    "model",
    [
        ir.observe,
        rover.initial,
        rover.transition,
        rover.observe,
        tables_world.initial,
        whiskers.observe,
    ],
)
def test_a_per_step_model_takes_the_callers_generator(model: Callable[..., Any]) -> None:
    rng = inspect.signature(model).parameters["rng"]
    assert rng.kind is inspect.Parameter.KEYWORD_ONLY and rng.default is inspect.Parameter.empty
    assert rng.annotation in ("np.random.Generator", np.random.Generator)
