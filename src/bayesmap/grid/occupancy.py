"""The occupancy grid: a probability layer and an entropy layer over a rectangle of the world.

Conventions (the ROS ``nav_msgs/OccupancyGrid`` ones): ``origin`` is the world position
``(x, y)`` [m] of the lower-left *corner* of cell ``(0, 0)``; row ``i`` is the ``i``-th cell
along +y, column ``j`` the ``j``-th along +x; the centre of cell ``(i, j)`` is
``origin + ((j + 0.5) res, (i + 0.5) res)``. Layers are float64 arrays of shape ``(ny, nx)``.

Updates touch a :class:`Window` of cells around a point, so their cost is proportional to
the cells touched, never to the whole map.
"""

from __future__ import annotations

import io
import math
import struct
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bayesmap._io import read_input, write_bytes
from bayesmap._typing import BoolArray, FloatArray, Grid, IntArray
from bayesmap.errors import ConfigError, FormatError, InputError
from bayesmap.grid.entropy import binary_entropy_bits
from bayesmap.limits import DEFAULT_LIMITS, ReadLimits, check_size

_NPZ_KEYS = ("probability", "entropy", "resolution", "origin", "prior")


@dataclass(frozen=True)
class Window:
    """A rectangular block of cells, ``rows = [row0, row1)``, ``cols = [col0, col1)``.

    Index a layer with ``layer[window.rows, window.cols]`` to get a writable view.
    """

    row0: int
    row1: int
    col0: int
    col1: int

    @property
    def rows(self) -> slice:
        """Row slice of the window."""
        return slice(self.row0, self.row1)

    @property
    def cols(self) -> slice:
        """Column slice of the window."""
        return slice(self.col0, self.col1)

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the window (0 for an empty window)."""
        return (max(self.row1 - self.row0, 0), max(self.col1 - self.col0, 0))

    @property
    def size(self) -> int:
        """Number of cells in the window."""
        rows, cols = self.shape
        return rows * cols


class OccupancyGrid:
    """An occupancy grid with a probability layer and an entropy layer [bits].

    Parameters
    ----------
    width, height
        Size of the mapped rectangle along x and y [m]; rounded to whole cells.
    resolution
        Cell side [m].
    origin
        World position ``(x, y)`` of the lower-left corner of cell ``(0, 0)`` [m].
    prior
        Initial obstacle probability of every cell (Post et al. 2016 §4.3: ``P(R)``).
    initial_entropy
        Initial entropy of every cell [bits]; 1 (the maximum, "unknown") by default, as in
        Post et al. 2016 §4.4.
    max_cells
        Most cells the grid may have; a larger one (a tiny resolution, or a pose far away
        in a log) is a :class:`ConfigError` before anything is allocated.

    Attributes
    ----------
    probability
        ``(ny, nx)`` obstacle probability of each cell.
    entropy
        ``(ny, nx)`` entropy of each cell [bits].

    Examples
    --------
    >>> grid = OccupancyGrid(20.0, 10.0, 0.5, prior=0.2)
    >>> grid.shape
    (20, 40)
    >>> rows, cols = grid.world_to_cell(np.array([0.1, 19.9]), np.array([0.1, 9.9]))
    >>> rows.tolist(), cols.tolist()
    ([0, 19], [0, 39])
    """

    def __init__(
        self,
        width: float,
        height: float,
        resolution: float,
        origin: tuple[float, float] = (0.0, 0.0),
        prior: float = 0.5,
        initial_entropy: float = 1.0,
        *,
        max_cells: int = DEFAULT_LIMITS.max_cells,
    ) -> None:
        if not (math.isfinite(resolution) and resolution > 0):
            raise ConfigError(
                f"grid resolution must be a positive number of metres, got {resolution!r}"
            )
        if not (math.isfinite(width) and math.isfinite(height) and width > 0 and height > 0):
            raise ConfigError(
                f"grid width and height must be positive metres, got {width!r} x {height!r}"
            )
        if not 0.0 <= prior <= 1.0:
            raise ConfigError(f"grid prior must be a probability in [0, 1], got {prior!r}")
        if not 0.0 <= initial_entropy <= 1.0:
            raise ConfigError(f"initial entropy must be in [0, 1] bits, got {initial_entropy!r}")
        nx, ny = _cell_counts(width, height, resolution, max_cells)
        self.resolution = float(resolution)
        self.origin = (float(origin[0]), float(origin[1]))
        self.prior = float(prior)
        self.probability: Grid = np.full((ny, nx), self.prior)
        self.entropy: Grid = np.full((ny, nx), float(initial_entropy))

    # ----------------------------------------------------------------- geometry
    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``: rows along y, columns along x."""
        ny, nx = self.probability.shape
        return (int(ny), int(nx))

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` [m] of the mapped rectangle (matplotlib ``extent``)."""
        ny, nx = self.shape
        x0, y0 = self.origin
        return (x0, x0 + nx * self.resolution, y0, y0 + ny * self.resolution)

    def world_to_cell(self, x: npt.ArrayLike, y: npt.ArrayLike) -> tuple[IntArray, IntArray]:
        """Cell ``(rows, cols)`` holding world points ``(x, y)`` [m]; may be out of bounds."""
        xs = np.asarray(x, dtype=np.float64)
        ys = np.asarray(y, dtype=np.float64)
        cols = np.floor((xs - self.origin[0]) / self.resolution).astype(np.int64)
        rows = np.floor((ys - self.origin[1]) / self.resolution).astype(np.int64)
        return rows, cols

    def cell_centers(
        self, rows: npt.ArrayLike, cols: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """World ``(x, y)`` [m] of the centres of cells ``(rows, cols)``."""
        r = np.asarray(rows, dtype=np.float64)
        c = np.asarray(cols, dtype=np.float64)
        return self.origin[0] + (c + 0.5) * self.resolution, self.origin[1] + (
            r + 0.5
        ) * self.resolution

    def in_bounds(self, rows: npt.ArrayLike, cols: npt.ArrayLike) -> BoolArray:
        """Whether each cell ``(rows, cols)`` lies inside the grid."""
        r = np.asarray(rows)
        c = np.asarray(cols)
        ny, nx = self.shape
        return np.asarray((r >= 0) & (r < ny) & (c >= 0) & (c < nx))

    def window(self, x: float, y: float, radius: float) -> Window:
        """Cells whose centres may lie within ``radius`` [m] of ``(x, y)``, clipped to the grid.

        The window is the bounding square of the disc; it is empty when the disc misses the
        grid. Its size depends on ``radius`` only, never on the size of the map.
        """
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InputError(f"window centre must be finite, got ({x!r}, {y!r})")
        if not (math.isfinite(radius) and radius >= 0):
            raise InputError(
                f"window radius must be a non-negative number of metres, got {radius!r}"
            )
        ny, nx = self.shape
        res = self.resolution
        col0 = math.floor((x - radius - self.origin[0]) / res)
        col1 = math.floor((x + radius - self.origin[0]) / res) + 1
        row0 = math.floor((y - radius - self.origin[1]) / res)
        row1 = math.floor((y + radius - self.origin[1]) / res) + 1
        return Window(
            row0=min(max(row0, 0), ny),
            row1=min(max(row1, 0), ny),
            col0=min(max(col0, 0), nx),
            col1=min(max(col1, 0), nx),
        )

    def window_centers(self, window: Window) -> tuple[FloatArray, FloatArray]:
        """World ``(x, y)`` [m] of the cell centres of ``window``, each ``window.shape``."""
        cols = np.arange(window.col0, max(window.col1, window.col0))
        rows = np.arange(window.row0, max(window.row1, window.row0))
        xc, yc = self.cell_centers(rows[:, None], cols[None, :])
        shape = window.shape
        return np.broadcast_to(xc, shape).copy(), np.broadcast_to(yc, shape).copy()

    # ----------------------------------------------------------------- updates
    def set_probability(
        self, window: Window, probability: npt.ArrayLike, mask: npt.ArrayLike | None = None
    ) -> None:
        """Write ``probability`` into ``window`` and update its entropy (eq. 37, amended).

        Post et al. 2016 eq. 37 keeps, per cell, the minimum over time of the Bernoulli
        entropy of its probability [bits]. Taken literally, a cell once read as "certainly
        free" stays certain after later readings make it an obstacle again. Here a write that
        makes a cell *less* certain (``H(p_new) > H(p_old)``: the new evidence contradicts
        what the cell held) resets its entropy to ``H(p_new)``; a write that agrees keeps the
        minimum. So the minimum runs over the readings since the last contradiction. With
        ``mask`` (booleans of ``window.shape``) only the cells it marks are written.
        """
        values = np.asarray(probability, dtype=np.float64)
        if values.shape != window.shape:
            raise InputError(
                f"probability block has shape {values.shape}, window is {window.shape}"
            )
        if values.size and not (np.all(values >= 0.0) and np.all(values <= 1.0)):
            raise InputError("probabilities written to the grid must lie in [0, 1]")
        chosen = np.ones(window.shape, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        if chosen.shape != window.shape:
            raise InputError(f"mask has shape {chosen.shape}, window is {window.shape}")
        block = self.probability[window.rows, window.cols]
        entropy = self.entropy[window.rows, window.cols]
        h_new = binary_entropy_bits(values[chosen])
        contradicted = h_new > binary_entropy_bits(block[chosen])
        entropy[chosen] = np.where(contradicted, h_new, np.minimum(entropy[chosen], h_new))
        block[chosen] = values[chosen]

    def unobserved(self) -> BoolArray:
        """Cells no reading has informed: probability still exactly the prior (Yamauchi 1997)."""
        return np.asarray(self.probability == self.prior)

    # ----------------------------------------------------------------- files
    def save_npz(self, path: str | Path) -> Path:
        """Write the grid (both layers, resolution, origin, prior) to a ``.npz`` file atomically."""
        buffer = io.BytesIO()
        np.savez_compressed(
            buffer,
            probability=self.probability,
            entropy=self.entropy,
            resolution=np.float64(self.resolution),
            origin=np.asarray(self.origin, dtype=np.float64),
            prior=np.float64(self.prior),
        )
        return write_bytes(path, buffer.getvalue())

    @classmethod
    def load_npz(cls, path: str | Path, *, limits: ReadLimits | None = None) -> OccupancyGrid:
        """Read a grid written by :meth:`save_npz`; :class:`FormatError` if it is not one.

        The file must be a regular file; its bytes, each array's bytes and cells are
        checked against ``limits`` (:class:`~bayesmap.limits.ReadLimits`) before they are
        read, and NaN or infinite values anywhere are refused.
        """
        limits = limits or DEFAULT_LIMITS
        arrays = read_npz_arrays(path, _NPZ_KEYS, limits)
        try:
            probability, entropy, origin = (
                arrays[key].astype(np.float64) for key in ("probability", "entropy", "origin")
            )
            resolution, prior = (float(arrays[key].item()) for key in ("resolution", "prior"))
        except (TypeError, ValueError) as error:
            raise FormatError(
                f"occupancy grid arrays of the wrong type or size ({error})", path=path
            ) from None
        if probability.ndim != 2 or probability.shape != entropy.shape or probability.size == 0:
            raise FormatError(
                f"layers must be equal 2-D arrays, got {probability.shape}, {entropy.shape}",
                path=path,
            )
        if not np.all((probability >= 0) & (probability <= 1) & (entropy >= 0) & (entropy <= 1)):
            raise FormatError(
                "probabilities and entropies [bits] must lie in [0, 1] (no NaN)",
                path=path,
            )
        if origin.shape != (2,) or not np.all(np.isfinite(origin)):
            raise FormatError(f"origin must hold 2 finite numbers [m], got {origin!r}", path=path)
        ny, nx = probability.shape
        try:
            grid = cls(
                nx * resolution,
                ny * resolution,
                resolution,
                (origin[0], origin[1]),
                prior=prior,
                max_cells=limits.max_cells,
            )
        except ConfigError as error:
            raise FormatError(str(error), path=path) from None
        if grid.shape != probability.shape:
            raise FormatError(
                f"layers of {probability.shape} cells do not fit resolution {resolution!r}",
                path=path,
            )
        grid.probability = probability
        grid.entropy = entropy
        return grid


def _cell_counts(width: float, height: float, resolution: float, max_cells: int) -> tuple[int, int]:
    """``(nx, ny)`` cells of a ``width x height`` [m] grid; :class:`ConfigError` past the limit."""
    along_x, along_y = width / resolution, height / resolution
    cells = along_x * along_y
    if not math.isfinite(cells) or cells > 2 * max_cells:
        nx = ny = max_cells + 1  # too many: no need to round
    else:
        nx, ny = max(int(round(along_x)), 1), max(int(round(along_y)), 1)
    if nx * ny > max_cells:
        raise ConfigError(
            f"a {width:g} m x {height:g} m grid at {resolution:g} m resolution has "
            f"{cells:.3g} cells, more than the limit of {max_cells:,} (max_cells); use a "
            "coarser resolution, a smaller area, or check the poses for outliers"
        )
    return nx, ny


def read_npz_arrays(
    path: str | Path, keys: tuple[str, ...], limits: ReadLimits
) -> dict[str, npt.NDArray[Any]]:
    """The numeric arrays ``keys`` of the ``.npz`` file ``path``, each checked before reading.

    Every array's header is read first: a non-numeric dtype (objects, pickles), more
    than ``limits.max_cells`` values or more than ``limits.max_bytes`` bytes is refused
    before its data is decompressed.
    """
    data = read_input(path, max_bytes=limits.max_bytes)
    arrays: dict[str, npt.NDArray[Any]] = {}
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            names = set(archive.namelist())
            missing = [key for key in keys if f"{key}.npy" not in names]
            if missing:
                raise FormatError(f"not an occupancy grid: missing arrays {missing}", path=path)
            for key in keys:
                arrays[key] = _npz_member(archive, key, limits, str(path))
    except FormatError:
        raise
    except (
        OSError,
        EOFError,
        ValueError,
        TypeError,
        KeyError,
        RuntimeError,  # includes NotImplementedError: an unsupported compression method
        struct.error,
        zipfile.BadZipFile,
        zlib.error,
    ) as error:
        raise FormatError(
            f"cannot read .npz occupancy grid ({type(error).__name__}: {error})", path=path
        ) from None
    return arrays


def _npz_member(
    archive: zipfile.ZipFile, key: str, limits: ReadLimits, path: str
) -> npt.NDArray[Any]:
    info = archive.getinfo(f"{key}.npy")
    element = f"array {key!r}"
    check_size("bytes", info.file_size, limits.max_bytes, "max_bytes", path=path, element=element)
    with archive.open(info) as member:
        version = np.lib.format.read_magic(member)
        header = (
            np.lib.format.read_array_header_1_0
            if version == (1, 0)
            else np.lib.format.read_array_header_2_0
        )
        shape, _, dtype = header(member)
    if dtype.kind not in "biuf" or dtype.hasobject:
        raise FormatError(f"holds {dtype} values, not numbers", path=path, element=element)
    check_size("cells", math.prod(shape), limits.max_cells, "max_cells", path=path, element=element)
    with archive.open(info) as member:
        return np.asarray(np.lib.format.read_array(member, allow_pickle=False))
