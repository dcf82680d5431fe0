"""Occupancy grids: probability + entropy layers, local-window updates, ROS map export.

- :class:`OccupancyGrid` holds the layers, the world/cell transforms and ``.npz`` I/O;
- :mod:`bayesmap.grid.ros` writes and reads ROS map_server YAML + PGM;
- :func:`binary_entropy_bits` is the Bernoulli entropy of eq. 37 of Post et al. 2016 in bits.
"""

from bayesmap.grid import ros
from bayesmap.grid.entropy import binary_entropy_bits
from bayesmap.grid.occupancy import OccupancyGrid, Window

__all__ = ["OccupancyGrid", "Window", "binary_entropy_bits", "ros"]
