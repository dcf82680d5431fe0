"""The fused mapper's evidence store: every whisker sweep, indexed by where it was made.

A sweep (see :mod:`~bayesmap.blackboard.sweep_model`) is kept as a row ``root x, root y,
start, stop, length, r̂, φ̂, τ̂`` (r̂, φ̂, τ̂ NaN when it touched nothing) with a count. A
uniform grid over the roots answers "sweeps whose root lies within a radius of a point",
so one pose's work touches only the evidence around the robot.

Bounded memory: sweeps made from the same root (to 1 cm) between the same angles (to
0.01 rad) with the same outcome share one row and a count. A robot that stays in place adds
counts, not rows, so the store grows with the area explored and the distinct views of it,
not with time. Merged contacts keep the mean range and the circular mean normal; for the
Gaussian part of the sweep likelihood n readings with mean m carry the same information
about the surface as m read n times (Σ (z_i − μ)² = n (m − μ)² + const), which is what the
count-weighted likelihood uses (exact without the clutter term, an approximation with it).
"""

from __future__ import annotations

import math

import numpy as np

from bayesmap._typing import FloatArray, IntArray
from bayesmap.errors import InputError

__all__ = ["EvidenceStore", "SWEEP_FIELDS", "check_sweeps"]

SWEEP_FIELDS = ("start", "stop", "length", "range", "normal", "texture")
"""Columns of the sweeps a mapper step takes: start and stop world angles [rad], whisker
length [m], reported range r̂ [m], normal φ̂ [rad], texture τ̂ (last three NaN: no contact)."""

_ROOT_QUANTUM = 0.01
_ANGLE_QUANTUM = 0.01


def check_sweeps(pose: FloatArray, sweeps: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Validate one pose ``(3,)`` and its sweeps ``(w, 6)`` (columns :data:`SWEEP_FIELDS`).

    Raises
    ------
    InputError
        Naming the bad row and column: wrong shapes, non-finite angles or lengths, a
        negative range, or a contact with a missing normal.
    """
    pose = np.asarray(pose, dtype=np.float64)
    if pose.shape != (3,) or not np.isfinite(pose).all():
        raise InputError(f"pose must be a finite (3,) array x, y, heading; got {pose!r}")
    array = np.asarray(sweeps, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != len(SWEEP_FIELDS):
        raise InputError(
            f"sweeps must be a (w, {len(SWEEP_FIELDS)}) array of {', '.join(SWEEP_FIELDS)} rows, "
            f"got shape {array.shape}"
        )
    for column in range(3):
        bad = ~np.isfinite(array[:, column])
        if bad.any():
            raise InputError(
                f"sweeps row {int(np.flatnonzero(bad)[0])}: {SWEEP_FIELDS[column]} must be finite"
            )
    if (array[:, 2] <= 0).any():
        raise InputError(
            f"sweeps row {int(np.flatnonzero(array[:, 2] <= 0)[0])}: length must be > 0"
        )
    hit = np.isfinite(array[:, 3])
    bad = hit & ((array[:, 3] < 0) | ~np.isfinite(array[:, 4]))
    if bad.any():
        raise InputError(
            f"sweeps row {int(np.flatnonzero(bad)[0])}: a contact needs a range >= 0 [m] and a "
            "finite normal [rad]"
        )
    return pose, array


class EvidenceStore:
    """Every sweep seen so far, merged by view, with a grid index over the roots.

    Parameters
    ----------
    cell
        Side of the index's grid cells [m] (about one whisker length).

    Attributes
    ----------
    rows_
        ``(m, 8)`` stored sweeps ``root x, root y, start, stop, length, r̂, φ̂, τ̂``.
    counts_
        ``(m,)`` how many sweeps each row stands for.
    version_
        How many times :meth:`add` has run: caches of terms computed from the store hold
        while it is unchanged.
    """

    def __init__(self, cell: float = 1.0) -> None:
        if not cell > 0:
            raise InputError(f"EvidenceStore cell must be > 0 [m], got {cell}")
        self.cell = cell
        self._rows = np.zeros((64, 8))
        self._counts = np.zeros(64)
        self._normal_sum = np.zeros((64, 2))
        self._points = np.zeros((64, 2))
        self._size = 0
        self.version_ = 0
        self._keys: dict[tuple[int, int, int, int, bool], int] = {}
        self._grid = _CellIndex()
        self._contact_grid = _CellIndex()

    @property
    def rows_(self) -> FloatArray:
        return self._rows[: self._size]

    @property
    def counts_(self) -> FloatArray:
        return self._counts[: self._size]

    @property
    def points_(self) -> FloatArray:
        """``(m, 2)`` contact points root + min(r̂, length) along the stop bearing [m] (0 for
        misses): where on the whisker the contact can have been (a range read past the
        tip is noise)."""
        return self._points[: self._size]

    def __len__(self) -> int:
        return self._size

    def _cell_of(self, x: float, y: float) -> tuple[int, int]:
        return (math.floor(x / self.cell), math.floor(y / self.cell))

    def add(self, pose: FloatArray, sweeps: FloatArray) -> IntArray:
        """Store one pose's sweeps; return the indices of the rows they went to (new or merged)."""
        pose, sweeps = check_sweeps(pose, sweeps)
        self.version_ += 1
        touched = []
        for row in sweeps:
            hit = bool(np.isfinite(row[3]))
            key = (
                round(pose[0] / _ROOT_QUANTUM),
                round(pose[1] / _ROOT_QUANTUM),
                round(row[0] / _ANGLE_QUANTUM),
                round(row[1] / _ANGLE_QUANTUM),
                hit,
            )
            index = self._keys.get(key)
            if index is None:
                index = self._append(pose, row, hit)
                self._keys[key] = index
            else:
                self._merge(index, row, hit)
            touched.append(index)
        return np.asarray(sorted(set(touched)), dtype=np.int64)

    def _append(self, pose: FloatArray, row: FloatArray, hit: bool) -> int:
        if self._size == len(self._rows):
            grow = 2 * len(self._rows)
            self._rows = np.resize(self._rows, (grow, 8))
            self._counts = np.resize(self._counts, grow)
            self._normal_sum = np.resize(self._normal_sum, (grow, 2))
            self._points = np.resize(self._points, (grow, 2))
        index = self._size
        self._rows[index] = [pose[0], pose[1], *row]
        self._counts[index] = 1.0
        if hit:
            self._normal_sum[index] = (math.cos(row[4]), math.sin(row[4]))
        self._size += 1
        self._grid.add(self._cell_of(pose[0], pose[1]), index)
        if hit:
            point = pose[:2] + min(row[3], row[2]) * np.array([math.cos(row[1]), math.sin(row[1])])
            self._points[index] = point
            self._contact_grid.add(self._cell_of(*point), index)
        return index

    def _merge(self, index: int, row: FloatArray, hit: bool) -> None:
        n = self._counts[index]
        self._counts[index] = n + 1.0
        if hit:
            self._rows[index, 5] = (n * self._rows[index, 5] + row[3]) / (n + 1.0)
            r = self._rows[index]
            self._points[index] = r[:2] + min(r[5], r[4]) * np.array(
                [math.cos(r[3]), math.sin(r[3])]
            )
            self._normal_sum[index] += (math.cos(row[4]), math.sin(row[4]))
            self._rows[index, 6] = math.atan2(
                self._normal_sum[index, 1], self._normal_sum[index, 0]
            )
            if np.isfinite(row[5]):
                self._rows[index, 7] = (n * self._rows[index, 7] + row[5]) / (n + 1.0)

    def near(self, x: float, y: float, radius: float) -> IntArray:
        """Indices of stored sweeps whose root lies within ``radius`` [m] of ``(x, y)``."""
        return self._query(self._grid, self._rows, x, y, radius, radius)

    def contacts_near(self, x: float, y: float, radius: float) -> IntArray:
        """Indices of stored contacts whose point (:attr:`points_`) lies within ``radius``
        [m] of ``(x, y)``."""
        # A merged contact's point moves with its mean range; the index keeps its first
        # cell, so the cells searched are widened by a quarter cell.
        return self._query(
            self._contact_grid, self._points, x, y, radius, radius + 0.25 * self.cell
        )

    def _query(
        self,
        grid: _CellIndex,
        points: FloatArray,
        x: float,
        y: float,
        radius: float,
        search: float,
    ) -> IntArray:
        ids = grid.ids(self._cell_of(x - search, y - search), self._cell_of(x + search, y + search))
        if not len(ids):
            return ids
        keep = (points[ids, 0] - x) ** 2 + (points[ids, 1] - y) ** 2 <= radius**2
        return np.asarray(ids[keep], dtype=np.int64)


class _CellIndex:
    """A uniform grid of row indices: each cell's rows in the order they were added.

    A query gathers a block of cells; each cell's indices are kept as an array too
    (rebuilt only after the cell gained a row), so a query concatenates a few arrays rather
    than converting every index it finds from a Python list.
    """

    def __init__(self) -> None:
        self._cells: dict[tuple[int, int], list[int]] = {}
        self._arrays: dict[tuple[int, int], IntArray] = {}

    def add(self, cell: tuple[int, int], index: int) -> None:
        self._cells.setdefault(cell, []).append(index)
        self._arrays.pop(cell, None)

    def ids(self, lo: tuple[int, int], hi: tuple[int, int]) -> IntArray:
        """Indices in the cells from ``lo`` to ``hi`` (inclusive), cell by cell (row-major
        over ``i``, then ``j``), each cell's in the order added."""
        found: list[IntArray] = []
        for i in range(lo[0], hi[0] + 1):
            for j in range(lo[1], hi[1] + 1):
                array = self._arrays.get((i, j))
                if array is None:
                    cell = self._cells.get((i, j))
                    if cell is None:
                        continue
                    array = self._arrays[(i, j)] = np.asarray(cell, dtype=np.int64)
                found.append(array)
        if not found:
            return np.zeros(0, dtype=np.int64)
        return np.concatenate(found) if len(found) > 1 else found[0]
