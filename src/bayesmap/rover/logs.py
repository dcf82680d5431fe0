"""Logged rover drives and IR calibrations: CSV files in, readings and poses out.

A drive log is a CSV file with a header naming its columns: ``x``, ``y``, ``heading`` and
one column per ranger, ``ir_0``, ``ir_1``, … (8-bit ADC readings, in the order of
``RoverParams.sensor_angles``); other columns (a timestamp, say) are ignored. Units of the
pose columns are given by the caller (:data:`~bayesmap.sonar.logs.LENGTH_UNITS`,
:data:`~bayesmap.sonar.logs.ANGLE_UNITS`) and converted to SI here, once. Blank lines and
lines starting with ``#`` are skipped. A bad row (wrong number of fields, a field that is
not a finite number, a reading outside 0..255) is reported with its line number and left
out, or, with ``strict=True``, aborts the read with a :class:`~bayesmap.errors.FormatError`.

An IR calibration is either a JSON file ``{"a": .., "b": .., "c": ..}`` (the fit
``r_raw = (a r + b) / (r + c)`` of Post et al. 2016 §5.1, ``r`` in metres) or a CSV file of
pairs with columns ``raw`` and ``distance``, to which that fit is made
(:func:`~bayesmap.sensing.ir.fit_calibration`).
"""

from __future__ import annotations

import csv
import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayesmap._io import GZIP_MAGIC, gunzip_bytes, read_input
from bayesmap._numbers import is_decimal
from bayesmap._typing import FloatArray
from bayesmap.errors import FormatError, InputError
from bayesmap.geometry import MAX_POSE_JUMP, isolated_jumps
from bayesmap.limits import DEFAULT_LIMITS
from bayesmap.sensing.ir import Calibration, calibration_problem, fit_calibration
from bayesmap.sonar.logs import ANGLE_UNITS, LENGTH_UNITS, SkippedRow

__all__ = ["RoverLog", "read_calibration", "read_rover_log"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RoverLog:
    """What a drive log holds: ``(n, 3)`` poses ``(x [m], y [m], heading [rad])``, ``(n, k)``
    ADC readings, and the rows left out with the reason."""

    poses: FloatArray
    raw: FloatArray
    skipped: tuple[SkippedRow, ...]


def _rows(path: Path) -> list[tuple[int, list[str]]]:
    """``(line number, fields)`` of the non-blank, non-comment lines of a CSV file."""
    limit = DEFAULT_LIMITS.max_bytes
    data = read_input(path, max_bytes=limit)  # a regular file, bounded
    if data.startswith(GZIP_MAGIC):  # a compressed log, whatever its name
        data = gunzip_bytes(data, limit, str(path))
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise FormatError(f"the file is not UTF-8 text ({error})", path=path) from None
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        if line.strip() and not line.lstrip().startswith("#"):
            rows.append((number, next(csv.reader([line]))))
    if not rows:
        raise FormatError("the file holds no header and no rows", path=path)
    return rows


def _columns(path: Path, header: list[str], line: int, wanted: list[str]) -> list[int]:
    names = [name.strip().lower() for name in header]
    missing = [name for name in wanted if name not in names]
    if missing:
        raise FormatError(
            f"the header lacks the column(s) {', '.join(missing)} (found {', '.join(names)})",
            path=path,
            line=line,
        )
    return [names.index(name) for name in wanted]


def read_rover_log(
    path: str | Path,
    n_rangers: int,
    *,
    position_unit: str = "m",
    heading_unit: str = "rad",
    strict: bool = False,
) -> RoverLog:
    """Read a drive log (see the module docstring) into SI poses and raw readings."""
    file = Path(path)
    if position_unit not in LENGTH_UNITS or heading_unit not in ANGLE_UNITS:
        raise InputError(
            f"units must be one of {list(LENGTH_UNITS)} and {list(ANGLE_UNITS)}, got "
            f"{position_unit!r}, {heading_unit!r}"
        )
    (header_line, header), *rows = _rows(file)
    wanted = ["x", "y", "heading", *(f"ir_{k}" for k in range(n_rangers))]
    index = _columns(file, header, header_line, wanted)
    values: list[list[float]] = []
    lines: list[int] = []
    skipped: list[SkippedRow] = []

    def skip(number: int, reason: str) -> None:
        if strict:
            raise FormatError(reason, path=file, line=number)
        logger.warning("%s, line %d: %s; row skipped", file, number, reason)
        skipped.append(SkippedRow(str(file), number, reason))

    for number, fields in rows:
        reason = None
        if len(fields) != len(header):
            reason = f"{len(fields)} fields, the header has {len(header)}"
        else:
            wanted = [fields[k].strip() for k in index]
            plain = all(is_decimal(field) for field in wanted)
            row = [float(field) for field in wanted] if plain else []
            if not plain or not all(math.isfinite(v) for v in row):
                reason = "a field is not a finite plain decimal number"
            elif not all(0.0 <= v <= 255.0 for v in row[3:]):
                reason = "an IR reading outside 0..255"
        if reason is not None:
            skip(number, reason)
            continue
        values.append(row)
        lines.append(number)
    if not values:
        raise FormatError("no usable rows", path=file)
    table = np.asarray(values, dtype=np.float64)
    xy = table[:, :2] * LENGTH_UNITS[position_unit]
    glitches = isolated_jumps(xy)
    for k in np.flatnonzero(glitches).tolist():
        skip(lines[k], f"the position leaps over {MAX_POSE_JUMP:g} m away and back")
    table, xy = table[~glitches], xy[~glitches]
    steps = np.hypot(*np.diff(xy, axis=0).T)
    if steps.size and float(np.median(steps)) > MAX_POSE_JUMP:
        logger.warning(
            "%s: the poses lie %.3g m apart (median): are the positions in cm or mm? "
            "give --position-unit",
            file,
            float(np.median(steps)),
        )
    poses = np.column_stack([xy, table[:, 2] * ANGLE_UNITS[heading_unit]])
    skipped.sort(key=lambda row: row.line)
    return RoverLog(poses, table[:, 3:], tuple(skipped))


MAX_CALIBRATION_DISTANCE = 10.0
"""Longest calibration distance [m] taken as metres: IR rangers like the rover's read up to
a few metres (the paper's to 2 m), so a larger number is a distance in cm or mm."""


def read_calibration(path: str | Path, *, distance_unit: str = "m") -> Calibration:
    """An IR calibration from a JSON fit or a CSV of ``raw, distance`` pairs (fitted)."""
    file = Path(path)
    if file.suffix.lower() == ".json":
        try:
            document = json.loads(file.read_text(encoding="utf-8"))
            numbers = [document[key] for key in ("a", "b", "c")]
            if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in numbers):
                raise TypeError("not JSON numbers")
            fit = tuple(float(v) for v in numbers)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
            raise FormatError(f"cannot read the calibration ({error})", path=file) from None
        except (KeyError, TypeError, ValueError):
            raise FormatError(
                'a JSON calibration needs numbers "a", "b" and "c"', path=file
            ) from None
        calibration = (fit[0], fit[1], fit[2])
        problem = calibration_problem(calibration)
        if problem is not None:
            raise FormatError(problem, path=file)
        return calibration
    if distance_unit not in LENGTH_UNITS:
        raise InputError(
            f"distance unit must be one of {list(LENGTH_UNITS)}, got {distance_unit!r}"
        )
    (header_line, header), *rows = _rows(file)
    raw_col, distance_col = _columns(file, header, header_line, ["raw", "distance"])
    pairs = []
    for number, fields in rows:
        pair = [
            f.strip()
            for f in fields[raw_col : raw_col + 1] + fields[distance_col : distance_col + 1]
        ]
        if len(pair) == 2 and all(is_decimal(field) for field in pair):
            pairs.append((float(pair[0]), float(pair[1])))
        else:
            raise FormatError("expected two numbers (raw, distance)", path=file, line=number)
    raw, distance = np.asarray(pairs, dtype=np.float64).reshape(-1, 2).T
    metres = distance * LENGTH_UNITS[distance_unit]
    if metres.size and np.nanmax(metres) > MAX_CALIBRATION_DISTANCE:
        raise FormatError(
            f"distances up to {np.nanmax(metres):g} m, beyond the {MAX_CALIBRATION_DISTANCE:g} m "
            "an IR ranger reads (are they in cm or mm? pass --distance-unit)",
            path=file,
        )
    try:
        return fit_calibration(raw, metres)
    except InputError as error:
        raise FormatError(str(error), path=file) from None
