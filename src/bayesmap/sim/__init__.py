"""The world's truth and simulated robots and sensors.

Every world is registered under a versioned name in :mod:`~bayesmap.sim.scenarios`
(:func:`scenario` looks one up). Every simulator has the functional shape
``h(world, pose, params)`` (noiseless) beside ``observe(world, pose, params, *, rng)``
(noisy); reach those through their modules.

Randomness: a function that draws a whole world or a whole log (``generate_world``,
``random_building``, ``simulate_log``, the sonar's ``observe`` over a trajectory) is an
entry point and takes ``rng`` as a seed or a generator (:mod:`bayesmap._rng`). A per-step
model (``initial``, ``transition``, the one-pose ``observe`` of the rover, its IR rangers
and the whiskers) is a building block of the caller's loop and takes the loop's
``numpy.random.Generator``, so that a seed cannot silently repeat the same noise at every
step.

The modules:

- :mod:`~bayesmap.sim.world2d`, :mod:`~bayesmap.sim.rover`, :mod:`~bayesmap.sim.ir`: the
  micro-rover with IR rangers among boxes (Post et al. 2016); :mod:`~bayesmap.sim.rover_worlds`:
  its world files;
- :mod:`~bayesmap.sim.polygons`, :mod:`~bayesmap.sim.sonar`, :mod:`~bayesmap.sim.sonar_log`:
  a sonar ring in polygon buildings;
- :mod:`~bayesmap.sim.tables_world`, :mod:`~bayesmap.sim.whiskers`,
  :mod:`~bayesmap.sim.whisker_worlds`: whiskers among tables (Fox & Prescott 2011).

Names load on first use (:mod:`bayesmap._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from bayesmap._lazy import lazy_exports

if TYPE_CHECKING:
    from bayesmap.sim import (
        ir,
        polygons,
        rover,
        rover_worlds,
        scenarios,
        sonar,
        sonar_log,
        tables_world,
        whisker_worlds,
        whiskers,
        world2d,
    )
    from bayesmap.sim.ir import IRRangers
    from bayesmap.sim.polygons import PolygonWorld
    from bayesmap.sim.rover import RoverState, SimulatedRoverParams
    from bayesmap.sim.scenarios import scenario
    from bayesmap.sim.sonar import EchoKind, SonarRing, SonarScan
    from bayesmap.sim.sonar_log import Realism, SimulatedLog, simulate_log
    from bayesmap.sim.tables_world import TablesWorld, WorldParams
    from bayesmap.sim.whiskers import WhiskerParams, WhiskerReading
    from bayesmap.sim.world2d import BoxWorld, box_world

_EXPORTS = {
    "BoxWorld": "world2d",
    "EchoKind": "sonar",
    "IRRangers": "ir",
    "PolygonWorld": "polygons",
    "Realism": "sonar_log",
    "RoverState": "rover",
    "SimulatedLog": "sonar_log",
    "SimulatedRoverParams": "rover",
    "SonarRing": "sonar",
    "SonarScan": "sonar",
    "TablesWorld": "tables_world",
    "WhiskerParams": "whiskers",
    "WhiskerReading": "whiskers",
    "WorldParams": "tables_world",
    "box_world": "world2d",
    "ir": "ir",
    "polygons": "polygons",
    "rover": "rover",
    "rover_worlds": "rover_worlds",
    "scenario": "scenarios",
    "scenarios": "scenarios",
    "simulate_log": "sonar_log",
    "sonar": "sonar",
    "sonar_log": "sonar_log",
    "tables_world": "tables_world",
    "whisker_worlds": "whisker_worlds",
    "whiskers": "whiskers",
    "world2d": "world2d",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = [
    "BoxWorld",
    "EchoKind",
    "IRRangers",
    "PolygonWorld",
    "Realism",
    "RoverState",
    "SimulatedLog",
    "SimulatedRoverParams",
    "SonarRing",
    "SonarScan",
    "TablesWorld",
    "WhiskerParams",
    "WhiskerReading",
    "WorldParams",
    "box_world",
    "ir",
    "polygons",
    "rover",
    "rover_worlds",
    "scenario",
    "scenarios",
    "simulate_log",
    "sonar",
    "sonar_log",
    "tables_world",
    "whisker_worlds",
    "whiskers",
    "world2d",
]
