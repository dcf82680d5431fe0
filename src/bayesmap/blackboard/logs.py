"""Logged whisker sweeps: a CSV or Parquet table in, each pose with its sweep rows out.

A sweep log has one row per whisker sweep and a header naming its columns:

- ``pose``: an integer shared by the sweeps taken at one robot pose; poses are mapped in
  the order they first appear;
- ``x``, ``y``, ``heading``: that pose (every whisker's root [m], the heading [rad]),
  the same on each of its rows;
- ``start``, ``stop``: the whisker's angle in the world frame where the sweep began and
  where it ended (at the contact, or fully protracted) [rad];
- ``length``: the whisker's length [m];
- ``range``, ``normal``: the contact's distance from the root [m] and the touched
  surface's normal [rad], both blank when the sweep touched nothing;
- ``texture`` (optional): the contact's texture reading.

These are the rows :meth:`~bayesmap.blackboard.fused.FusedMapper.step` takes
(:data:`~bayesmap.blackboard.evidence.SWEEP_FIELDS`), so a real robot's log and the
simulator (:func:`~bayesmap.sim.whiskers.observe`) meet there. Other columns (a timestamp,
say) are ignored. A ``.parquet`` file is read with pandas' Parquet reader, anything else as
CSV (``#`` comment lines skipped, gzip by the ``.gz`` extension). Lengths are given in
``length_unit`` and angles in ``angle_unit`` and converted to SI once, here. Every problem
is a :class:`~bayesmap.errors.FormatError` naming the file, the data row (1 = the first row
after the header) and the column.
"""

from __future__ import annotations

import gzip
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from bayesmap._io import write_bytes
from bayesmap._typing import FloatArray
from bayesmap.blackboard.evidence import SWEEP_FIELDS
from bayesmap.errors import FormatError, InputError
from bayesmap.sonar.logs import ANGLE_UNITS, LENGTH_UNITS

__all__ = ["SweepLog", "angle_unit_hint", "read_sweep_log", "write_sweep_log"]

POSE_COLUMNS = ("x", "y", "heading")
REQUIRED = ("pose", *POSE_COLUMNS, "start", "stop", "length", "range", "normal")
LENGTHS = {"x", "y", "length", "range"}
ANGLES = {"heading", "start", "stop", "normal"}


@dataclass(frozen=True)
class SweepLog:
    """A sweep log: ``(m, 3)`` poses ``x, y`` [m], heading [rad], and for each pose its
    ``(w_i, 6)`` sweep rows (columns :data:`~bayesmap.blackboard.evidence.SWEEP_FIELDS`)."""

    poses: FloatArray
    sweeps: tuple[FloatArray, ...]
    largest_angle: float = 0.0
    """The largest magnitude of any angle as logged, in the log's angle unit."""

    @property
    def whisker_length(self) -> float:
        """The longest whisker of the log [m]."""
        return float(max(float(s[:, 2].max()) for s in self.sweeps))


def read_sweep_log(
    path: str | Path, *, length_unit: str = "m", angle_unit: str = "rad"
) -> SweepLog:
    """Read a sweep log (see the module) into poses and sweep rows, in SI units.

    Raises
    ------
    InputError
        An unknown unit.
    FormatError
        The file cannot be read, lacks a column, holds a value that is not a number where
        one is needed, a non-positive whisker length, a negative range or one over ten
        whisker lengths, a contact without a normal, or a pose whose rows disagree; the
        message names the row and column.
    """
    if length_unit not in LENGTH_UNITS or angle_unit not in ANGLE_UNITS:
        raise InputError(
            f"units must be one of {sorted(LENGTH_UNITS)} and {sorted(ANGLE_UNITS)}, "
            f"got {length_unit!r} and {angle_unit!r}"
        )
    where = str(path)
    table = _table(Path(path))
    missing = [c for c in REQUIRED if c not in table.columns]
    if missing:
        raise FormatError(
            f"no column(s) {missing}; a sweep log has the columns {', '.join(REQUIRED)} "
            "(and optionally texture)",
            path=where,
        )
    if table.empty:
        raise FormatError("the log has no rows", path=where)
    columns = [*REQUIRED, *(["texture"] if "texture" in table.columns else [])]
    values = {c: _numbers(table[c], c, where) for c in columns}
    for column in ("pose", *POSE_COLUMNS, "start", "stop", "length"):
        _require(~np.isfinite(values[column]), where, f"{column} must be a finite number")
    _require(values["pose"] != np.round(values["pose"]), where, "pose must be an integer id")
    _require(values["length"] <= 0, where, "length must be > 0")
    contact = np.isfinite(values["range"])
    _require(contact & (values["range"] < 0), where, "range must be >= 0 (blank: no contact)")
    _require(  # noise carries a contact past the tip (σ 0.5 m on 1 m whiskers), not this far
        contact & (values["range"] > 10.0 * values["length"]),
        where,
        "range is over 10 whisker lengths: a contact lies on the whisker (are range and "
        "length in one unit?)",
    )
    _require(contact & ~np.isfinite(values["normal"]), where, "a contact needs a normal")
    largest = max(float(np.nanmax(np.abs(values[c]), initial=0.0)) for c in ANGLES)
    for column in LENGTHS:
        values[column] = values[column] * LENGTH_UNITS[length_unit]
    for column in ANGLES:
        values[column] = values[column] * ANGLE_UNITS[angle_unit]
    texture = values.get("texture", np.full(len(table), np.nan))
    rows = np.column_stack(
        [values[c] for c in SWEEP_FIELDS[:-1]] + [np.where(contact, texture, np.nan)]
    )
    rows[~contact, 4] = np.nan  # a normal without a contact says nothing
    ids = values["pose"].astype(np.int64)
    _, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # poses in the order they first appear
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    group = rank[inverse]
    pose_rows = np.column_stack([values[c] for c in POSE_COLUMNS])
    firsts = pose_rows[first[order]]
    differs = np.any(pose_rows != firsts[group], axis=1)
    _require(differs, where, "the pose's x, y and heading differ from its first row")
    by_pose = np.argsort(group, kind="stable")
    bounds = np.searchsorted(group[by_pose], np.arange(len(order) + 1))
    sweeps = tuple(
        np.ascontiguousarray(rows[by_pose[a:b]]) for a, b in zip(bounds, bounds[1:], strict=False)
    )
    return SweepLog(poses=np.ascontiguousarray(firsts), sweeps=sweeps, largest_angle=largest)


def angle_unit_hint(log: SweepLog, unit: str) -> str | None:
    """A hint when a log read in radians has angles beyond ±(2π + 0.1), as degrees read as
    radians would (an unwrapped heading can be that large too: a hint, not an error)."""
    if unit != "rad" or log.largest_angle <= 2.0 * math.pi + 0.1:
        return None
    return (
        f"angles reach {log.largest_angle:.4g} rad: if the log is in degrees, give --angle-unit deg"
    )


def _table(path: Path) -> pd.DataFrame:
    """The file as a table of text cells (numbers are converted and checked afterwards)."""
    try:
        if path.suffix.lower() == ".parquet":
            return pd.read_parquet(path)
        return pd.read_csv(path, comment="#", dtype=str, skipinitialspace=True)
    except FileNotFoundError:
        raise FormatError("no such file", path=str(path)) from None
    except (OSError, ValueError, UnicodeDecodeError, pd.errors.ParserError) as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise FormatError(f"cannot read the log: {first}", path=str(path)) from None


def _numbers(column: pd.Series, name: str, path: str) -> FloatArray:
    """A column as floats; blank cells are NaN, any other text and an infinity are errors
    at their row."""
    if pd.api.types.is_numeric_dtype(column):
        numbers = column.to_numpy(dtype=np.float64)
    else:
        numbers = pd.to_numeric(column, errors="coerce").to_numpy(dtype=np.float64)
        given = column.notna().to_numpy() & (column.astype(str).str.strip() != "").to_numpy()
        bad = given & np.isnan(numbers)
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise FormatError(
                f"row {row + 1}, column {name}: {str(column.iloc[row])[:40]!r} is not a number",
                path=path,
            )
    _require(np.isinf(numbers), path, f"{name} must be a finite number (or blank)")
    return np.asarray(numbers, dtype=np.float64)


def _require(bad: np.ndarray, path: str, what: str) -> None:
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise FormatError(f"row {row + 1}: {what}", path=path)


def write_sweep_log(path: str | Path, poses: FloatArray, sweeps: list[FloatArray]) -> Path:
    """Write poses ``(m, 3)`` and their sweep rows (``(w_i, 6)`` each) as a sweep log in SI
    units: Parquet when ``path`` ends in ``.parquet``, else CSV (gzipped when it ends in
    ``.gz``), every double written to the digit; written atomically."""
    frames = []
    for k, (pose, rows) in enumerate(zip(np.asarray(poses), sweeps, strict=True)):
        rows = np.asarray(rows, dtype=np.float64).reshape(-1, len(SWEEP_FIELDS))
        frame = pd.DataFrame(rows, columns=list(SWEEP_FIELDS))
        frame.insert(0, "heading", pose[2])
        frame.insert(0, "y", pose[1])
        frame.insert(0, "x", pose[0])
        frame.insert(0, "pose", k)
        frames.append(frame)
    table = pd.concat(frames, ignore_index=True)
    target = Path(path)
    if target.suffix.lower() == ".parquet":
        data = table.to_parquet(index=False)
    else:
        data = table.to_csv(index=False, float_format="%.17g", lineterminator="\n").encode()
        if target.suffix.lower() == ".gz":
            data = gzip.compress(data, mtime=0)
    return write_bytes(target, data)
