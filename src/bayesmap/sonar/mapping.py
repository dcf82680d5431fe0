"""Grid mappers that integrate sonar rings into a :class:`~bayesmap.grid.OccupancyGrid`.

- :class:`ElfesMapper`: log-odds accumulation of the eq. 1 inverse cone model
  (:func:`bayesmap.sensing.sonar.elfes_inverse_model`);
- :class:`ThrunMapper`: log-odds ±0.4 of Thrun et al. (2005) Table 9.2;
- :class:`RosRangeLayerMapper`: the ROS costmap ``range_sensor_layer`` update.

Each keeps its own layer (log-odds, or the ROS layer's probabilities) and writes the
probabilities into the shared grid on :meth:`sync` (which also lowers the entropy layer).
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._typing import FloatArray, Grid, IntArray
from bayesmap.errors import ConfigError, InputError
from bayesmap.grid import OccupancyGrid, Window
from bayesmap.sensing.sonar import elfes_inverse_model, log_odds
from bayesmap.sensing.sonar_baselines import ros_bayes_update, ros_sensor_model, thrun_inverse_model
from bayesmap.sonar.geometry import ConeCells, SonarGeometry, cone_cells

__all__ = ["ElfesMapper", "NoEcho", "RosRangeLayerMapper", "ThrunMapper"]

NoEcho = Literal["cone", "clear", "ignore"]
"""How a mapper treats a no-echo reading (see :class:`ElfesMapper`)."""

_READINGS_PER_BATCH = 256
"""Readings whose cone cells are found in one pass (bounds the memory of a batch)."""


class _ConeMapper:
    """Shared shell: checks a ring's readings and finds the cells of each cone."""

    def __init__(self, grid: OccupancyGrid, geometry: SonarGeometry) -> None:
        self.grid = grid
        self.geometry = geometry
        self.rings_ = 0

    def _prepare(
        self,
        poses: npt.ArrayLike,
        ranges: npt.ArrayLike,
        use: npt.ArrayLike | None,
        *,
        clip: bool = True,
    ) -> tuple[FloatArray, FloatArray, FloatArray, np.ndarray]:
        """Check ``m`` rings: ``(m, n, 2)`` centres, ``(m, n)`` bearings, ranges and mask."""
        r = np.asarray(ranges, dtype=np.float64)
        p = np.asarray(poses, dtype=np.float64)
        if r.ndim != 2 or r.shape[1] != self.geometry.n or len(r) != len(p):
            raise InputError(
                f"a ring has {self.geometry.n} readings, got {len(p)} poses and ranges {r.shape}"
            )
        if np.any(np.isnan(r)) or np.any(r < 0):
            raise InputError(
                "sonar ranges must be non-negative numbers (inf = no echo), got NaN or < 0"
            )
        mask = np.ones(r.shape, dtype=bool) if use is None else np.asarray(use, dtype=bool)
        if mask.shape != r.shape:
            raise InputError(f"'use' mask has shape {mask.shape}, the rings {r.shape}")
        centres, axis = self.geometry.sensors_many(p)
        if clip:
            r = np.minimum(r, self.geometry.max_range)
        self.rings_ += len(r)
        return centres, axis, r, mask

    def integrate(
        self,
        pose: npt.ArrayLike,
        ranges: npt.ArrayLike,
        use: npt.ArrayLike | None = None,
        free_limit: npt.ArrayLike | None = None,
    ) -> None:
        """Add one ring of ``ranges`` [m] taken at ``pose``; skip readings where not ``use``.

        ``free_limit``: per reading, the distance [m] beyond which its cone writes no free
        space (``inf``: none; see :attr:`~bayesmap.sonar.filter.RingVerdict.free_limit`).
        """
        p, r = self.geometry.one_ring(pose, ranges)
        self.integrate_many(
            p[None],
            r[None],
            None if use is None else np.asarray(use)[None],
            None if free_limit is None else np.asarray(free_limit, dtype=np.float64)[None],
        )

    def integrate_many(
        self,
        poses: npt.ArrayLike,
        ranges: npt.ArrayLike,
        use: npt.ArrayLike | None = None,
        free_limit: npt.ArrayLike | None = None,
    ) -> None:
        """Add ``m`` rings in order: ``ranges`` ``(m, n)`` [m] at ``poses`` ``(m, 3)``."""
        raise NotImplementedError

    def _cells(self, centres: FloatArray, axis: FloatArray, reach: FloatArray) -> ConeCells:
        return cone_cells(self.grid, centres, axis, reach, self.geometry.beam_width / 2.0)


class _LogOddsMapper(_ConeMapper):
    """Log-odds layer ``log_odds_`` ``(ny, nx)``, clamped to ``±clamp``."""

    def __init__(
        self,
        grid: OccupancyGrid,
        geometry: SonarGeometry,
        clamp: float,
        decay: float = 0.0,
        footprint: float = 0.0,
        free_lock: float = 0.0,
        explain_away: float = 0.0,
        explain_beyond: float = 0.0,
    ) -> None:
        super().__init__(grid, geometry)
        if not explain_away >= 0:
            raise ConfigError(f"explain_away must be an exponent >= 0, got {explain_away}")
        if not explain_beyond >= 0:
            raise ConfigError(f"explain_beyond must be >= 0 metres, got {explain_beyond}")
        self.explain_away = float(explain_away)
        self.explain_beyond = float(explain_beyond)
        if not free_lock >= 0:
            raise ConfigError(f"free_lock must be >= 0 (log-odds), got {free_lock}")
        self.free_lock = float(free_lock)
        if not footprint >= 0:
            raise ConfigError(f"footprint radius must be >= 0 metres, got {footprint}")
        self.footprint = float(footprint)
        if not clamp > 0:
            raise ConfigError(f"log-odds clamp must be positive, got {clamp}")
        if not 0.0 <= decay < 1.0:
            raise ConfigError(f"log-odds decay must be in [0, 1), got {decay}")
        self.clamp = float(clamp)
        self.decay = float(decay)
        prior = min(max(grid.prior, 1e-9), 1 - 1e-9)
        self.prior_log_odds = float(log_odds(prior))
        self.log_odds_: Grid = np.full(grid.shape, self.prior_log_odds)
        self.swept_: np.ndarray = np.zeros(grid.shape, dtype=bool)
        self.reference_: Grid | None = None
        """A map of the whole log (a forward-model sweep's E-step), or ``None``: streaming."""
        self.echo_reference_: Grid | None = None
        """A map of the whole log's echoes alone, where a sweep's silences also stop, or
        ``None``."""
        self.free_stop = False

    def _reach(self, ranges: FloatArray) -> FloatArray:
        """How far each reading's cone is updated [m]."""
        raise NotImplementedError

    def _increment(self, ranges: FloatArray, cells: ConeCells) -> FloatArray:
        """Log-odds added to each cell of ``cells`` (``ranges``: its reading's range)."""
        raise NotImplementedError

    def integrate_many(
        self,
        poses: npt.ArrayLike,
        ranges: npt.ArrayLike,
        use: npt.ArrayLike | None = None,
        free_limit: npt.ArrayLike | None = None,
    ) -> None:
        """Add ``m`` rings in order: ``ranges`` ``(m, n)`` [m] at ``poses`` ``(m, 3)``.

        The cone cells and the model's log-odds of a batch of rings are computed at once;
        they are added ring by ring (saturation, decay and the footprint act per ring), so
        the map is the one ring-by-ring integration gives. ``free_limit`` ``(m, n)`` [m]:
        cells of a cone farther than this from its transducer get no free evidence.
        """
        centres, axis, r, mask = self._prepare(poses, ranges, use)
        limit = None if free_limit is None else np.asarray(free_limit, dtype=np.float64)
        if limit is not None and limit.shape != r.shape:
            raise InputError(f"'free_limit' has shape {limit.shape}, the rings {r.shape}")
        p = np.asarray(poses, dtype=np.float64)
        n = self.geometry.n
        reach = np.where(mask, self._reach(r), 0.0)
        step = max(1, _READINGS_PER_BATCH // n)
        footprint = self._footprint_cells(p)
        for a in range(0, len(r), step):
            b = min(a + step, len(r))
            cells = self._cells(centres[a:b].reshape(-1, 2), axis[a:b].ravel(), reach[a:b].ravel())
            increment = self._increment(r[a:b].ravel()[cells.reading], cells)
            if limit is not None:
                beyond = cells.rho > limit[a:b].ravel()[cells.reading]
                increment = np.where(beyond & (increment < 0.0), 0.0, increment)
            if self.reference_ is not None:
                # A sweep's E-step reference stays fixed while the sweep adds its rings, so
                # the first hits and the arcs' shares are found for the whole batch at once.
                if self.free_stop:
                    increment = self._first_hit(cells, r[a:b].ravel(), increment)
                if self.explain_away > 0.0:
                    increment = self._explained(cells, increment)
            bounds = np.searchsorted(cells.reading, n * np.arange(b - a + 1))
            flat = cells.rows * self.grid.shape[1] + cells.cols
            for i in range(b - a):
                part = slice(bounds[i], bounds[i + 1])
                if self.explain_away > 0.0 and self.reference_ is None:
                    piece = ConeCells(
                        cells.rows[part],
                        cells.cols[part],
                        cells.rho[part],
                        cells.theta[part],
                        cells.reading[part],
                    )
                    self._add(flat[part], self._explained(piece, increment[part]))
                else:
                    self._add(flat[part], increment[part])
                if footprint is not None:
                    rows, cols, inside = footprint
                    index = (rows[a + i][inside[a + i]], cols[a + i][inside[a + i]])
                    self.log_odds_[index] = -self.clamp
                    self.swept_[index] = True

    def _add(self, flat: IntArray, increment: FloatArray) -> None:
        """Add one ring's ``increment`` at the cells ``flat`` (row-major indices)."""
        log_odds, swept = self.log_odds_.reshape(-1), self.swept_.reshape(-1)
        if self.decay > 0.0:
            # Evidence in view fades towards the prior before the new ring is added, so a
            # passer-by that saturated cells is cleared by the next few free readings.
            log_odds[flat] = self.prior_log_odds + (1.0 - self.decay) * (
                log_odds[flat] - self.prior_log_odds
            )
        if self.free_lock > 0.0:
            # A cell many readings have seen free is free space: a later echo there is a
            # passer-by, so its occupied evidence is not written (free evidence still is).
            locked = log_odds[flat] <= self.prior_log_odds - self.free_lock
            increment = np.where(locked & (increment > 0.0), 0.0, increment)
        np.add.at(log_odds, flat, increment)
        updated = np.minimum(np.maximum(log_odds[flat], -self.clamp), self.clamp)
        # Where the robot's body has been, no static obstacle stands: an echo there later
        # came from something passing by (a person), so swept cells stay free.
        log_odds[flat] = np.where(swept[flat], -self.clamp, updated)

    def _explained(self, cells: ConeCells, increment: FloatArray) -> FloatArray:
        """Share each echo's occupied evidence along its arc by what the map already knows.

        An echo says that *some* cell of its arc reflected; the cone model credits every
        arc cell alike. Here each arc cell (positive increment) gets the fraction
        ``(p_i / max_j p_j) ** explain_away`` of it, ``p`` the current occupancy
        probabilities of the same reading's arc cells: a cell other readings have seen
        free is explained away by the arc cells that may still reflect, which take the
        echo's full weight. This is one E-step of the forward sensor model's
        expectation-maximisation (Thrun 2003, "Learning occupancy grid maps with forward
        sensor models": the posterior share of each cell in causing the measurement),
        taken with the map as it stands, so the update stays one pass. Only arc cells
        farther than ``explain_beyond`` from the transducer are shared: a near arc is
        narrow (``ρβ``: 0.9 m at 2 m for a 25° beam) and lies mostly on the surface that
        echoed, while a far one spans pillars, walls and the free space between them.
        """
        arc = np.flatnonzero((increment > 0.0) & (cells.rho > self.explain_beyond))
        if len(arc) == 0:
            return increment
        where = (cells.rows[arc], cells.cols[arc])
        if self.reference_ is not None:
            probability = self.reference_[where]
        else:
            probability = 1.0 / (1.0 + np.exp(-self.log_odds_[where]))
        reading = cells.reading[arc]
        starts = np.flatnonzero(np.r_[True, reading[1:] != reading[:-1]])
        peak = np.maximum.reduceat(probability, starts)
        runs = np.diff(np.r_[starts, len(arc)])
        share = probability / np.repeat(peak, runs)
        if self.explain_away != 1.0:
            share **= self.explain_away
        out = increment.copy()
        out[arc] *= share
        return out

    def _first_hit(self, cells: ConeCells, ranges: FloatArray, increment: FloatArray) -> FloatArray:
        """Stop each reading's free evidence at the first surface ``reference_`` holds.

        The forward sensor model's first hit (Thrun 2003): a beam cannot pass a surface, so
        a reading whose echo lies beyond a cell the whole-log map holds occupied (``p > ½``,
        within half the cone's half-width of its axis, more than ``2σ`` before the echo)
        either missed that surface (specular) or the surface is not there; its free space
        stops one cell beyond it, so the surface's own cell still hears the evidence
        against it but the cells behind it do not. A silence (no echo) also stops at a
        surface ``echo_reference_`` holds, when there is one: a wall whose echoes the
        silences of the pass cleared is still a surface the silences lost.
        """
        assert self.reference_ is not None
        sigma = max(self.geometry.sigma, self.grid.resolution)
        reach = ranges[cells.reading]
        central = np.abs(cells.theta) <= self.geometry.beam_width / 4.0
        held = self.reference_[cells.rows, cells.cols] > 0.5
        if self.echo_reference_ is not None:
            silent = reach >= self.geometry.max_range
            held |= silent & (self.echo_reference_[cells.rows, cells.cols] > 0.5)
        surface = central & held & (cells.rho < reach - 2.0 * sigma)
        first = np.full(len(ranges), np.inf)
        np.minimum.at(first, cells.reading[surface], cells.rho[surface])
        behind = cells.rho > first[cells.reading] + self.grid.resolution
        return np.where(behind & (increment < 0.0), 0.0, increment)

    def _footprint_cells(
        self, poses: FloatArray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The robot stands here: per pose, the cells within ``footprint`` [m] of its centre.

        Returns ``(rows, cols, inside)``, each ``(m, k)``: candidate cells round each pose
        and which of them lie inside the footprint and the grid; ``None`` when off. After
        each ring these cells are set free and join ``swept_``, and stay free for good: the
        map is of the static world, and no static obstacle can stand where the robot has
        stood.
        """
        if self.footprint <= 0:
            return None
        res, (x0, y0), (ny, nx) = self.grid.resolution, self.grid.origin, self.grid.shape
        span = int(math.ceil(self.footprint / res)) + 1
        offset = np.arange(-span, span + 1)
        d_row, d_col = (g.ravel() for g in np.meshgrid(offset, offset, indexing="ij"))
        x, y = poses[:, 0:1], poses[:, 1:2]
        rows = np.floor((y - y0) / res).astype(np.int64) + d_row[None, :]
        cols = np.floor((x - x0) / res).astype(np.int64) + d_col[None, :]
        inside = (x0 + (cols + 0.5) * res - x) ** 2 + (y0 + (rows + 0.5) * res - y) ** 2 <= (
            self.footprint**2
        )
        inside &= (rows >= 0) & (rows < ny) & (cols >= 0) & (cols < nx)
        return rows, cols, inside

    def probability(self) -> Grid:
        """``(ny, nx)`` occupancy probability of each cell."""
        return np.asarray(1.0 / (1.0 + np.exp(-self.log_odds_)))

    def observed(self) -> np.ndarray:
        """``(ny, nx)``: cells some reading has changed."""
        return np.asarray(self.log_odds_ != self.prior_log_odds)

    def sync(self) -> OccupancyGrid:
        """Write the probabilities into the grid (and its entropy layer); return the grid."""
        ny, nx = self.grid.shape
        self.grid.set_probability(Window(0, ny, 0, nx), self.probability())
        return self.grid


class _StoredRings(NamedTuple):
    """A batch of mapped rings kept for the forward-model sweeps, packed: the poses and
    ranges as given, which readings to map as bits, and only the finite free-space limits
    (``limit_at``: row-major positions, ``limit``: their values [m]); about 170 bytes a ring
    of 16 readings instead of 296."""

    poses: FloatArray
    ranges: FloatArray
    use: npt.NDArray[np.uint8]
    limit_at: npt.NDArray[np.int32] | None
    limit: FloatArray

    @classmethod
    def pack(
        cls, poses: FloatArray, ranges: FloatArray, use: np.ndarray, limit: FloatArray | None
    ) -> _StoredRings:
        """Pack ``m`` rings: poses ``(m, 3)``, ranges, ``use`` and ``limit`` ``(m, n)``."""
        bits = np.packbits(use, axis=1)
        if limit is None:
            return cls(poses, ranges, bits, None, np.zeros(0))
        at = np.flatnonzero(np.isfinite(limit)).astype(np.int32)
        return cls(poses, ranges, bits, at, limit.ravel()[at])

    def unpack(self) -> tuple[FloatArray, FloatArray, np.ndarray, FloatArray | None]:
        """The rings as :meth:`ElfesMapper.integrate_many` takes them (the values packed)."""
        n = self.ranges.shape[1]
        use = np.unpackbits(self.use, axis=1, count=n).astype(bool)
        if self.limit_at is None:
            return self.poses, self.ranges, use, None
        limit = np.full(self.ranges.size, np.inf)
        limit[self.limit_at] = self.limit
        return self.poses, self.ranges, use, limit.reshape(self.ranges.shape)


class ElfesMapper(_LogOddsMapper):
    """Log-odds mapping with the eq. 1 inverse cone model (ICINCO 2007 eq. 1, Elfes 1989).

    Parameters
    ----------
    grid
        The map to fill.
    geometry
        The ring.
    p_occ, p_free
        Peak and free probabilities of :func:`~bayesmap.sensing.sonar.elfes_inverse_model`.
    sigma_front
        The occupied arc's near side: flat for half a cell in front of the echo (the
        cell that holds the echo point), then a Gaussian of this width [m]; ``None``: the
        arc's width ``max(σ, cell size)`` on both sides (docs/sonar.md, *The first echo's
        near side*).
    no_echo
        What a no-echo reading (at or above the max range) does: ``"cone"`` clears its whole
        cone to the max range (Elfes' reading of "nothing there"), ``"clear"`` clears it up
        to ``clear_distance``, ``"ignore"`` leaves the map alone. A lost specular echo is
        also a no-echo reading, so clearing far erases glancing walls.
    clear_distance
        How far ``"clear"`` clears [m].
    clamp
        Log-odds saturation: no cell goes beyond ``±clamp``, so a cell a person saturated
        needs at most ``clamp / |free increment|`` free readings to clear.
    decay
        Fraction of a cell's log-odds (relative to the prior) lost each time a ring sees it,
        before the ring's own evidence is added; 0 keeps everything.
    footprint
        Radius [m] round the robot's centre marked free at every ring (the robot is there),
        as the ROS costmap's footprint clearing does, and kept free afterwards (the cells
        join ``swept_``: a later echo there is a passer-by); 0: off.
    free_lock, explain_away, explain_beyond
        See docs/sonar.md (*Map model choices*): an echo at a well-seen free cell is not
        written; an echo's occupied evidence beyond ``explain_beyond`` [m] is shared along
        its arc by the map, ``(p_i / max_j p_j) ** explain_away``.
    forward_sweeps
        Sweeps of the forward-model refinement run when the map is synced (0: none). Each
        sweep rebuilds the log-odds from every mapped reading with the previous sweep's
        map of the *whole* log as the E-step's reference (Thrun 2003, forward sensor
        models): an echo's occupied evidence is shared along its arc by that map
        (exponent ``forward_gamma`` for arc cells beyond ``forward_beyond`` [m]), and
        with ``forward_free_stop`` a reading's free space ends at the first surface the
        map holds on its beam. The mapped rings are kept for it, packed: pose and ranges,
        the mask as bits, the finite free limits only (about 170 bytes a ring of 16).
    forward_echo_stop
        With ``forward_free_stop``: a no-echo reading's free space in the sweeps also ends
        at the first surface a map of the log's echoes alone holds (built once per
        :meth:`refine`, the pass's settings with no-echo readings ignored). The pass's
        silences clear oblique walls whose echoes the ring lost (the narrower the beam,
        the more often), so the pass's map may no longer hold the walls the sweep should
        protect; the echoes that saw them from elsewhere still do (docs/sonar.md).

    Attributes
    ----------
    log_odds_
        ``(ny, nx)`` accumulated log-odds.
    swept_
        ``(ny, nx)`` cells within ``footprint`` of a pose the robot stood at.
    rings_
        Rings integrated so far.
    """

    def __init__(
        self,
        grid: OccupancyGrid,
        geometry: SonarGeometry,
        *,
        p_occ: float = 0.7,
        p_free: float = 0.35,
        sigma_front: float | None = None,
        no_echo: NoEcho = "cone",
        clear_distance: float = 2.0,
        clamp: float = 10.0,
        decay: float = 0.0,
        footprint: float = 0.0,
        free_lock: float = 0.0,
        explain_away: float = 0.0,
        explain_beyond: float = 0.0,
        forward_sweeps: int = 0,
        forward_gamma: float = 1.0,
        forward_beyond: float = 2.0,
        forward_free_stop: bool = False,
        forward_no_echo: float = 0.0,
        forward_echo_stop: bool = False,
    ) -> None:
        super().__init__(
            grid, geometry, clamp, decay, footprint, free_lock, explain_away, explain_beyond
        )
        if not (forward_sweeps >= 0 and forward_gamma > 0 and forward_beyond >= 0):
            raise ConfigError(
                "forward_sweeps must be >= 0, forward_gamma > 0 and forward_beyond >= 0 m, "
                f"got {forward_sweeps}, {forward_gamma}, {forward_beyond}"
            )
        self.forward_sweeps = int(forward_sweeps)
        self.forward_gamma = float(forward_gamma)
        self.forward_beyond = float(forward_beyond)
        self.forward_free_stop = bool(forward_free_stop)
        self.forward_echo_stop = bool(forward_echo_stop)
        if not 0.0 <= forward_no_echo <= geometry.max_range:
            raise ConfigError(
                f"forward_no_echo must be in [0, max range = {geometry.max_range}] m, "
                f"got {forward_no_echo}"
            )
        self.forward_no_echo = float(forward_no_echo)
        self._mapped: list[_StoredRings] = []
        self._refined = 0
        if no_echo not in ("cone", "clear", "ignore"):
            raise ConfigError(f"no_echo must be 'cone', 'clear' or 'ignore', got {no_echo!r}")
        if not 0.0 < clear_distance <= geometry.max_range:
            raise ConfigError(
                f"clear_distance must be in (0, max range = {geometry.max_range}] m, "
                f"got {clear_distance}"
            )
        self.no_echo = no_echo
        self.clear_distance = float(clear_distance)
        self.p_occ = p_occ
        self.p_free = p_free
        self.sigma_map = max(geometry.sigma, grid.resolution)
        self.sigma_front = sigma_front
        self.front_flat = grid.resolution / 2.0
        # Check p_occ, p_free and sigma_front here, not at the first ring: the model
        # raises ConfigError.
        elfes_inverse_model(
            1.0,
            1.0,
            0.0,
            sigma=self.sigma_map,
            beam_width=geometry.beam_width,
            max_range=geometry.max_range,
            p_occ=p_occ,
            p_free=p_free,
            sigma_front=sigma_front,
            front_flat=self.front_flat,
        )

    def integrate_many(
        self,
        poses: npt.ArrayLike,
        ranges: npt.ArrayLike,
        use: npt.ArrayLike | None = None,
        free_limit: npt.ArrayLike | None = None,
    ) -> None:
        """Add ``m`` rings in order (see :meth:`_LogOddsMapper.integrate_many`)."""
        super().integrate_many(poses, ranges, use, free_limit)
        if self.forward_sweeps > 0 and self.reference_ is None:
            r = np.asarray(ranges, dtype=np.float64)
            mask = np.ones(r.shape, dtype=bool) if use is None else np.asarray(use, dtype=bool)
            limit = None if free_limit is None else np.asarray(free_limit, dtype=np.float64)
            self._mapped.append(
                _StoredRings.pack(np.asarray(poses, dtype=np.float64), r, mask, limit)
            )

    def remask(self, use: npt.ArrayLike) -> None:
        """Replace which readings of the stored rings the sweeps map (the map's verdict).

        ``use`` ``(k, n)``: one row per ring stored for the refinement, in the order they
        were integrated. The streaming map is left as it is; the next :meth:`refine`
        maps the readings ``use`` keeps.
        """
        if self.forward_sweeps == 0:
            return
        mask = np.asarray(use, dtype=bool)
        stored = sum(len(rings.ranges) for rings in self._mapped)
        if mask.shape != (stored, self.geometry.n):
            raise InputError(f"'use' has shape {mask.shape}, the stored rings ({stored}, n)")
        start = 0
        for k, rings in enumerate(self._mapped):
            stop = start + len(rings.ranges)
            self._mapped[k] = rings._replace(use=np.packbits(mask[start:stop], axis=1))
            start = stop
        self._refined = 0

    def refine(self) -> None:
        """Run the forward-model sweeps over every ring mapped so far (see the class).

        Sweep ``s`` resets the layer to the prior and integrates the stored rings again in
        their order, with the map sweep ``s - 1`` ended with (the streaming map for the
        first) as ``reference_``: the E-step sees the whole log, the M-step is the usual
        log-odds sum, so the map is the same function of the log however it was batched.
        """
        if self.forward_sweeps == 0 or self._refined == len(self._mapped):
            return
        if self.forward_free_stop and self.forward_echo_stop:
            self.echo_reference_ = self._echo_map()
        streaming = (self.explain_away, self.explain_beyond, self.free_stop, self.rings_)
        silence = (self.no_echo, self.clear_distance)
        self.explain_away, self.explain_beyond = self.forward_gamma, self.forward_beyond
        self.free_stop = self.forward_free_stop
        if self.forward_no_echo > 0.0:
            self.no_echo, self.clear_distance = "clear", self.forward_no_echo
        for _ in range(self.forward_sweeps):
            self.reference_ = self.probability()
            self.log_odds_ = np.full(self.grid.shape, self.prior_log_odds)
            self.swept_ = np.zeros(self.grid.shape, dtype=bool)
            for rings in self._mapped:
                super().integrate_many(*rings.unpack())
        self.explain_away, self.explain_beyond, self.free_stop, self.rings_ = streaming
        self.no_echo, self.clear_distance = silence
        self.reference_ = self.echo_reference_ = None
        self._refined = len(self._mapped)

    def _echo_map(self) -> Grid:
        """Occupancy probabilities of the stored rings mapped as the pass maps them, but
        with every no-echo reading ignored (``forward_echo_stop``); the layer is left as
        it was."""
        kept = (self.log_odds_, self.swept_, self.rings_, self.no_echo)
        self.log_odds_ = np.full(self.grid.shape, self.prior_log_odds)
        self.swept_ = np.zeros(self.grid.shape, dtype=bool)
        self.no_echo = "ignore"
        for rings in self._mapped:
            super().integrate_many(*rings.unpack())
        echoes = self.probability()
        self.log_odds_, self.swept_, self.rings_, self.no_echo = kept
        return echoes

    def sync(self) -> OccupancyGrid:
        """Refine (when ``forward_sweeps``), then write the map into the grid."""
        self.refine()
        return super().sync()

    def _reach(self, ranges: FloatArray) -> FloatArray:
        echo = ranges < self.geometry.max_range
        no_echo_reach = {"cone": self.geometry.max_range, "clear": self.clear_distance}
        return np.where(echo, ranges + 3.0 * self.sigma_map, no_echo_reach.get(self.no_echo, 0.0))

    def _increment(self, ranges: FloatArray, cells: ConeCells) -> FloatArray:
        p = elfes_inverse_model(
            ranges,
            cells.rho,
            cells.theta,
            sigma=self.sigma_map,
            beam_width=self.geometry.beam_width,
            max_range=self.geometry.max_range,
            p_occ=self.p_occ,
            p_free=self.p_free,
            sigma_front=self.sigma_front,
            front_flat=self.front_flat,
        )
        return log_odds(p)


class ThrunMapper(_LogOddsMapper):
    """Log-odds ±0.4 mapping, Thrun, Burgard & Fox (2005) Table 9.2, every beam its own cone.

    Parameters
    ----------
    grid, geometry
        The map and the ring.
    alpha
        Obstacle thickness [m]; default twice the grid resolution.
    l_occ, l_free
        Log-odds per hit and per miss.
    clamp, decay
        Log-odds saturation and decay, as for :class:`ElfesMapper`.
    """

    def __init__(
        self,
        grid: OccupancyGrid,
        geometry: SonarGeometry,
        *,
        alpha: float | None = None,
        l_occ: float = 0.4,
        l_free: float = -0.4,
        clamp: float = 10.0,
        decay: float = 0.0,
    ) -> None:
        super().__init__(grid, geometry, clamp, decay)
        self.alpha = 2.0 * grid.resolution if alpha is None else float(alpha)
        if not self.alpha > 0:
            raise ConfigError(f"obstacle thickness alpha must be positive metres, got {alpha}")
        self.l_occ = l_occ
        self.l_free = l_free

    def _reach(self, ranges: FloatArray) -> FloatArray:
        return np.minimum(self.geometry.max_range, ranges + self.alpha / 2.0)

    def _increment(self, ranges: FloatArray, cells: ConeCells) -> FloatArray:
        return thrun_inverse_model(
            ranges,
            cells.rho,
            cells.theta,
            z_max=self.geometry.max_range,
            alpha=self.alpha,
            beta=self.geometry.beam_width,
            l_occ=self.l_occ,
            l_free=self.l_free,
        )


class RosRangeLayerMapper(_ConeMapper):
    """The ROS costmap ``range_sensor_layer`` sonar update (DLu/navigation_layers).

    Per reading, in ring order: the target cell's cost is set to 233, then every cell of
    the update triangle (the transducer and the cone edges at 1.2 times the range) gets
    Bayes' rule with :func:`~bayesmap.sensing.sonar_baselines.ros_sensor_model`, stored with
    the layer's ``(uchar)(p · 254)`` quantisation. As in ``processVariableRangeMsg``, a
    reading above the maximum range or below the minimum (a no-echo code, ``inf``) is
    dropped; a reading exactly at the maximum clears its cone (sensor value 0) when
    ``clear_on_max_reading``, and otherwise marks an arc there like any echo (the layer's
    default). Our clearing touches the cone's cells only.

    Attributes
    ----------
    probability_
        ``(ny, nx)`` the layer's probabilities (start 127/254 = 0.5).
    """

    def __init__(
        self,
        grid: OccupancyGrid,
        geometry: SonarGeometry,
        *,
        phi_v: float = 1.2,
        clear_on_max_reading: bool = False,
    ) -> None:
        super().__init__(grid, geometry)
        self.phi_v = float(phi_v)
        self.clear_on_max_reading = bool(clear_on_max_reading)
        self.probability_: Grid = np.full(grid.shape, 127.0 / 254.0)
        self.touched_ = np.zeros(grid.shape, dtype=bool)

    def integrate_many(
        self,
        poses: npt.ArrayLike,
        ranges: npt.ArrayLike,
        use: npt.ArrayLike | None = None,
        free_limit: npt.ArrayLike | None = None,
    ) -> None:
        """Add ``m`` rings in order: ``ranges`` ``(m, n)`` [m] at ``poses`` ``(m, 3)``.

        The layer clears each cone as a whole: a finite ``free_limit`` is refused.
        """
        if free_limit is not None and np.any(np.isfinite(free_limit)):
            raise ConfigError("the ROS range_sensor_layer model takes no free-space limit")
        centres, axis, r, mask = self._prepare(poses, ranges, use, clip=False)
        for i in range(len(r)):
            self._integrate_ring(centres[i], axis[i], r[i], mask[i])

    def _integrate_ring(
        self, centres: FloatArray, axis: FloatArray, r: FloatArray, mask: np.ndarray
    ) -> None:
        """One ring, reading by reading, as the layer does."""
        mask = mask & (r <= self.geometry.max_range) & (r >= self.geometry.min_range)
        r = np.where(mask, r, 0.0)
        half = self.geometry.beam_width / 2.0
        edge = 1.2 * r * math.cos(half)  # the triangle's far side, along the axis
        cells = self._cells(centres, axis, np.where(mask, edge / math.cos(half), 0.0))
        keep = cells.rho * np.cos(cells.theta) <= edge[cells.reading]
        starts = np.searchsorted(cells.reading[keep], np.arange(self.geometry.n + 1))
        rows_all, cols_all = cells.rows[keep], cells.cols[keep]
        rho_all, theta_all = cells.rho[keep], cells.theta[keep]
        for k in np.flatnonzero(mask):
            part = slice(starts[k], starts[k + 1])
            rows, cols = rows_all[part], cols_all[part]
            if self.clear_on_max_reading and r[k] >= self.geometry.max_range:
                sensor = np.zeros(len(rows))
            else:
                target = centres[k] + r[k] * np.array([math.cos(axis[k]), math.sin(axis[k])])
                tr, tc = self.grid.world_to_cell(target[0], target[1])
                if self.grid.in_bounds(tr, tc):
                    self.probability_[tr, tc] = 233.0 / 254.0
                    self.touched_[tr, tc] = True
                sensor = ros_sensor_model(
                    r[k],
                    rho_all[part],
                    theta_all[part],
                    max_angle=half,
                    resolution=self.grid.resolution,
                    phi_v=self.phi_v,
                )
            self.probability_[rows, cols] = ros_bayes_update(self.probability_[rows, cols], sensor)
            self.touched_[rows, cols] |= sensor != 0.5

    def probability(self) -> Grid:
        """``(ny, nx)`` occupancy probability of each cell."""
        return self.probability_.copy()

    def observed(self) -> np.ndarray:
        """``(ny, nx)``: cells some reading has changed."""
        return self.touched_.copy()

    def sync(self) -> OccupancyGrid:
        """Write the probabilities into the grid (and its entropy layer); return the grid."""
        ny, nx = self.grid.shape
        self.grid.set_probability(Window(0, ny, 0, nx), self.probability_)
        return self.grid
