"""Tests of the Player log reader on logs written from a simulated drive."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tests.sonar.helpers import (
    junk_lines,
    player_lines,
    read_with_junk,
    simulated_drive,
    write_log_lines,
)

from bayesmap.errors import FormatError, InputError
from bayesmap.sensing.sonar_rings import PIONEER_RING16
from bayesmap.sonar.logs import SonarLog, read_sonar_log, write_sonar_log
from bayesmap.sonar.player import is_player_log, read_player_log


def _text_log(tmp_path: Path) -> SonarLog:
    """The drive as a two-file plain-text log: ranges and odometry joined by time."""
    drive = simulated_drive()
    ranges = write_sonar_log(tmp_path / "ranges.txt", drive.times, drive.ranges)
    poses = write_sonar_log(
        tmp_path / "poses.txt", drive.pose_times, np.zeros((len(drive.pose_times), 0)), drive.poses
    )
    return read_sonar_log(ranges, 16, poses_path=poses)


@pytest.mark.parametrize("version", ["0.3.0", "0.2.0"])
def test_a_player_log_reads_as_the_same_plain_text_log(tmp_path: Path, version: str) -> None:
    path = write_log_lines(tmp_path / "drive.log", player_lines(simulated_drive(), version))
    player = read_player_log(path).log
    text = _text_log(tmp_path)
    assert player.skipped == () and len(player.timestamps) == len(simulated_drive().times)
    assert np.array_equal(player.timestamps, text.timestamps)
    assert np.array_equal(player.ranges, text.ranges)
    assert np.array_equal(player.poses, text.poses)
    assert player.rows == len(simulated_drive().times) + len(simulated_drive().pose_times) + (
        version == "0.3.0"  # the geometry line
    )


@pytest.mark.parametrize("version", ["0.3.0", "0.2.0"])
def test_the_geometry_lines_give_the_ring(tmp_path: Path, version: str) -> None:
    path = write_log_lines(tmp_path / "drive.log", player_lines(simulated_drive(), version))
    ring = read_player_log(path).ring
    assert ring is not None and ring.n == 16
    assert ring.angles == pytest.approx([a for _, _, a in PIONEER_RING16], abs=1e-4)
    assert np.allclose(ring.offsets, [(x, y) for x, y, _ in PIONEER_RING16], atol=1e-3)
    assert ring.max_range == 5.0 and ring.min_range == 0.1 and ring.closed is None
    assert math.degrees(ring.beam_width) == pytest.approx(25.0)
    bare = write_log_lines(tmp_path / "bare.log", player_lines(simulated_drive(), version, False))
    assert read_player_log(bare).ring is None


def test_geometry_published_as_data_and_a_wrong_sized_one(tmp_path: Path) -> None:
    lines = player_lines(simulated_drive())
    geometry = lines[3]
    assert " sonar 00 004 001 16 " in geometry
    lines[3] = geometry.replace(" 004 001 16 ", " 001 002 16 ")  # PLAYER_SONAR_DATA_GEOM
    ring = read_player_log(write_log_lines(tmp_path / "data.log", lines)).ring
    assert ring is not None and ring.n == 16
    fields = geometry.split()
    lines[3] = " ".join([*fields[:7], "8", *fields[8 : 8 + 24]])  # 8 transducers, rings of 16
    log = read_player_log(write_log_lines(tmp_path / "eight.log", lines))
    assert log.ring is None
    assert [(row.line, row.reason) for row in log.log.skipped] == [
        (4, "sonar geometry of 8 transducers for rings of 16 ranges")
    ]
    lines[3] = geometry + " 7"  # a field too many: the line is skipped, its ring unused
    log = read_player_log(write_log_lines(tmp_path / "long.log", lines))
    assert log.ring is None and log.log.skipped[0].reason == "1 fields after the sonar geometry"


def test_bad_lines_cost_their_line_and_strict_names_the_first(tmp_path: Path) -> None:
    lines = player_lines(simulated_drive())
    sonar = [i for i, line in enumerate(lines) if " sonar 00 001 001 " in line]
    pose = [i for i, line in enumerate(lines) if " position2d " in line]
    lines[sonar[5]] = lines[sonar[5]].replace(" 16 ", " 17 ", 1)  # count says 17, holds 16
    fields = lines[sonar[9]].split()
    fields[10] = "-0.5"
    lines[sonar[9]] = " ".join(fields)  # a negative range
    lines[sonar[12]] = " ".join(lines[sonar[12]].split()[:12])  # cut short
    lines[pose[4]] = " ".join(lines[pose[4]].split()[:-1])  # odometry without its stall flag
    lines[sonar[20]] = lines[sonar[20]].replace(" 001 001 ", " 001 0x1 ")  # a broken header
    fields = lines[sonar[30]].split()
    fields[0] = "0000000001.000"  # a clock jump back
    lines[sonar[30]] = " ".join(fields)
    path = write_log_lines(tmp_path / "bad.log", lines)
    log = read_player_log(path).log
    reasons = {row.line: row.reason for row in log.skipped}
    numbers = [i + 1 for i in (sonar[5], sonar[9], sonar[12], pose[4], sonar[20], sonar[30])]
    assert sorted(reasons) == sorted(numbers)
    assert "count is 17 but the line holds 16" in reasons[numbers[0]]
    assert "negative range" in reasons[numbers[1]]
    assert "count is 16 but the line holds 4" in reasons[numbers[2]]
    assert "(px py pa vx vy va stall), found 6" in reasons[numbers[3]]
    assert "not a Player message" in reasons[numbers[4]]
    assert "out of order" in reasons[numbers[5]]
    assert all(row.path == str(path) for row in log.skipped)
    assert len(log.timestamps) == len(simulated_drive().times) - 5
    with pytest.raises(FormatError) as info:
        read_player_log(path, strict=True)
    assert info.value.line == numbers[0] and "bad.log" in str(info.value)
    assert "\n" not in str(info.value)


def test_devices_are_chosen_by_index(tmp_path: Path) -> None:
    lines = player_lines(simulated_drive())
    moved = [line.replace(" sonar 00 ", " sonar 01 ") for line in lines]
    path = write_log_lines(tmp_path / "one.log", moved)
    assert len(read_player_log(path, sonar_index=1).log.timestamps) == 240
    with pytest.raises(FormatError, match=r"no ranges of sonar:0 \(it holds laser:0, "):
        read_player_log(path)
    with pytest.raises(FormatError, match="no odometry of position device 2"):
        read_player_log(path, sonar_index=1, position_index=2)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("0 0 0 0 1.5 1.5\n1 0 0 0 1.5 1.5\n", "not a Player log: writelog's .* header"),
        ("# a note\n" * 21 + "## Player version 3.0.2 \n", "not a Player log"),
        ("", "not a Player log"),
        ("## Player version 1.5 \n## File version 0.0.0 \n1 h 1 position 00 1 0 0 0\n", "0.0.0"),
        ("## Player version 3.0.2 \n1 0 6665 sonar 00 001 001 2 1 1\n", "no '## File version'"),
    ],
)
def test_other_files_are_one_line_errors_naming_the_file(
    tmp_path: Path, text: str, words: str
) -> None:
    path = tmp_path / "other.log"
    path.write_text(text)
    with pytest.raises(FormatError, match=words) as info:
        read_player_log(path)
    assert "other.log" in str(info.value) and "\n" not in str(info.value)
    assert not is_player_log(path) or text.startswith("## Player")


def test_comments_before_the_header_are_read_past(tmp_path: Path) -> None:
    """A note added by hand above writelog's header: the log is still detected and read
    the same, and bad lines are named by their line in the file as it is."""
    lines = player_lines(simulated_drive())
    plain = read_player_log(write_log_lines(tmp_path / "plain.log", lines)).log
    sonar = next(i for i, line in enumerate(lines) if " sonar 00 001 001 " in line)
    lines[sonar] = " ".join(lines[sonar].split()[:12])  # cut short
    path = write_log_lines(tmp_path / "noted.log", ["# recorded in the east corridor", "", *lines])
    assert is_player_log(path)
    noted = read_player_log(path).log
    assert np.array_equal(noted.timestamps, plain.timestamps[1:])  # the first ring cut short
    assert np.array_equal(noted.ranges, plain.ranges[1:])
    assert [row.line for row in noted.skipped] == [sonar + 3]


def test_detection_progress_and_settings(tmp_path: Path) -> None:
    path = write_log_lines(tmp_path / "drive.log", player_lines(simulated_drive()))
    assert is_player_log(path) and not is_player_log(tmp_path / "missing.log")
    calls: list[tuple[str, int, int]] = []
    read_player_log(path, progress=lambda *call: calls.append(call))
    size = path.stat().st_size
    assert calls[-1] == ("reading drive.log", size, size)
    with pytest.raises(InputError, match="max_pose_gap"):
        read_player_log(path, max_pose_gap=-1.0)
    with pytest.raises(FormatError, match="not a regular file"):
        read_player_log(tmp_path)


def test_a_gzipped_player_log_is_detected_and_read(tmp_path: Path) -> None:
    path = write_log_lines(tmp_path / "drive.log", player_lines(simulated_drive()))
    packed = tmp_path / "drive.log.gz"
    packed.write_bytes(gzip.compress(path.read_bytes()))
    assert is_player_log(packed)
    plain, unpacked = read_player_log(path).log, read_player_log(packed).log
    assert np.array_equal(plain.ranges, unpacked.ranges)
    assert np.array_equal(plain.poses, unpacked.poses)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    extra=st.lists(
        st.tuples(
            st.integers(0, 60),
            junk_lines(["1", "0", "16", "sonar", "position2d", "001", "-1", "x"]),
        ),
        max_size=8,
    ),
    strict=st.booleans(),
)
def test_junk_lines_never_crash_the_reader(
    tmp_path: Path, extra: list[tuple[int, str]], strict: bool
) -> None:
    lines = player_lines(simulated_drive(), geometry=False)[:60]
    read_with_junk(read_player_log, tmp_path / "junk.log", lines, extra, strict, first=2)
