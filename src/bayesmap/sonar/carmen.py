"""CARMEN logs: sonar rings and odometry from the logs of CARMEN's ``logger``.

CARMEN, the Carnegie Mellon Robot Navigation Toolkit, logs one message a line, ``NAME
fields .. ipc_timestamp ipc_hostname logger_timestamp``, in metres, radians and seconds
(``src/lib/carmen/writelog/writelog.c`` writes them and ``readlog/readlog.c`` reads them in
the CARMEN sources); a log opens with ``# CARMEN Logfile`` and ``#`` lines naming the
messages. Two messages are read here:

``SONAR cone_angle num_sonars r_1 .. r_n x_1 y_1 theta_1 .. x_n y_n theta_n`` + stamps
    a base's sonar ring: the beams' full width [rad], the ranges [m], and where each
    transducer sits on the robot and points [m, m, rad] (the ``robot_sonar_offsets``
    parameter the base was started with);
``ODOM x y theta tv rv accel`` + stamps
    the base's odometry.

Every other message (``PARAM``, ``SYNC``, lasers, ``TRUEPOS`` ...) is passed over. A ring's
or a pose's time is its ``ipc_timestamp``, when the base sent it (the sonar and the odometry
come from one process, so from one clock), or with ``clock="logger"`` the logger's
timestamp, seconds since logging began (for a log whose ipc stamps are missing or from
unsynchronised hosts). The rings are joined to the odometry by time as two-file plain-text
logs are (:func:`bayesmap.sonar.logs.read_sonar_log`: interpolated across gaps up to
``max_pose_gap``, else the nearest pose within ``time_tolerance``), and bad lines are handled
the same way: a line that is not a CARMEN message, a field that is not a plain decimal (a
range may be ``inf``, no echo), a negative range, a count that disagrees with the fields
after it, a timestamp out of order, a pose that leaps away and back, a ring with no pose —
each costs its line only, reported with file, line number and reason; ``strict=True``
aborts at the first.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal

from bayesmap._io import LineReader
from bayesmap._numbers import is_decimal
from bayesmap._typing import ProgressHook
from bayesmap.errors import FormatError, InputError
from bayesmap.sensing.sonar_rings import Layout
from bayesmap.sonar.logs import (
    CHUNK_ROWS,
    RingLog,
    RowBlocks,
    SkippedRow,
    check_join_settings,
    report_skipped,
    ring_log,
    row_values,
)
from bayesmap.sonar.ring import logged_ring

__all__ = ["CLOCKS", "Clock", "MESSAGES", "is_carmen_log", "read_carmen_log"]

Clock = Literal["ipc", "logger"]
CLOCKS: tuple[Clock, ...] = ("ipc", "logger")
"""The two timestamps every CARMEN message ends with (see the module docstring)."""

MESSAGES = frozenset(
    "PARAM SYNC COMMENT ODOM TRUEPOS GLOBALPOS FLASER RLASER LASER3 LASER4 RAWLASER1 RAWLASER2 "
    "RAWLASER3 RAWLASER4 ROBOTLASER1 ROBOTLASER2 REMISSIONFLASER REMISSIONRLASER "
    "REMISSIONLASER3 REMISSIONLASER4 POSITIONLASER NMEAGGA NMEARMC SONAR BUMPER SCANMARK IMU "
    "ARM VECTORMOVE ROBOTVELOCITY FOLLOWTRAJECTORY BASEVELOCITY".split()
)
"""The message names CARMEN's logger writes (its log header lists them): a file whose first
line that is not a comment starts with one is a CARMEN log."""

HEADER = "# CARMEN Logfile"
"""The line CARMEN's logger opens a log with."""

_SNIFF_LINES = 20
"""Lines :func:`is_carmen_log` reads, at most, for the header or a first message."""

_NAME = re.compile(r"[A-Z][A-Z0-9_]*")
_COUNT = re.compile(r"[0-9]+")
_STAMPS = 3  # ipc_timestamp ipc_hostname logger_timestamp
_ODOMETRY = 6  # x y theta tv rv accel


def is_carmen_log(path: str | Path) -> bool:
    """Whether ``path`` opens as a CARMEN log: its ``# CARMEN Logfile`` header, or a first
    line that is neither blank nor a ``#`` comment starting with a CARMEN message name
    (:data:`MESSAGES`), within its first :data:`_SNIFF_LINES` lines."""
    try:
        with LineReader(path) as handle:
            for _ in range(_SNIFF_LINES):
                raw = handle.readline(4096)
                line = raw.decode("utf-8", errors="replace").lstrip("\ufeff").strip()
                if line.startswith(HEADER):
                    return True
                if not raw:
                    return False
                if line and not line.startswith("#"):
                    return line.split(maxsplit=1)[0] in MESSAGES
    except FormatError:
        return False
    return False


class _Scan:
    """What one pass over a CARMEN log gathers: rings, poses, the first ring's geometry."""

    def __init__(self, path: Path, clock: Clock, skipped: list[SkippedRow]) -> None:
        self.path = path
        self.stamp = -3 if clock == "ipc" else -1  # the field of the message's time
        self.skipped = skipped
        self.rings: RowBlocks | None = None
        self.first_ring_line = 0
        self.poses = RowBlocks(4)
        self.geometry: tuple[int, float, Layout] | None = None
        self.messages: set[str] = set()
        self.rows = 0

    def take(self, line: int, tokens: list[str]) -> None:
        """Record a line of a ring or of the odometry (a bad one is reported); pass over
        other messages."""
        name = tokens[0]
        if name not in ("SONAR", "ODOM"):
            if _NAME.fullmatch(name):
                self.messages.add(name)
            else:
                self.rows += 1
                self._bad(line, "not a CARMEN message: 'NAME fields .. stamp host stamp'")
            return
        self.messages.add(name)
        self.rows += 1
        outcome = self._sonar(line, tokens) if name == "SONAR" else self._pose(tokens)
        if isinstance(outcome, str):
            self._bad(line, outcome)
            return
        rows = self.poses if name == "ODOM" else self.rings
        assert rows is not None  # made by the first good SONAR line
        rows.add(line, outcome)

    def _pose(self, tokens: list[str]) -> list[float] | str:
        """``[time, x, y, theta]`` of ``ODOM x y theta tv rv accel`` + stamps."""
        fields = tokens[1:]
        if len(fields) != _ODOMETRY + _STAMPS:
            return (
                "an ODOM line holds x y theta tv rv accel and three stamps (9 fields), "
                f"found {len(fields)}"
            )
        values = row_values([fields[self.stamp], *fields[:_ODOMETRY]], 1 + _ODOMETRY, 0)
        return values if isinstance(values, str) else values[:4]

    def _sonar(self, line: int, tokens: list[str]) -> list[float] | str:
        """``[time, r_1 .. r_n]`` of a SONAR line (its geometry kept if it is the first)."""
        fields = tokens[1:]
        if len(fields) < 2 or not _COUNT.fullmatch(fields[1]):
            return "not a SONAR message: 'SONAR cone_angle num_sonars ranges offsets stamps'"
        n = int(fields[1])
        if n == 0:
            return "a SONAR line without ranges"
        expected = 2 + 4 * n + _STAMPS
        if len(fields) != expected:
            return (
                f"a SONAR line of {n} sonars holds {expected} fields (cone angle, count, "
                f"{n} ranges, {n} offsets x y theta, three stamps), found {len(fields)}"
            )
        geometry = [fields[0], *fields[2 + n : 2 + 4 * n]]
        culprit = next((f for f in geometry if not is_decimal(f)), None)
        if culprit is not None:
            return f"sonar geometry: {culprit[:40]!r} is not a plain decimal number"
        if self.rings is None:
            self.rings, self.first_ring_line = RowBlocks(1 + n), line
        elif self.rings.columns != 1 + n:
            first = f"the first SONAR line (line {self.first_ring_line})"
            return f"{n} sonars where {first} has {self.rings.columns - 1}"
        values = row_values([fields[self.stamp], *fields[2 : 2 + n]], 1 + n, n)
        if not isinstance(values, str) and self.geometry is None:
            o = [float(f) for f in geometry[1:]]
            layout = tuple((o[i], o[i + 1], o[i + 2]) for i in range(0, 3 * n, 3))
            self.geometry = (line, float(geometry[0]), layout)
        return values

    def _bad(self, line: int, reason: str) -> None:
        report_skipped(self.path, line, reason, self.skipped)


def _scan(
    path: Path, clock: Clock, skipped: list[SkippedRow], progress: ProgressHook | None
) -> _Scan:
    """Stream ``path`` line by line, gathering its SONAR and ODOM lines."""
    scan = _Scan(path, clock, skipped)
    with LineReader(path) as handle:
        total = max(handle.size, 1)
        for number, raw in enumerate(handle, start=1):
            if number % CHUNK_ROWS == 0 and progress is not None:
                progress(f"reading {path.name}", handle.consumed(), total)
            tokens = raw.decode("utf-8", errors="replace").lstrip("\ufeff").split()
            if tokens and not tokens[0].startswith("#"):
                scan.take(number, tokens)
    if progress is not None:
        progress(f"reading {path.name}", total, total)
    return scan


def read_carmen_log(
    path: str | Path,
    *,
    clock: Clock = "ipc",
    strict: bool = False,
    time_tolerance: float = 0.05,
    max_pose_gap: float = 1.0,
    progress: ProgressHook | None = None,
) -> RingLog:
    """Read the sonar rings (``SONAR``) and the odometry (``ODOM``) of a CARMEN log.

    Parameters
    ----------
    path
        The log, as CARMEN's logger wrote it (see the module docstring); gzipped or not.
    clock
        Which of each message's stamps is its time: ``"ipc"`` (when it was sent) or
        ``"logger"`` (seconds since logging began).
    strict
        Abort at the first bad line (:class:`FormatError` naming it) instead of skipping it.
    time_tolerance, max_pose_gap
        Pose join settings [s], as for :func:`~bayesmap.sonar.logs.read_sonar_log`.
    progress
        Optional hook, called as ``progress("reading <file>", bytes_read, bytes_total)``.

    Returns
    -------
    RingLog
        The rings with their poses, and the ring of the first SONAR line: its transducers'
        offsets, its cone angle as the beam width, the presets' min and max range and noise
        (a CARMEN log does not hold them).

    Raises
    ------
    FormatError
        No SONAR or no ODOM lines, no usable ring, or (with ``strict``) the first bad line.
    InputError
        A negative pose join setting, or an unknown ``clock``.
    """
    check_join_settings(time_tolerance, max_pose_gap)
    if clock not in CLOCKS:
        raise InputError(f"unknown clock {clock!r}; choose from: {', '.join(CLOCKS)}")
    source = Path(path)
    skipped: list[SkippedRow] = []
    scan = _scan(source, clock, skipped, progress)
    seen = f"it holds {', '.join(sorted(scan.messages)) or 'no messages'}"
    if scan.rings is None:
        raise FormatError(f"no SONAR lines ({seen})", path=source)
    pose_table = scan.poses.table(0)
    if len(pose_table.values) == 0:
        raise FormatError(f"no ODOM lines ({seen})", path=source)
    ring = None
    if scan.geometry is not None:
        line, cone, layout = scan.geometry
        described = logged_ring(layout, scan.rings.columns - 1, cone)
        if isinstance(described, str):
            report_skipped(source, line, described, skipped)
        else:
            ring = described
    hint = "each SONAR line needs ODOM lines around its time"
    join = (strict, time_tolerance, max_pose_gap)
    return ring_log(source, scan.rings.table(scan.rows), pose_table, skipped, join, hint, ring)
