"""Specular-reading rejection for sonar rings (ICINCO 2007 fragment, SciTePress 16519, p. 494).

- :mod:`~bayesmap.sonar.bottom_up`: Acceptability and Agreeability;
- :mod:`~bayesmap.sonar.traits`, :mod:`~bayesmap.sonar.verification`: traits, Trait Verification;
- :mod:`~bayesmap.sonar.filter`: :class:`SpecularFilter`, the three stages as one stateful object;
- :mod:`~bayesmap.sonar.mapping`: grid mappers (eq. 1 cone model, Thrun ±0.4, ROS range layer);
- :mod:`~bayesmap.sonar.map_verdict`: the map's verdict on each reading after the pass;
- :mod:`~bayesmap.sonar.logs`: real plain-text logs; :mod:`~bayesmap.sonar.player`: Player logs;
  :mod:`~bayesmap.sonar.carmen`: CARMEN logs; :mod:`~bayesmap.sonar.pipeline`: log → map.

See docs/sonar.md for every choice that fills the fragment's gaps.

Names load on first use (:mod:`bayesmap._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from bayesmap._lazy import lazy_exports

if TYPE_CHECKING:
    from bayesmap.sonar import (
        bags,
        bottom_up,
        carmen,
        filter,
        geometry,
        logs,
        map_verdict,
        mapping,
        pipeline,
        player,
        ring,
        traits,
        verification,
    )
    from bayesmap.sonar.bags import read_sonar_bag
    from bayesmap.sonar.bottom_up import acceptability, agreeability
    from bayesmap.sonar.carmen import read_carmen_log
    from bayesmap.sonar.filter import Rejection, RingVerdict, SpecularFilter
    from bayesmap.sonar.geometry import SonarGeometry
    from bayesmap.sonar.logs import RingLog, SonarLog, read_sonar_log, write_sonar_log
    from bayesmap.sonar.map_verdict import MapVerdict
    from bayesmap.sonar.mapping import ElfesMapper, NoEcho, RosRangeLayerMapper, ThrunMapper
    from bayesmap.sonar.pipeline import DEFAULT_PIPELINE, PIPELINES, Pipeline, build_map, map_log
    from bayesmap.sonar.player import read_player_log
    from bayesmap.sonar.ring import load_ring, preset
    from bayesmap.sonar.traits import fit_traits

_EXPORTS = {
    "DEFAULT_PIPELINE": "pipeline",
    "ElfesMapper": "mapping",
    "MapVerdict": "map_verdict",
    "NoEcho": "mapping",
    "PIPELINES": "pipeline",
    "Pipeline": "pipeline",
    "Rejection": "filter",
    "RingLog": "logs",
    "RingVerdict": "filter",
    "RosRangeLayerMapper": "mapping",
    "SonarGeometry": "geometry",
    "SonarLog": "logs",
    "SpecularFilter": "filter",
    "ThrunMapper": "mapping",
    "acceptability": "bottom_up",
    "agreeability": "bottom_up",
    "bags": "bags",
    "bottom_up": "bottom_up",
    "build_map": "pipeline",
    "carmen": "carmen",
    "filter": "filter",
    "fit_traits": "traits",
    "geometry": "geometry",
    "load_ring": "ring",
    "logs": "logs",
    "map_log": "pipeline",
    "map_verdict": "map_verdict",
    "mapping": "mapping",
    "pipeline": "pipeline",
    "player": "player",
    "preset": "ring",
    "read_carmen_log": "carmen",
    "read_player_log": "player",
    "read_sonar_bag": "bags",
    "read_sonar_log": "logs",
    "ring": "ring",
    "traits": "traits",
    "verification": "verification",
    "write_sonar_log": "logs",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = [
    "DEFAULT_PIPELINE",
    "ElfesMapper",
    "MapVerdict",
    "NoEcho",
    "PIPELINES",
    "Pipeline",
    "Rejection",
    "RingLog",
    "RingVerdict",
    "RosRangeLayerMapper",
    "SonarGeometry",
    "SonarLog",
    "SpecularFilter",
    "ThrunMapper",
    "acceptability",
    "agreeability",
    "bags",
    "bottom_up",
    "build_map",
    "carmen",
    "filter",
    "fit_traits",
    "geometry",
    "load_ring",
    "logs",
    "map_log",
    "map_verdict",
    "mapping",
    "pipeline",
    "player",
    "preset",
    "read_carmen_log",
    "read_player_log",
    "read_sonar_bag",
    "read_sonar_log",
    "ring",
    "traits",
    "verification",
    "write_sonar_log",
]
