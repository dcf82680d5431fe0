"""Figures and animations with matplotlib, from arrays and results only.

- :mod:`~bayesmap.viz.network`: a Bayesian network's drawing and DOT text;
- :mod:`~bayesmap.viz.rover`, :mod:`~bayesmap.viz.sonar`, :mod:`~bayesmap.viz.tables`: each
  experiment's maps and figures; :mod:`~bayesmap.viz.sweeps`: a sweep report's panels.

Importing :mod:`bayesmap` or this package does not import matplotlib: names load on first use
(:mod:`bayesmap._lazy`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from bayesmap._lazy import lazy_exports

if TYPE_CHECKING:
    from bayesmap.viz import network, render, rover, sonar, sweeps, tables
    from bayesmap.viz.network import network_figure, network_image, to_dot
    from bayesmap.viz.render import figure_png
    from bayesmap.viz.rover import coverage_figure, maps_pair_figure
    from bayesmap.viz.sonar import map_png, maps_side_by_side
    from bayesmap.viz.sweeps import metrics_figure
    from bayesmap.viz.tables import annealing_gif

_EXPORTS = {
    "annealing_gif": "tables",
    "coverage_figure": "rover",
    "figure_png": "render",
    "map_png": "sonar",
    "maps_pair_figure": "rover",
    "maps_side_by_side": "sonar",
    "metrics_figure": "sweeps",
    "network": "network",
    "network_figure": "network",
    "network_image": "network",
    "render": "render",
    "rover": "rover",
    "sonar": "sonar",
    "sweeps": "sweeps",
    "tables": "tables",
    "to_dot": "network",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = [
    "annealing_gif",
    "coverage_figure",
    "figure_png",
    "map_png",
    "maps_pair_figure",
    "maps_side_by_side",
    "metrics_figure",
    "network",
    "network_figure",
    "network_image",
    "render",
    "rover",
    "sonar",
    "sweeps",
    "tables",
    "to_dot",
]
