"""Player/Stage log files: sonar rings and odometry from the logs of Player's ``writelog``.

Player's ``writelog`` driver writes one message a line, in metres and radians; its ``readlog``
driver replays them (``server/drivers/shell/writelog.cc`` and ``readlog.cc`` in the Player
sources). A log opens with the line ``## Player version V`` and names its layout in
``## File version F``; lines starting ``#`` are comments. Two layouts carry sonar:

File version 0.3.0 (Player 2.0 to 3.x)
    ``time host robot interface index type subtype payload``. Type 1 is data, type 4 the
    reply to a request. Read here: ``sonar`` 1:1, the ranges ``count r_1 .. r_count`` [m];
    ``sonar`` 1:2 (geometry published as data) or 4:1 (the reply to the geometry request,
    which ``writelog`` logs as it opens the file), ``count x_1 y_1 yaw_1 ..`` [m, m, rad];
    ``position2d`` 1:1, the odometry ``px py pa vx vy va stall``.
File version 0.2.0 (Player 1.6)
    ``server_time host port interface index data_time payload``, no type or subtype. A
    ``sonar`` line holds the geometry and then the ranges, ``count x_1 y_1 yaw_1 .. count
    r_1 .. r_count``; a ``position`` line ``px py pa vx vy va stall``; ``sync`` lines are a
    heartbeat. The data time (the sixth field) is the reading's time, as ``readlog`` replays it.

Player 1.5 and older (file version 0.0.0) logged no sonar, so their logs are refused, as is
any other file version. Lines of other devices (lasers, other indices, other message types)
are passed over. The ranges are joined to the odometry by time as two-file plain-text logs
are (:func:`bayesmap.sonar.logs.read_sonar_log`: interpolated across gaps up to
``max_pose_gap``, else the nearest pose within ``time_tolerance``), and bad lines are
handled the same way: a line that cannot be read, a range that is negative or not a plain
decimal (``inf`` is no echo), a count that disagrees with the values after it, a timestamp
out of order, a pose that leaps away and back, a ring with no pose — each costs its line
only, reported with file, line number and reason; ``strict=True`` aborts at the first.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal, NamedTuple

from bayesmap._io import LineReader
from bayesmap._numbers import is_decimal
from bayesmap._typing import ProgressHook
from bayesmap.errors import FormatError
from bayesmap.sensing.sonar_rings import Layout
from bayesmap.sonar.geometry import SonarGeometry
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

__all__ = ["FILE_VERSIONS", "is_player_log", "read_player_log"]

FILE_VERSIONS: dict[str, str] = {"0.3.0": "Player 2.0-3.x", "0.2.0": "Player 1.6"}
"""The ``## File version`` of each log layout read here, and the Player releases writing it."""

_HEADER = "## Player version"
_VERSION_LINE = ("##", "File", "version")
_COUNT = re.compile(r"[0-9]+")
_DEVICES = {"0.3.0": ("sonar", "position2d"), "0.2.0": ("sonar", "position")}
"""The interfaces of the sonar ring and of the odometry in each layout."""


class _Message(NamedTuple):
    """One line's header: device, ``(type, subtype)`` (``None`` in 0.2.0), time, payload."""

    interface: str
    device: int
    kind: tuple[int, int] | None
    time: str
    payload: list[str]


_Role = Literal["ranges", "geometry", "geometry+ranges", "pose"]


HEADER_SEARCH_LINES = 20
"""Blank or comment lines a Player log may hold before its ``## Player version`` header (a
note added by hand, a tool's banner)."""


def is_player_log(path: str | Path) -> bool:
    """Whether ``path`` opens with the ``## Player version`` line ``writelog`` writes first
    (after at most :data:`HEADER_SEARCH_LINES` blank or comment lines)."""
    try:
        with LineReader(path) as handle:
            return _header_line(handle) is not None
    except FormatError:
        return False


def _header_line(handle: LineReader) -> int | None:
    """Read ``handle`` up to and including writelog's header; its line number, or ``None``
    when a line that is neither blank nor a comment, or the end of the file, or
    :data:`HEADER_SEARCH_LINES` lines come first."""
    for number in range(1, HEADER_SEARCH_LINES + 1):
        raw = handle.readline(4096)
        line = raw.decode("utf-8", errors="replace").lstrip("\ufeff").strip()
        if line.startswith(_HEADER):
            return number
        if not raw or (line and not line.startswith("#")):
            return None
    return None


def _message(tokens: list[str], version: str) -> _Message | str:
    """The header of a message line of file version ``version``, or why it is unreadable."""
    if version == "0.3.0":
        if len(tokens) < 7 or not (
            is_decimal(tokens[0]) and all(_COUNT.fullmatch(t) for t in tokens[1:3] + tokens[4:7])
        ):
            return "not a Player message: 'time host robot interface index type subtype ...'"
        kind = (int(tokens[5]), int(tokens[6]))
        return _Message(tokens[3], int(tokens[4]), kind, tokens[0], tokens[7:])
    if len(tokens) < 6 or not (
        is_decimal(tokens[0])
        and _COUNT.fullmatch(tokens[2])
        and _COUNT.fullmatch(tokens[4])
        and is_decimal(tokens[5])
    ):
        return "not a Player message: 'time host port interface index data_time ...'"
    return _Message(tokens[3], int(tokens[4]), None, tokens[5], tokens[6:])


def _role(message: _Message, version: str, sonar_index: int, position_index: int) -> _Role | None:
    """What the line gives: ranges, geometry, both (0.2.0), a pose; ``None`` for other devices."""
    sonar, position = _DEVICES[version]
    if message.interface == sonar and message.device == sonar_index:
        if message.kind is None:
            return "geometry+ranges"
        if message.kind == (1, 1):
            return "ranges"
        if message.kind in ((1, 2), (4, 1)):
            return "geometry"
    elif message.interface == position and message.device == position_index:
        if message.kind in (None, (1, 1)):
            return "pose"
    return None


def _counted(payload: list[str], per_item: int, what: str) -> tuple[list[str], list[str]] | str:
    """Split ``count v_1 .. v_(count·per_item)`` off ``payload``: ``(values, rest)``."""
    if not payload or not _COUNT.fullmatch(payload[0]):
        return f"the {what} count {payload[0][:40] if payload else ''!r} is not a whole number"
    count = int(payload[0])
    values = payload[1 : 1 + count * per_item]
    if len(values) < count * per_item:
        return f"the {what} count is {count} but the line holds {len(values) // per_item}"
    return values, payload[1 + count * per_item :]


def _geometry(payload: list[str]) -> tuple[Layout, list[str]] | str:
    """Transducer poses ``x y yaw`` [m, m, rad] from ``count x_1 y_1 yaw_1 ..``, and the fields
    after them; or why they are bad."""
    split = _counted(payload, 3, "sonar geometry")
    if isinstance(split, str):
        return split
    values, rest = split
    culprit = next((v for v in values if not is_decimal(v)), None)
    if culprit is not None:
        return f"sonar geometry: {culprit[:40]!r} is not a plain decimal number"
    n = [float(v) for v in values]
    return tuple((n[i], n[i + 1], n[i + 2]) for i in range(0, len(n), 3)), rest


def _range_fields(payload: list[str]) -> list[str] | str:
    """The range fields of ``count r_1 .. r_count``, or why they are bad."""
    split = _counted(payload, 1, "sonar range")
    if isinstance(split, str):
        return split
    if split[1]:
        return f"{len(split[1])} fields after the ranges"
    return split[0] or "a sonar line without ranges"


def _ranges(time: str, values: list[str], n: int, first: int) -> list[float] | str:
    """``[time, r_1 .. r_n]`` from a ranges line's fields, or why they are bad."""
    if len(values) != n:
        return f"{len(values)} ranges where the first sonar line (line {first}) has {n}"
    return row_values([time, *values], 1 + n, n)


def _pose(time: str, payload: list[str]) -> list[float] | str:
    """``[time, px, py, pa]`` from an odometry line's ``px py pa vx vy va stall``."""
    if len(payload) != 7:
        return f"an odometry line holds 7 values (px py pa vx vy va stall), found {len(payload)}"
    return row_values([time, *payload[:3]], 4, 0)


class _Scan:
    """What one pass over a Player log gathers: rings, poses, the first geometry, devices."""

    def __init__(self, path: Path, skipped: list[SkippedRow]) -> None:
        self.path = path
        self.skipped = skipped
        self.rings: RowBlocks | None = None
        self.first_ring_line = 0
        self.poses = RowBlocks(4)
        self.geometry: tuple[int, Layout] | None = None
        self.devices: set[str] = set()
        self.rows = 0

    def bad(self, line: int, reason: str) -> None:
        report_skipped(self.path, line, reason, self.skipped)

    def take(self, line: int, message: _Message, role: _Role) -> None:
        """Record one line of the sonar ring or of the odometry; a bad line is reported."""
        if role == "pose":
            self._row(line, self.poses, _pose(message.time, message.payload))
            return
        layout: Layout = ()
        payload = message.payload
        if role != "ranges":
            split = _geometry(payload)
            if isinstance(split, str):
                self.bad(line, split)
                return
            layout, payload = split
            if role == "geometry":
                if payload:
                    self.bad(line, f"{len(payload)} fields after the sonar geometry")
                else:
                    self._keep(line, layout)
                return
        fields = _range_fields(payload)
        if isinstance(fields, str):
            self.bad(line, fields)
            return
        if self.rings is None:
            self.rings, self.first_ring_line = RowBlocks(1 + len(fields)), line
        n = self.rings.columns - 1
        if self._row(line, self.rings, _ranges(message.time, fields, n, self.first_ring_line)):
            self._keep(line, layout)

    def _keep(self, line: int, layout: Layout) -> None:
        """Keep the log's first (non-empty) geometry and its line."""
        if layout and self.geometry is None:
            self.geometry = (line, layout)

    def _row(self, line: int, rows: RowBlocks, outcome: list[float] | str) -> bool:
        """Add a good row to ``rows`` or report a bad one; whether it was good."""
        if isinstance(outcome, str):
            self.bad(line, outcome)
            return False
        rows.add(line, outcome)
        return True


def _scan(
    path: Path,
    sonar_index: int,
    position_index: int,
    skipped: list[SkippedRow],
    progress: ProgressHook | None,
) -> _Scan:
    """Stream ``path`` line by line, gathering its sonar and odometry lines."""
    scan = _Scan(path, skipped)
    version: str | None = None
    with LineReader(path) as handle:
        total = max(handle.size, 1)
        header = _header_line(handle)
        if header is None:
            raise FormatError(
                f"not a Player log: writelog's {_HEADER!r} header does not open it",
                path=path,
            )
        for number, raw in enumerate(handle, start=header + 1):
            if number % CHUNK_ROWS == 0 and progress is not None:
                progress(f"reading {path.name}", handle.consumed(), total)
            tokens = raw.decode("utf-8", errors="replace").split()
            if not tokens:
                continue
            if tokens[0].startswith("#"):
                if tuple(tokens[:3]) == _VERSION_LINE and len(tokens) == 4:
                    version = _known_version(tokens[3], path, number)
                continue
            if version is None:
                raise FormatError(
                    "no '## File version' line before the first message", path=path, line=number
                )
            message = _message(tokens, version)
            if isinstance(message, str):
                scan.rows += 1
                scan.bad(number, message)
                continue
            scan.devices.add(f"{message.interface}:{message.device}")
            role = _role(message, version, sonar_index, position_index)
            if role is not None:
                scan.rows += 1
                scan.take(number, message, role)
    if progress is not None:
        progress(f"reading {path.name}", total, total)
    return scan


def _known_version(version: str, path: Path, line: int) -> str:
    if version not in FILE_VERSIONS:
        known = ", ".join(f"{v} ({who})" for v, who in FILE_VERSIONS.items())
        raise FormatError(
            f"file version {version[:20]!r} is not one bayesmap reads: {known}; "
            "Player 1.5 and older (0.0.0) logged no sonar",
            path=path,
            line=line,
        )
    return version


def _ring(scan: _Scan, n: int) -> SonarGeometry | None:
    """The ring of the log's first geometry; a geometry that cannot be one costs its line."""
    if scan.geometry is None:
        return None
    line, layout = scan.geometry
    ring = logged_ring(layout, n)
    if isinstance(ring, str):
        scan.bad(line, ring)
        return None
    return ring


def read_player_log(
    path: str | Path,
    *,
    sonar_index: int = 0,
    position_index: int = 0,
    strict: bool = False,
    time_tolerance: float = 0.05,
    max_pose_gap: float = 1.0,
    progress: ProgressHook | None = None,
) -> RingLog:
    """Read the rings of ``sonar:<sonar_index>`` and the odometry of ``position2d`` (or, in
    Player 1.6 logs, ``position``) ``:<position_index>`` from a Player log.

    Parameters
    ----------
    path
        The log, as ``writelog`` wrote it (see the module docstring for the layouts).
    sonar_index, position_index
        Device indices of the sonar ring and of the odometry.
    strict
        Abort at the first bad line (:class:`FormatError` naming it) instead of skipping it.
    time_tolerance, max_pose_gap
        Pose join settings [s], as for :func:`~bayesmap.sonar.logs.read_sonar_log`.
    progress
        Optional hook, called as ``progress("reading <file>", bytes_read, bytes_total)``.

    Raises
    ------
    FormatError
        Not a Player log, a file version without sonar, no lines of either device, no usable
        ring, or (with ``strict``) the first bad line.
    InputError
        A negative pose join setting.
    """
    check_join_settings(time_tolerance, max_pose_gap)
    source = Path(path)
    skipped: list[SkippedRow] = []
    scan = _scan(source, sonar_index, position_index, skipped, progress)
    seen = f"it holds {', '.join(sorted(scan.devices)) or 'no messages'}"
    if scan.rings is None:
        raise FormatError(f"no ranges of sonar:{sonar_index} ({seen})", path=source)
    pose_table = scan.poses.table(0)
    if len(pose_table.values) == 0:
        raise FormatError(f"no odometry of position device {position_index} ({seen})", path=source)
    ring = _ring(scan, scan.rings.columns - 1)
    hint = f"each sonar:{sonar_index} ring needs odometry of position device {position_index}"
    join = (strict, time_tolerance, max_pose_gap)
    return ring_log(source, scan.rings.table(scan.rows), pose_table, skipped, join, hint, ring)
