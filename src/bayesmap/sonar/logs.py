"""Plain-text sonar logs of real robots: read (tolerantly or strictly) and write.

A log holds one row per ring: ``timestamp x y heading r_1 ... r_N``, separated by commas,
semicolons or whitespace. Alternatively the ranges (``timestamp r_1 ... r_N``) and the poses
(``timestamp x y heading``) sit in two files joined by timestamp: each ranges row gets the
pose interpolated between the pose rows around it (linear in position, shortest arc in
heading) when they are at most ``max_pose_gap`` apart, else the nearest pose within
``time_tolerance``. Units are converted to SI once, here: ranges and positions from mm, cm or
m; headings from rad, deg or decidegrees. Files are read line by line into numpy blocks, so
memory stays close to the size of the numbers.

Real logs are untidy. Blank lines and comments (``#``, ``%``, ``//`` or ``;`` at the start of
a line; anything after ``#`` on a line) are ignored; a last line without a newline and
Windows line endings are fine. Numbers are plain ASCII decimals (a range may also be ``inf``,
no echo). Bad rows — a field that is not such a number (``nan``, ``1_0``, ``Infinity``, digits
of other scripts), a negative range, the wrong number of columns, a timestamp out of order,
no pose for a timestamp — cost that row only. Timestamps are put in order by keeping the
longest strictly increasing run of rows, so one corrupt timestamp drops its own row, not the
rows after it. Every skipped row
is reported with its line number and reason (a warning each, and in ``skipped``) and a summary
warning gives the fraction dropped; with ``strict=True`` the first bad row in the file aborts
the read with a :class:`~bayesmap.errors.FormatError` naming its file and line.

The row machinery (:class:`RowBlocks`, :func:`row_values`, :func:`in_order_rows`,
:func:`posed_rows`, :func:`finish_log`, :func:`report_skipped`, :func:`ring_log`) is shared
with the Player and CARMEN log readers (:mod:`bayesmap.sonar.player`,
:mod:`bayesmap.sonar.carmen`), so all treat bad rows alike; it is not part of the package's
API (``__all__``).
"""

from __future__ import annotations

import bisect
import logging
import math
import re
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._io import LineReader, write_text
from bayesmap._numbers import is_decimal
from bayesmap._typing import FloatArray, Poses, ProgressHook, Ranges
from bayesmap.errors import FormatError, InputError
from bayesmap.geometry import MAX_POSE_JUMP, isolated_jumps, wrap_angle
from bayesmap.sonar.geometry import SonarGeometry

__all__ = [
    "ANGLE_UNITS",
    "RingLog",
    "LENGTH_UNITS",
    "join_poses",
    "LogUnits",
    "SHOWN_SKIPS",
    "SkippedRow",
    "SonarLog",
    "TIME_UNITS",
    "heading_unit_hint",
    "position_unit_hint",
    "read_sonar_log",
    "write_sonar_log",
]

logger = logging.getLogger(__name__)

LENGTH_UNITS: dict[str, float] = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
"""Metres per unit of length."""
ANGLE_UNITS: dict[str, float] = {"rad": 1.0, "deg": math.pi / 180.0, "decideg": math.pi / 1800.0}
"""Radians per unit of angle."""
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
"""Seconds per unit of time (``rostopic echo -p`` writes nanoseconds)."""

_COMMENTS = ("#", "%", "//", ";")


def heading_unit_hint(headings: FloatArray, unit: str) -> str | None:
    """A hint when ``headings`` as logged, in ``unit``, look like degrees read as radians:
    some beyond ±(2π + 0.1). (Headings unwrapped over whole turns can be that large too,
    so this is a hint, not an error.)"""
    if unit != "rad" or not len(headings):
        return None
    largest = float(np.max(np.abs(headings)))
    if largest <= 2.0 * math.pi + 0.1:
        return None
    return (
        f"headings reach {largest:.4g} rad: if they are in degrees, give --heading-unit deg "
        "(decideg for tenths)"
    )


def position_unit_hint(xy: FloatArray, unit: str) -> str | None:
    """A hint when positions ``(n, 2)`` [m], logged in ``unit`` (``cm`` or ``mm``), span
    under 5 cm over 20 rows or more: metres read as cm or mm. (A robot that stood still the
    whole log spans as little, so this is a hint, not an error.)"""
    if unit == "m" or len(xy) < 20:
        return None
    span = float(np.max(np.ptp(xy, axis=0)))
    if span >= 0.05:
        return None
    return (
        f"the positions span {span:.3g} m over {len(xy)} rows: if they are in metres, give "
        f"--position-unit m (not {unit})"
    )


@dataclass(frozen=True)
class LogUnits:
    """Units of a log's columns.

    Ranges and positions in ``mm``, ``cm`` or ``m``; heading in ``rad``, ``deg`` or
    ``decideg``; timestamps in ``s``, ``ms``, ``us`` or ``ns``.
    """

    range_unit: Literal["mm", "cm", "m"] = "m"
    position_unit: Literal["mm", "cm", "m"] = "m"
    heading_unit: Literal["rad", "deg", "decideg"] = "rad"
    time_unit: Literal["s", "ms", "us", "ns"] = "s"

    def __post_init__(self) -> None:
        for name, value, table in (
            ("range unit", self.range_unit, LENGTH_UNITS),
            ("position unit", self.position_unit, LENGTH_UNITS),
            ("heading unit", self.heading_unit, ANGLE_UNITS),
            ("time unit", self.time_unit, TIME_UNITS),
        ):
            if value not in table:
                raise InputError(f"unknown {name} {value!r}; choose from: {', '.join(table)}")


@dataclass(frozen=True)
class SkippedRow:
    """A row left out of a log: file, 1-based line number and why."""

    path: str
    line: int
    reason: str


class SonarLog(NamedTuple):
    """A sonar log in SI units.

    Attributes
    ----------
    timestamps
        ``(n,)`` strictly increasing times [s] (as in the file).
    poses
        ``(n, 3)`` poses ``(x [m], y [m], heading [rad])``.
    ranges
        ``(n, N)`` ranges [m] (``inf`` allowed: no echo).
    rows
        Data rows (not blank, not comments) in the ranges file.
    skipped
        The rows left out, in file order.
    """

    timestamps: FloatArray
    poses: Poses
    ranges: Ranges
    rows: int
    skipped: tuple[SkippedRow, ...]


class RingLog(NamedTuple):
    """A robot's log that describes its own sonar ring: the rings with their poses, and the
    ring (:mod:`~bayesmap.sonar.player`, :mod:`~bayesmap.sonar.carmen`).

    Attributes
    ----------
    log
        The rings in SI units (``rows`` counts the lines of the ring and of the odometry,
        and the lines that could not be read).
    ring
        The ring the log describes (transducer positions and bearings; what the log does not
        say, such as the max range, is the presets': :func:`~bayesmap.sonar.ring.ring_from_layout`);
        ``None`` when the log describes none or its description was skipped.
    """

    log: SonarLog
    ring: SonarGeometry | None


class _Table(NamedTuple):
    lines: npt.NDArray[np.int64]
    values: FloatArray
    rows: int


_SPLIT = re.compile(r"\s*[,;]\s*|\s+")
CHUNK_ROWS = 20_000
"""Rows parsed into one numpy block: memory stays near the size of the numbers themselves."""


SHOWN_SKIPS = 10
"""Skipped rows named one warning each; the rest are counted in the summary warning
(:func:`finish_log`) and all are listed in ``SonarLog.skipped`` (``summary.json``), so a
log whose every row is bad prints a dozen lines, not one per row."""


def report_skipped(path: Path, number: int, reason: str, skipped: list[SkippedRow]) -> None:
    """Add a skipped row to ``skipped``, with a warning for each of the first
    :data:`SHOWN_SKIPS`."""
    skipped.append(SkippedRow(str(path), number, reason))
    if len(skipped) <= SHOWN_SKIPS:
        logger.warning("%s, line %d: %s; row skipped", path, number, reason)


def row_values(fields: list[str], columns: int, n_ranges: int) -> list[float] | str:
    """The row's numbers, or why it is bad."""
    if len(fields) != columns:
        return f"expected {columns} columns, found {len(fields)}"
    head_fields, range_fields = fields[: columns - n_ranges], fields[columns - n_ranges :]
    culprit = next((f for f in head_fields if not is_decimal(f)), None)
    if culprit is None:  # a range may also be ``inf``: the reading saw no echo
        culprit = next((f for f in range_fields if f != "inf" and not is_decimal(f)), None)
    if culprit is not None:
        return f"{culprit[:40]!r} is not a plain decimal number"
    numbers = [float(field) for field in fields]
    head, tail = numbers[: columns - n_ranges], numbers[columns - n_ranges :]
    if not all(math.isfinite(v) for v in head):
        return "infinite timestamp or pose"
    if any(v < 0 for v in tail):
        return "negative range"
    return numbers


class RowBlocks:
    """Rows of ``columns`` numbers and their line numbers, gathered into numpy blocks.

    Blocks of :data:`CHUNK_ROWS` rows keep memory near the size of the numbers themselves.
    """

    def __init__(self, columns: int) -> None:
        self.columns = columns
        self._blocks: list[FloatArray] = []
        self._line_blocks: list[npt.NDArray[np.int64]] = []
        self._pending: list[list[float]] = []
        self._pending_lines: list[int] = []

    def add(self, line: int, values: list[float]) -> bool:
        """Add one row; whether a full block was just stored."""
        self._pending.append(values)
        self._pending_lines.append(line)
        if len(self._pending) < CHUNK_ROWS:
            return False
        self._flush()
        return True

    def _flush(self) -> None:
        if self._pending:
            self._blocks.append(
                np.asarray(self._pending, dtype=np.float64).reshape(-1, self.columns)
            )
            self._line_blocks.append(np.asarray(self._pending_lines, dtype=np.int64))
            self._pending.clear()
            self._pending_lines.clear()

    def table(self, rows: int) -> _Table:
        """All rows as one table (the blocks are freed as they are copied)."""
        self._flush()
        values = np.vstack(self._blocks) if self._blocks else np.zeros((0, self.columns))
        lines = (
            np.concatenate(self._line_blocks) if self._line_blocks else np.zeros(0, dtype=np.int64)
        )
        self._blocks.clear()
        self._line_blocks.clear()
        return _Table(lines, values, rows)


def _parse(
    path: Path,
    columns: int,
    n_ranges: int,
    skipped: list[SkippedRow],
    progress: ProgressHook | None = None,
    *,
    strict: bool = False,
) -> _Table:
    """Stream ``path`` line by line into numpy blocks; bad rows go to ``skipped``. With
    ``strict``, reading stops at the first bad row (the rows before it are still checked
    for order, so the caller can name the first bad line whatever its fault)."""
    parsed = RowBlocks(columns)
    rows = 0
    with LineReader(path) as handle:
        total = max(handle.size, 1)
        for number, raw in enumerate(handle, start=1):
            body = raw.decode("utf-8", errors="replace").strip().lstrip("\ufeff")
            if not body or body.startswith(_COMMENTS):
                continue
            body = body.split("#", 1)[0].strip()
            if not body:
                continue
            rows += 1
            outcome = row_values(_SPLIT.split(body), columns, n_ranges)
            if isinstance(outcome, str):
                if strict:
                    skipped.append(SkippedRow(str(path), number, outcome))
                    break
                report_skipped(path, number, outcome, skipped)
                continue
            if parsed.add(number, outcome) and progress is not None:
                progress(f"reading {path.name}", handle.consumed(), total)
    if progress is not None:
        progress(f"reading {path.name}", total, total)
    return in_order_rows(path, parsed.table(rows), skipped)


def in_order_rows(path: Path, table: _Table, skipped: list[SkippedRow]) -> _Table:
    """The rows of ``table`` whose timestamps (column 0) strictly increase (:func:`_in_order`).

    Each row left out is reported: as repeating a neighbour's timestamp, or as out of order.
    """
    values, lines = table.values, table.lines
    keep = _in_order(values[:, 0])
    if keep.all():
        return table
    kept = np.flatnonzero(keep)
    for index in np.flatnonzero(~keep):
        time = float(values[index, 0])
        kept_before, kept_after = kept[kept < index], kept[kept > index]
        twins = [k for k in (*kept_before[-1:], *kept_after[:1]) if values[k, 0] == time]
        if twins:
            reason = f"timestamp {time!r} repeats line {int(lines[twins[0]])}'s"
        else:
            after = f" (line {int(lines[kept_before[-1]])})" if len(kept_before) else ""
            reason = f"timestamp {time!r} out of order with its neighbours{after}"
        report_skipped(path, int(lines[index]), reason, skipped)
    return _Table(lines[keep], values[keep], table.rows)


def _in_order(times: FloatArray) -> npt.NDArray[np.bool_]:
    """Rows to keep so that timestamps strictly increase, losing as few rows as possible.

    The longest strictly increasing subsequence (patience sorting): one corrupt timestamp,
    however large or small, costs its own row only, not every row after it.
    """
    n = len(times)
    if n < 2 or bool(np.all(np.diff(times) > 0)):
        return np.ones(n, dtype=bool)
    tails: list[float] = []
    tail_index: list[int] = []
    parent = np.full(n, -1, dtype=np.int64)
    for i, t in enumerate(times.tolist()):
        k = bisect.bisect_left(tails, t)
        if k == len(tails):
            tails.append(t)
            tail_index.append(i)
        else:
            tails[k] = t
            tail_index[k] = i
        parent[i] = tail_index[k - 1] if k > 0 else -1
    keep = np.zeros(n, dtype=bool)
    i = tail_index[-1]
    while i >= 0:
        keep[i] = True
        i = int(parent[i])
    return keep


def read_sonar_log(
    path: str | Path,
    n_ranges: int,
    *,
    poses_path: str | Path | None = None,
    units: LogUnits = LogUnits(),  # noqa: B008 - frozen dataclass, immutable
    strict: bool = False,
    time_tolerance: float = 0.05,
    max_pose_gap: float = 1.0,
    progress: ProgressHook | None = None,
) -> SonarLog:
    """Read a sonar log (one file, or ranges and poses in two files joined by timestamp).

    Parameters
    ----------
    path
        The log: rows ``t x y heading r_1..r_N``, or ``t r_1..r_N`` when ``poses_path`` is given.
    n_ranges
        ``N``, the number of transducers.
    poses_path
        Optional pose file with rows ``t x y heading``.
    units
        Units of the columns.
    strict
        Abort at the first bad row (:class:`FormatError` naming its line) instead of skipping it.
    time_tolerance
        A ranges row takes the nearest pose within this many seconds when it cannot be
        interpolated (before the first pose, after the last, or across a gap).
    max_pose_gap
        Poses are interpolated (linear in position, shortest arc in heading) between two
        pose rows at most this many seconds apart.
    progress
        Optional hook, called as ``progress("reading <file>", bytes_read, bytes_total)``.

    Returns
    -------
    :class:`SonarLog` in SI units.

    Raises
    ------
    InputError
        A file cannot be opened, or ``n_ranges`` is not positive.
    FormatError
        With ``strict``, the first bad row; in any case, a log without one usable row.
    """
    if n_ranges < 1:
        raise InputError(f"a sonar log needs at least one range column, got n_ranges={n_ranges}")
    check_join_settings(time_tolerance, max_pose_gap)
    main = Path(path)
    skipped: list[SkippedRow] = []
    length = LENGTH_UNITS[units.position_unit]
    angle = ANGLE_UNITS[units.heading_unit]
    seconds = TIME_UNITS[units.time_unit]
    hint = f"expected {n_ranges} ranges per row"
    if poses_path is None:
        table = _parse(main, 4 + n_ranges, n_ranges, skipped, progress, strict=strict)
        _abort_if_strict(strict, skipped)
        data = table.values
        glitches = isolated_jumps(data[:, 1:3] * length)
        _report_glitches(main, table.lines[glitches], skipped)
        _abort_if_strict(strict, skipped)
        if glitches.any():  # no copy of the whole table when nothing leaps (the peak memory)
            data = data[~glitches]
        _warn_units(main, np.column_stack([data[:, 1:3] * length, data[:, 3]]), units)
        # A copy: a view would keep the whole parsed table alive beside the log.
        times, range_raw = data[:, 0] * seconds, data[:, 4:]
        poses = np.column_stack([data[:, 1:3] * length, data[:, 3] * angle])
    else:
        pose_file = Path(poses_path)
        pose_table = _parse(pose_file, 4, 0, skipped, strict=strict)
        _abort_if_strict(strict, skipped)
        if not len(pose_table.values):
            dropped = sum(1 for row in skipped if row.path == str(pose_file))
            raise FormatError(
                f"no usable pose rows ({dropped} skipped; rows are 't x y heading')"
                if dropped
                else "no pose rows (rows are 't x y heading')",
                path=pose_file,
            )
        table = _parse(main, 1 + n_ranges, n_ranges, skipped, progress, strict=strict)
        logged = pose_table.values[:, 1:]
        _warn_units(pose_file, np.column_stack([logged[:, :2] * length, logged[:, 2]]), units)
        pose_si = pose_table.values * np.array([seconds, length, length, angle])
        table.values[:, 0] *= seconds
        times, range_raw, poses = posed_rows(
            (main, table),
            (pose_file, _Table(pose_table.lines, pose_si, pose_table.rows)),
            skipped,
            strict,
            time_tolerance,
            max_pose_gap,
        )
        if len(table.values) and not len(times) and units.time_unit == "s":
            hint += "; if the timestamps are not in seconds, give --time-unit (ms, us or ns)"
    ranges = range_raw * LENGTH_UNITS[units.range_unit]
    return finish_log(main, times, poses, ranges, table.rows, skipped, hint)


def check_join_settings(time_tolerance: float, max_pose_gap: float) -> None:
    """Refuse a negative pose-join setting (:func:`join_poses`) with an :class:`InputError`."""
    if not (time_tolerance >= 0 and max_pose_gap >= 0):
        raise InputError(
            "need time_tolerance >= 0 and max_pose_gap >= 0 s, "
            f"got {time_tolerance}, {max_pose_gap}"
        )


def posed_rows(
    ranges: tuple[Path, _Table],
    poses: tuple[Path, _Table],
    skipped: list[SkippedRow],
    strict: bool,
    time_tolerance: float,
    max_pose_gap: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Join timed ranges rows ``t r_1..r_N`` to timed pose rows ``t x y heading`` [s, m, rad].

    Pose rows that leap away and back are skipped first; each ranges row then takes its pose
    from :func:`join_poses`, or is skipped and reported. ``strict`` aborts at the first bad row
    found so far. Returns the kept rows' times, ranges and ``(n, 3)`` poses.
    """
    (main, table), (pose_file, pose_table) = ranges, poses
    _abort_if_strict(strict, skipped)
    glitches = isolated_jumps(pose_table.values[:, 1:3])
    _report_glitches(pose_file, pose_table.lines[glitches], skipped)
    _abort_if_strict(strict, skipped)
    pose_data = pose_table.values[~glitches] if glitches.any() else pose_table.values
    times, range_raw = table.values[:, 0], table.values[:, 1:]
    joined, why = join_poses(times, pose_data[:, 0], pose_data[:, 1:], time_tolerance, max_pose_gap)
    keep = why == ""
    for number, reason in zip(table.lines[~keep], why[~keep], strict=True):
        report_skipped(main, int(number), str(reason), skipped)
    _abort_if_strict(strict, skipped)
    return times[keep], range_raw[keep], joined[keep]


def ring_log(
    source: Path,
    rings: _Table,
    poses: _Table,
    skipped: list[SkippedRow],
    join: tuple[bool, float, float],
    hint: str,
    ring: SonarGeometry | None,
) -> RingLog:
    """The :class:`RingLog` of a file that holds both its rings and its odometry (a Player
    or CARMEN log): each table put in time order (:func:`in_order_rows`), the rings joined
    to the poses (:func:`posed_rows`; ``join`` is ``strict, time_tolerance,
    max_pose_gap``) and the log finished (:func:`finish_log`, ``hint`` for an empty one)."""
    times, ranges, joined = posed_rows(
        (source, in_order_rows(source, rings, skipped)),
        (source, in_order_rows(source, poses, skipped)),
        skipped,
        *join,
    )
    return RingLog(finish_log(source, times, joined, ranges, rings.rows, skipped, hint), ring)


def finish_log(
    main: Path,
    times: FloatArray,
    poses: FloatArray,
    ranges: FloatArray,
    rows: int,
    skipped: list[SkippedRow],
    hint: str,
) -> SonarLog:
    """The :class:`SonarLog` of the kept rows, with one summary warning of the rows skipped.

    Raises :class:`FormatError` (with ``hint`` on what a row should hold) when no row is kept.
    """
    if len(times) == 0:
        raise FormatError(f"no usable rows ({len(skipped)} skipped; {hint})", path=main)
    skipped.sort(key=lambda row: (row.path != str(main), row.line))
    where = (
        "see the warnings above or summary.json"
        if len(skipped) <= SHOWN_SKIPS
        else f"the first {SHOWN_SKIPS} are named above, all in summary.json"
    )
    for name, count in Counter(row.path for row in skipped).items():
        if name == str(main):
            share = f"{count} of {rows} rows skipped ({100.0 * count / max(rows, 1):.1f} %)"
        else:
            share = f"{count} row{'s' if count != 1 else ''} skipped"
        logger.warning("%s: %s; %s", name, share, where)
    return SonarLog(times, poses, ranges, rows, tuple(skipped))


def _warn_units(path: Path, poses: FloatArray, units: LogUnits) -> None:
    """Warn of positions and headings ``(n, 3)`` [m, m, as logged] that look like another
    unit than the log's."""
    hints = (
        position_unit_hint(poses[:, :2], units.position_unit),
        heading_unit_hint(poses[:, 2], units.heading_unit),
    )
    for hint in hints:
        if hint is not None:
            logger.warning("%s: %s", path, hint)


def _report_glitches(path: Path, lines: npt.NDArray[np.int64], skipped: list[SkippedRow]) -> None:
    """Skip the rows whose position leaps away and straight back (:func:`isolated_jumps`)."""
    for number in lines.tolist():
        report_skipped(
            path, int(number), f"position leaps over {MAX_POSE_JUMP:g} m away and back", skipped
        )


def _abort_if_strict(strict: bool, skipped: list[SkippedRow]) -> None:
    if strict and skipped:
        first = min(skipped, key=lambda row: (row.path, row.line))
        raise FormatError(
            first.reason + " (drop --strict to skip bad rows)", path=first.path, line=first.line
        )


def join_poses(
    times: FloatArray,
    pose_times: FloatArray,
    poses: FloatArray,
    tolerance: float,
    max_gap: float,
) -> tuple[FloatArray, npt.NDArray[np.str_]]:
    """A pose for each of ``times`` from poses ``(m, 3)`` [m, m, rad] at ``pose_times``.

    Interpolated between the bracketing poses when they are at most ``max_gap`` [s] apart
    (linear in position, shortest arc in heading), else the nearest pose within
    ``tolerance`` [s]. Returns ``(n, 3)`` poses and, per time, why none was found ("" if
    one was).
    """
    n = len(times)
    out = np.full((n, 3), np.nan)
    why = np.full(n, "", dtype=object)
    if len(pose_times) == 0:
        why[:] = "no pose rows to join"
        return out, why.astype(str)
    right = np.clip(np.searchsorted(pose_times, times, side="left"), 0, len(pose_times) - 1)
    left = np.clip(np.searchsorted(pose_times, times, side="right") - 1, 0, len(pose_times) - 1)
    t0, t1 = pose_times[left], pose_times[right]
    inside = (t0 <= times) & (times <= t1)
    gap = t1 - t0
    interpolate = inside & (gap <= max_gap)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(gap > 0, (times - t0) / gap, 0.0)
    p0, p1 = poses[left], poses[right]
    turn = wrap_angle(p1[:, 2] - p0[:, 2])
    blend = np.column_stack([p0[:, :2] + w[:, None] * (p1[:, :2] - p0[:, :2]), p0[:, 2] + w * turn])
    blend[:, 2] = wrap_angle(blend[:, 2])
    out[interpolate] = blend[interpolate]
    nearest = np.where(np.abs(t0 - times) <= np.abs(t1 - times), left, right)
    distance = np.abs(pose_times[nearest] - times)
    fallback = ~interpolate & (distance <= tolerance)
    out[fallback] = poses[nearest[fallback]]
    missing = ~(interpolate | fallback)
    for i in np.flatnonzero(missing):
        if inside[i]:
            why[i] = (
                f"poses around t={float(times[i])!r} are {float(gap[i]):.3g} s apart "
                f"(more than the {max_gap} s max pose gap) and none is within {tolerance} s"
            )
        else:
            why[i] = (
                f"no pose for timestamp {float(times[i])!r}: nearest {float(distance[i]):.3g} s "
                f"away (tolerance {tolerance} s)"
            )
    return out, why.astype(str)


def write_sonar_log(
    path: str | Path,
    timestamps: npt.ArrayLike,
    ranges: npt.ArrayLike,
    poses: npt.ArrayLike | None = None,
    *,
    units: LogUnits = LogUnits(),  # noqa: B008 - frozen dataclass, immutable
    delimiter: str = " ",
    comments: Sequence[str] = (),
) -> Path:
    """Write a log in the format :func:`read_sonar_log` reads (SI inputs, converted to ``units``).

    With ``poses`` the rows are ``t x y heading r_1..r_N``; without, ``t r_1..r_N``; with
    ``ranges`` of zero columns and ``poses`` given, a pose file ``t x y heading``.
    """
    t = np.asarray(timestamps, dtype=np.float64).reshape(-1, 1) / TIME_UNITS[units.time_unit]
    r = np.asarray(ranges, dtype=np.float64).reshape(len(t), -1) / LENGTH_UNITS[units.range_unit]
    columns = [t]
    if poses is not None:
        p = np.asarray(poses, dtype=np.float64).reshape(len(t), 3)
        columns.append(p[:, :2] / LENGTH_UNITS[units.position_unit])
        columns.append(p[:, 2:] / ANGLE_UNITS[units.heading_unit])
    columns.append(r)
    table = np.hstack(columns)
    header = "".join(f"# {line}\n" for line in comments)
    # Timestamps exactly (shortest round trip: epoch stamps need all their digits), the
    # rest to 10 significant digits.
    body = "\n".join(
        delimiter.join([repr(float(row[0])), *(f"{float(v):.10g}" for v in row[1:])])
        for row in table
    )
    return write_text(path, header + body + "\n")
