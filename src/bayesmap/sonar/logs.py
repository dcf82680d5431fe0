"""Plain-text sonar logs of real robots: read (tolerantly or strictly) and write.

A log holds one row per ring: ``timestamp x y heading r_1 ... r_N``, separated by commas or
by whitespace. Alternatively the ranges (``timestamp r_1 ... r_N``) and the poses
(``timestamp x y heading``) sit in two files joined by timestamp. Units are converted to SI
once, here: ranges and positions from mm, cm or m; headings from rad, deg or decidegrees.

Real logs are untidy. Blank lines and comments (``#``, ``%``, ``//`` or ``;`` at the start of
a line; anything after ``#`` on a line) are ignored; a last line without a newline and
Windows line endings are fine. Bad rows — a non-numeric or empty field, NaN, a negative
range, the wrong number of columns, a timestamp not after the previous row's, no pose for a
timestamp — are reported with their line numbers (logged as warnings and returned in
``skipped``) and left out, or, with ``strict=True``, abort the read with a
:class:`~bayesmap.errors.FormatError` naming the file and line.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from bayesmap._io import write_text
from bayesmap._typing import FloatArray, Poses, Ranges
from bayesmap.errors import FormatError, InputError

__all__ = [
    "ANGLE_UNITS",
    "LENGTH_UNITS",
    "LogUnits",
    "SkippedRow",
    "SonarLog",
    "read_sonar_log",
    "write_sonar_log",
]

logger = logging.getLogger(__name__)

LENGTH_UNITS: dict[str, float] = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
"""Metres per unit of length."""
ANGLE_UNITS: dict[str, float] = {"rad": 1.0, "deg": math.pi / 180.0, "decideg": math.pi / 1800.0}
"""Radians per unit of angle."""

_COMMENTS = ("#", "%", "//", ";")


@dataclass(frozen=True)
class LogUnits:
    """Units of a log's columns.

    Ranges and positions in ``mm``, ``cm`` or ``m``; heading in ``rad``, ``deg`` or ``decideg``.
    """

    range_unit: Literal["mm", "cm", "m"] = "m"
    position_unit: Literal["mm", "cm", "m"] = "m"
    heading_unit: Literal["rad", "deg", "decideg"] = "rad"

    def __post_init__(self) -> None:
        for name, value, table in (
            ("range unit", self.range_unit, LENGTH_UNITS),
            ("position unit", self.position_unit, LENGTH_UNITS),
            ("heading unit", self.heading_unit, ANGLE_UNITS),
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


class _Table(NamedTuple):
    lines: list[int]
    values: list[list[float]]
    rows: int


_SPLIT = re.compile(r"\s*,\s*|\s+")


def _skip(path: Path, number: int, reason: str, strict: bool, skipped: list[SkippedRow]) -> None:
    """Record a bad row (and log it), or with ``strict`` raise :class:`FormatError` for it."""
    if strict:
        raise FormatError(reason + " (drop --strict to skip bad rows)", path=path, line=number)
    skipped.append(SkippedRow(str(path), number, reason))
    logger.warning("%s, line %d: %s; row skipped", path, number, reason)


def _parse(
    path: Path, columns: int, n_ranges: int, strict: bool, skipped: list[SkippedRow]
) -> _Table:
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise InputError(f"cannot read sonar log {path}: {error.strerror or error}") from None
    text = raw.decode("utf-8", errors="replace")
    lines: list[int] = []
    values: list[list[float]] = []
    rows = 0
    last_time = -math.inf
    last_line = 0

    def bad(number: int, reason: str) -> None:
        _skip(path, number, reason, strict, skipped)

    for number, line in enumerate(text.split("\n"), start=1):
        body = line.strip().lstrip("\ufeff")
        if not body or body.startswith(_COMMENTS):
            continue
        body = body.split("#", 1)[0].strip()
        if not body:
            continue
        rows += 1
        fields = _SPLIT.split(body)
        if len(fields) != columns:
            bad(number, f"expected {columns} columns, found {len(fields)}")
            continue
        try:
            numbers = [float(field) for field in fields]
        except ValueError:
            culprit = next(f for f in fields if not _is_float(f))
            bad(number, f"non-numeric or empty field {culprit[:40]!r}")
            continue
        if any(math.isnan(v) for v in numbers):
            bad(number, "NaN in row")
            continue
        head, tail = numbers[: columns - n_ranges], numbers[columns - n_ranges :]
        if not all(math.isfinite(v) for v in head):
            bad(number, "infinite timestamp or pose")
            continue
        if any(v < 0 for v in tail):
            bad(number, "negative range")
            continue
        if numbers[0] <= last_time:
            bad(
                number,
                f"timestamp {numbers[0]!r} is not after the previous row's (line {last_line})",
            )
            continue
        last_time, last_line = numbers[0], number
        lines.append(number)
        values.append(numbers)
    return _Table(lines, values, rows)


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_sonar_log(
    path: str | Path,
    n_ranges: int,
    *,
    poses_path: str | Path | None = None,
    units: LogUnits = LogUnits(),  # noqa: B008 - frozen dataclass, immutable
    strict: bool = False,
    time_tolerance: float = 1e-6,
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
        Abort at the first bad row (:class:`FormatError`) instead of skipping it.
    time_tolerance
        Largest difference [s] between a ranges row's and a pose row's timestamps to join them.

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
    main = Path(path)
    skipped: list[SkippedRow] = []
    if poses_path is None:
        table = _parse(main, 4 + n_ranges, n_ranges, strict, skipped)
        data = np.asarray(table.values, dtype=np.float64).reshape(-1, 4 + n_ranges)
        times, pose_raw, range_raw = data[:, 0], data[:, 1:4], data[:, 4:]
    else:
        pose_file = Path(poses_path)
        pose_table = _parse(pose_file, 4, 0, strict, skipped)
        table = _parse(main, 1 + n_ranges, n_ranges, strict, skipped)
        pose_data = np.asarray(pose_table.values, dtype=np.float64).reshape(-1, 4)
        data = np.asarray(table.values, dtype=np.float64).reshape(-1, 1 + n_ranges)
        times, range_raw = data[:, 0], data[:, 1:]
        match = _join(times, pose_data[:, 0], time_tolerance)
        keep = match >= 0
        for number, t in zip(np.asarray(table.lines)[~keep], times[~keep], strict=True):
            reason = f"no pose for timestamp {float(t)!r} within {time_tolerance} s"
            _skip(main, int(number), reason, strict, skipped)
        times, range_raw = times[keep], range_raw[keep]
        pose_raw = pose_data[match[keep], 1:4]
    if len(times) == 0:
        raise FormatError(
            f"no usable rows ({len(skipped)} skipped; expected {n_ranges} ranges per row)",
            path=main,
        )
    length = LENGTH_UNITS[units.position_unit]
    poses = np.column_stack(
        [pose_raw[:, :2] * length, pose_raw[:, 2] * ANGLE_UNITS[units.heading_unit]]
    )
    ranges = range_raw * LENGTH_UNITS[units.range_unit]
    skipped.sort(key=lambda row: (row.path != str(main), row.line))
    return SonarLog(times, poses, ranges, table.rows, tuple(skipped))


def _join(times: FloatArray, pose_times: FloatArray, tolerance: float) -> npt.NDArray[np.int64]:
    """Index of the pose row nearest each time, or −1 when none is within ``tolerance``."""
    if len(pose_times) == 0:
        return np.full(len(times), -1, dtype=np.int64)
    right = np.clip(np.searchsorted(pose_times, times), 0, len(pose_times) - 1)
    left = np.clip(right - 1, 0, len(pose_times) - 1)
    nearest = np.where(
        np.abs(pose_times[left] - times) <= np.abs(pose_times[right] - times), left, right
    )
    ok = np.abs(pose_times[nearest] - times) <= tolerance
    return np.where(ok, nearest, -1).astype(np.int64)


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
    t = np.asarray(timestamps, dtype=np.float64).reshape(-1, 1)
    r = np.asarray(ranges, dtype=np.float64).reshape(len(t), -1) / LENGTH_UNITS[units.range_unit]
    columns = [t]
    if poses is not None:
        p = np.asarray(poses, dtype=np.float64).reshape(len(t), 3)
        columns.append(p[:, :2] / LENGTH_UNITS[units.position_unit])
        columns.append(p[:, 2:] / ANGLE_UNITS[units.heading_unit])
    columns.append(r)
    table = np.hstack(columns)
    header = "".join(f"# {line}\n" for line in comments)
    body = "\n".join(delimiter.join(f"{float(v):.10g}" for v in row) for row in table)
    return write_text(path, header + body + "\n")
