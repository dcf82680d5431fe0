"""Tests of the CARMEN log reader on logs written from a simulated drive."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.sonar.helpers import (
    carmen_lines,
    junk_lines,
    player_lines,
    read_with_junk,
    simulated_drive,
    write_log_lines,
)

from bayesmap.errors import FormatError, InputError
from bayesmap.sensing.sonar_rings import PIONEER_RING16
from bayesmap.sonar.carmen import is_carmen_log, read_carmen_log
from bayesmap.sonar.player import read_player_log


def _drive_log(tmp_path: Path, lines: list[str] | None = None, name: str = "drive.log") -> Path:
    return write_log_lines(
        tmp_path / name, carmen_lines(simulated_drive()) if lines is None else lines
    )


def test_a_carmen_log_reads_as_the_same_player_log(tmp_path: Path) -> None:
    """The same drive logged by CARMEN and by Player: the same rings, times and poses."""
    drive = simulated_drive()
    carmen = read_carmen_log(_drive_log(tmp_path))
    player = read_player_log(write_log_lines(tmp_path / "p.log", player_lines(drive))).log
    log = carmen.log
    assert log.skipped == () and len(log.timestamps) == len(drive.times)
    assert np.array_equal(log.timestamps, player.timestamps)
    assert np.array_equal(log.ranges, player.ranges)
    assert np.allclose(log.poses, player.poses, atol=1e-6, rtol=0)  # CARMEN writes 6 decimals
    assert log.rows == len(drive.times) + len(drive.pose_times)


def test_the_sonar_lines_give_the_ring(tmp_path: Path) -> None:
    ring = read_carmen_log(_drive_log(tmp_path)).ring
    assert ring is not None and ring.n == 16
    assert ring.angles == pytest.approx([a for _, _, a in PIONEER_RING16], abs=1e-6)
    assert np.allclose(ring.offsets, [(x, y) for x, y, _ in PIONEER_RING16], atol=1e-3)
    assert math.degrees(ring.beam_width) == pytest.approx(25.0, abs=0.01)  # the cone angle
    assert ring.max_range == 5.0 and ring.min_range == 0.1  # not in a CARMEN log: the presets'
    narrow = write_log_lines(tmp_path / "narrow.log", carmen_lines(simulated_drive(), cone=0.2))
    narrow_ring = read_carmen_log(narrow).ring
    assert narrow_ring is not None and narrow_ring.beam_width == pytest.approx(0.2)


def test_the_logger_clock(tmp_path: Path) -> None:
    """With the logger's stamps the times shift by the log's start, and the join is the same."""
    path = _drive_log(tmp_path)
    ipc, logger = read_carmen_log(path).log, read_carmen_log(path, clock="logger").log
    start = float(simulated_drive().times[0]) - 1.0
    assert np.allclose(logger.timestamps, ipc.timestamps - start + 0.0005, atol=1e-9, rtol=0)
    assert np.array_equal(logger.ranges, ipc.ranges)
    assert np.allclose(logger.poses, ipc.poses, atol=1e-9, rtol=0)
    with pytest.raises(InputError, match="unknown clock 'wall'"):
        read_carmen_log(path, clock="wall")  # type: ignore[arg-type]


def test_bad_lines_cost_their_line_and_strict_names_the_first(tmp_path: Path) -> None:
    lines = carmen_lines(simulated_drive())
    sonar = [i for i, line in enumerate(lines) if line.startswith("SONAR ")]
    odom = [i for i, line in enumerate(lines) if line.startswith("ODOM ")]
    fields = lines[sonar[3]].split()
    lines[sonar[3]] = " ".join(fields[:-1])  # a stamp short
    fields = lines[sonar[5]].split()
    fields[4] = "-0.5"
    lines[sonar[5]] = " ".join(fields)  # a negative range
    fields = lines[sonar[7]].split()
    fields[2] = "8"
    lines[sonar[7]] = " ".join(fields[:3] + fields[3:11] + fields[19:43] + fields[-3:])  # 8 sonars
    fields = lines[odom[4]].split()
    fields[1] = "1,5"
    lines[odom[4]] = " ".join(fields)  # a decimal comma
    lines.insert(sonar[9], "12.5 3.0 4.0")  # not a CARMEN message
    path = _drive_log(tmp_path, lines)
    log = read_carmen_log(path).log
    reasons = {row.line: row.reason for row in log.skipped}
    assert reasons[sonar[3] + 1].startswith("a SONAR line of 16 sonars holds 69 fields")
    assert reasons[sonar[5] + 1] == "negative range"
    first = f"the first SONAR line (line {sonar[0] + 1})"
    assert reasons[sonar[7] + 1] == f"8 sonars where {first} has 16"
    assert reasons[odom[4] + 1] == "'1,5' is not a plain decimal number"
    assert reasons[sonar[9] + 1].startswith("not a CARMEN message")
    assert len(log.timestamps) == len(simulated_drive().times) - 3  # the pose is interpolated
    with pytest.raises(FormatError, match=rf"line {min(reasons)}\b"):
        read_carmen_log(path, strict=True)


def test_a_log_without_rings_or_odometry_is_refused_by_name(tmp_path: Path) -> None:
    lines = carmen_lines(simulated_drive())
    no_odom = _drive_log(tmp_path, [s for s in lines if not s.startswith("ODOM ")], "a.log")
    with pytest.raises(FormatError, match=r"no ODOM lines \(it holds FLASER, PARAM, SONAR, SYNC\)"):
        read_carmen_log(no_odom)
    no_sonar = _drive_log(tmp_path, [s for s in lines if not s.startswith("SONAR ")], "b.log")
    with pytest.raises(FormatError, match="no SONAR lines"):
        read_carmen_log(no_sonar)


def test_a_bad_geometry_leaves_no_ring(tmp_path: Path) -> None:
    lines = carmen_lines(simulated_drive(), cone=0.0)  # a zero-width beam
    log = read_carmen_log(_drive_log(tmp_path, lines))
    assert log.ring is None
    assert log.log.skipped[0].reason.startswith("sonar geometry: beam width must be in (0, pi)")


def test_detection(tmp_path: Path) -> None:
    path = _drive_log(tmp_path)
    assert is_carmen_log(path) and not is_carmen_log(tmp_path / "missing.log")
    headless = _drive_log(tmp_path, carmen_lines(simulated_drive())[4:], "headless.log")
    assert is_carmen_log(headless)  # no header: its first message names it
    player = write_log_lines(tmp_path / "p.log", player_lines(simulated_drive()))
    text = write_log_lines(tmp_path / "t.txt", ["# t x y heading r1 r2", "0.0 0 0 0 1 2"])
    assert not is_carmen_log(player) and not is_carmen_log(text)
    packed = tmp_path / "drive.log.gz"
    packed.write_bytes(gzip.compress(path.read_bytes()))
    assert is_carmen_log(packed)
    assert np.array_equal(read_carmen_log(packed).log.ranges, read_carmen_log(path).log.ranges)
    calls: list[tuple[str, int, int]] = []
    read_carmen_log(path, progress=lambda *call: calls.append(call))
    size = path.stat().st_size
    assert calls[-1] == ("reading drive.log", size, size)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    extra=st.lists(
        st.tuples(
            st.integers(0, 60),
            junk_lines(["SONAR", "ODOM", "0.4363", "16", "2", "1.0", "-1", "inf", "x"]),
        ),
        max_size=8,
    ),
    strict=st.booleans(),
)
def test_junk_lines_never_crash_the_reader(
    tmp_path: Path, extra: list[tuple[int, str]], strict: bool
) -> None:
    lines = carmen_lines(simulated_drive())[:60]
    read_with_junk(read_carmen_log, tmp_path / "junk.log", lines, extra, strict)
