"""The one registry of simulated worlds: every kind under versioned names, typed lookups."""

from __future__ import annotations

import pytest

from bayesmap.errors import ConfigError
from bayesmap.sim.polygons import PolygonWorld, world
from bayesmap.sim.scenarios import SCENARIOS, names, register, scenario
from bayesmap.sim.tables_world import WorldParams
from bayesmap.sim.world2d import BoxWorld, box_world


def test_every_world_kind_is_in_the_one_registry_under_a_versioned_name() -> None:
    for kind in (BoxWorld, PolygonWorld, WorldParams):
        assert names(kind), kind
    assert set(SCENARIOS) == set(names(BoxWorld) + names(PolygonWorld) + names(WorldParams))
    assert all(name.rsplit("-", 1)[1].startswith("v") for name in SCENARIOS)


def test_lookups_give_the_registered_worlds_and_check_their_kind() -> None:
    assert scenario("rover-field-obstacles-v1", BoxWorld) is box_world("rover-field-obstacles-v1")
    assert scenario("sonar-room-v1", PolygonWorld).name == world("sonar-room-v1").name
    assert scenario("whisker-tables-v1", WorldParams) == WorldParams()
    with pytest.raises(ConfigError, match="unknown BoxWorld scenario 'sonar-room-v1'.*rover-field"):
        scenario("sonar-room-v1", BoxWorld)


def test_a_name_is_registered_once() -> None:
    with pytest.raises(ConfigError, match="registered twice"):
        register("sonar-room-v1", PolygonWorld, lambda: world("sonar-room-v1"))
