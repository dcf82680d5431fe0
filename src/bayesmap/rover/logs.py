"""Logged rover drives and IR calibrations: CSV files in, readings and poses out.

A drive log is a CSV file with a header naming its columns: ``x``, ``y``, ``heading`` and
one column per ranger, ``ir_0``, ``ir_1``, … (8-bit ADC readings, in the order of
``RoverParams.sensor_angles``); other columns (a timestamp, say) are ignored. Units of the
pose columns are given by the caller (:data:`~bayesmap.sonar.logs.LENGTH_UNITS`,
:data:`~bayesmap.sonar.logs.ANGLE_UNITS`) and converted to SI here, once. The file may be
gzip-compressed. Blank lines and lines starting with ``#`` are skipped; bytes that are not
UTF-8 cost only the row they are in. A bad row (wrong number of fields, a field that is
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
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bayesmap._io import LineReader
from bayesmap._numbers import is_decimal
from bayesmap._typing import FloatArray, ProgressHook
from bayesmap.errors import FormatError, InputError
from bayesmap.geometry import MAX_POSE_JUMP, isolated_jumps
from bayesmap.sensing.ir import Calibration, calibration_problem, fit_calibration
from bayesmap.sonar.logs import (
    ANGLE_UNITS,
    LENGTH_UNITS,
    SHOWN_SKIPS,
    RowBlocks,
    SkippedRow,
    heading_unit_hint,
    position_unit_hint,
)

__all__ = ["RoverLog", "read_calibration", "read_rover_log"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RoverLog:
    """What a drive log holds: ``(n, 3)`` poses ``(x [m], y [m], heading [rad])``, ``(n, k)``
    ADC readings, and the rows left out with the reason."""

    poses: FloatArray
    raw: FloatArray
    skipped: tuple[SkippedRow, ...]


def _csv_rows(handle: LineReader) -> Iterator[tuple[int, list[str]]]:
    """``(line number, fields)`` of the non-blank, non-comment lines of a CSV file; a byte
    that is not UTF-8 becomes U+FFFD (a bad number costs its row; a comment is skipped)."""
    for number, raw in enumerate(handle, start=1):
        line = raw.decode("utf-8", errors="replace").lstrip("\ufeff").rstrip("\r\n")
        if line.strip() and not line.lstrip().startswith("#"):
            yield number, next(csv.reader([line]))


def _columns(path: Path, header: list[str], line: int, wanted: list[str]) -> list[int]:
    names = [name.strip().lower() for name in header]
    missing = [name for name in wanted if name not in names]
    if missing:
        raise FormatError(
            f"the header lacks the column(s) {', '.join(missing)} (found {', '.join(names)})",
            path=path,
            line=line,
        )
    twice = [name for name in wanted if names.count(name) > 1]
    if twice:
        raise FormatError(
            f"the header names the column {twice[0]} more than once; which one is meant?",
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
    progress: ProgressHook | None = None,
) -> RoverLog:
    """Read a drive log (see the module docstring) into SI poses and raw readings.

    The file is streamed line by line (gunzipped on the fly if compressed) into numpy
    blocks, so memory stays near the size of the numbers; ``progress`` is called as
    ``progress("reading NAME", bytes_read, bytes_total)`` every
    :data:`~bayesmap.sonar.logs.CHUNK_ROWS` rows and at the end.
    """
    file = Path(path)
    if position_unit not in LENGTH_UNITS or heading_unit not in ANGLE_UNITS:
        raise InputError(
            f"units must be one of {list(LENGTH_UNITS)} and {list(ANGLE_UNITS)}, got "
            f"{position_unit!r}, {heading_unit!r}"
        )
    wanted = ["x", "y", "heading", *(f"ir_{k}" for k in range(n_rangers))]
    skipped: list[SkippedRow] = []

    def skip(number: int, reason: str) -> None:
        if strict:
            raise FormatError(reason, path=file, line=number)
        if len(skipped) < SHOWN_SKIPS:
            logger.warning("%s, line %d: %s; row skipped", file, number, reason)
        skipped.append(SkippedRow(str(file), number, reason))

    blocks = RowBlocks(len(wanted))
    header: list[str] | None = None
    index: list[int] = []
    rows = 0
    with LineReader(file) as handle:
        for number, fields in _csv_rows(handle):
            if header is None:
                header = fields
                index = _columns(file, header, number, wanted)
                continue
            rows += 1
            reason = _row_problem(fields, len(header), index, wanted)
            if isinstance(reason, str):
                skip(number, reason)
                continue
            if blocks.add(number, reason) and progress is not None:
                progress(f"reading {file.name}", handle.consumed(), max(handle.size, 1))
    if progress is not None:
        progress(f"reading {file.name}", 1, 1)
    if header is None:
        raise FormatError("the file holds no header and no rows", path=file)
    found = blocks.table(rows)
    if not len(found.values):
        raise FormatError("no usable rows", path=file)
    table, lines = found.values, found.lines
    xy = table[:, :2] * LENGTH_UNITS[position_unit]
    glitches = isolated_jumps(xy)
    for k in np.flatnonzero(glitches).tolist():
        skip(int(lines[k]), f"the position leaps over {MAX_POSE_JUMP:g} m away and back")
    if glitches.any():  # no copy of the whole table when nothing leaps
        table, xy = table[~glitches], xy[~glitches]
    steps = np.hypot(*np.diff(xy, axis=0).T)
    if steps.size and float(np.median(steps)) > MAX_POSE_JUMP:
        logger.warning(
            "%s: the poses lie %.3g m apart (median): are the positions in cm or mm? "
            "give --position-unit",
            file,
            float(np.median(steps)),
        )
    for hint in (
        position_unit_hint(xy, position_unit),
        heading_unit_hint(table[:, 2], heading_unit),
    ):
        if hint is not None:
            logger.warning("%s: %s", file, hint)
    if len(skipped) > SHOWN_SKIPS:
        logger.warning(
            "%s: %d of %d rows skipped; the first %d are named above, all in summary.json",
            file,
            len(skipped),
            rows,
            SHOWN_SKIPS,
        )
    poses = np.column_stack([xy, table[:, 2] * ANGLE_UNITS[heading_unit]])
    skipped.sort(key=lambda row: row.line)
    return RoverLog(poses, table[:, 3:], tuple(skipped))


def _row_problem(
    fields: list[str], columns: int, index: list[int], names: list[str]
) -> list[float] | str:
    """The wanted numbers of a data row (columns ``names`` at ``index``), or why the row
    is bad, naming the column."""
    if len(fields) != columns:
        return f"{len(fields)} fields, the header has {columns}"
    row = []
    for name, k in zip(names, index, strict=True):
        field = fields[k].strip()
        value = float(field) if is_decimal(field) else math.nan
        if not math.isfinite(value):
            return f"column {name}: {field!r} is not a finite plain decimal number"
        if name.startswith("ir_") and not 0.0 <= value <= 255.0:
            return f"column {name}: the IR reading {field} is outside 0..255"
        row.append(value)
    return row


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
    with LineReader(file) as handle:
        rows = list(_csv_rows(handle))
    if not rows:
        raise FormatError("the file holds no header and no rows", path=file)
    (header_line, header), *rows = rows
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
