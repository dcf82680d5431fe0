"""A spatial hash of hypotheses for neighbour look-ups (Fox & Prescott 2011 §II-C).

"For computational efficiency it is useful to implement a spatial hash-table to look up
nearby hypotheses. This hash-table may also be reused to look up overlapping hypotheses in
the computation of φ_c." Points live in square cells of side ``cell`` [m]; a radius query
visits only the cells the disc touches. Results come in insertion order (dicts keep it), so
the sampler stays deterministic.
"""

from __future__ import annotations

import math

from bayesmap.errors import ConfigError


class SpatialHash:
    """Points ``(x, y)`` [m] keyed by integer id, in square cells of side ``cell`` [m].

    Examples
    --------
    >>> h = SpatialHash(1.0)
    >>> h.insert(7, 0.2, 0.3)
    >>> h.query(0.0, 0.0, 0.5)
    [7]
    >>> h.query(3.0, 3.0, 0.5)
    []
    """

    __slots__ = ("cell", "_cells", "_where")

    def __init__(self, cell: float) -> None:
        if not (math.isfinite(cell) and cell > 0):
            raise ConfigError(
                f"SpatialHash cell size must be a positive number of metres, got {cell}"
            )
        self.cell = cell
        self._cells: dict[tuple[int, int], dict[int, tuple[float, float]]] = {}
        self._where: dict[int, tuple[int, int]] = {}

    def _key(self, x: float, y: float) -> tuple[int, int]:
        return (math.floor(x / self.cell), math.floor(y / self.cell))

    def __len__(self) -> int:
        return len(self._where)

    def __contains__(self, key: int) -> bool:
        return key in self._where

    def insert(self, key: int, x: float, y: float) -> None:
        """Add point ``key`` at ``(x, y)``; a key already present is moved."""
        if key in self._where:
            self.remove(key)
        cell = self._key(x, y)
        self._cells.setdefault(cell, {})[key] = (x, y)
        self._where[key] = cell

    def remove(self, key: int) -> None:
        """Remove point ``key`` (a missing key raises ``KeyError``)."""
        cell = self._where.pop(key)
        bucket = self._cells[cell]
        del bucket[key]
        if not bucket:
            del self._cells[cell]

    def query(self, x: float, y: float, radius: float) -> list[int]:
        """Ids of the points within ``radius`` [m] of ``(x, y)`` (boundary included).

        The cells searched reach a hair past ``radius`` (a relative 1e-9): the distance test
        rounds, and accepts points on the boundary that lie just outside it in exact
        arithmetic, such as a point at x = −1e-68 for a disc of radius 1 about x = 1, whose
        cell is the one left of x = 0.
        """
        c = self.cell
        reach = radius * (1.0 + 1e-9) + 1e-12
        i0, i1 = math.floor((x - reach) / c), math.floor((x + reach) / c)
        j0, j1 = math.floor((y - reach) / c), math.floor((y + reach) / c)
        r2 = radius * radius
        found: list[int] = []
        cells = self._cells
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                bucket = cells.get((i, j))
                if bucket is None:
                    continue
                for key, (px, py) in bucket.items():
                    if (px - x) ** 2 + (py - y) ** 2 <= r2:
                        found.append(key)
        return found
