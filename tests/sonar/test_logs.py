"""Tests of the real-log loader and writer (including hypothesis fuzzing)."""

from __future__ import annotations

import gzip
import math
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from bayesmap.errors import FormatError, InputError
from bayesmap.geometry import isolated_jumps
from bayesmap.sonar.logs import (
    SHOWN_SKIPS,
    LogUnits,
    SonarLog,
    read_sonar_log,
    write_sonar_log,
)

DATA = Path(__file__).parent / "data"
MM = LogUnits(range_unit="mm", position_unit="mm", heading_unit="deg")


def test_example_log_reports_every_bad_row_with_its_line() -> None:
    log = read_sonar_log(DATA / "example_log.txt", 16, units=MM)
    lines = [row.line for row in log.skipped]
    assert lines == [13, 21, 31, 41]
    assert "'nan' is not a plain decimal" in log.skipped[0].reason
    assert "not a plain decimal" in log.skipped[1].reason
    assert "columns" in log.skipped[2].reason
    assert "out of order" in log.skipped[3].reason
    assert log.rows == len(log.timestamps) + len(log.skipped)
    assert np.all(np.diff(log.timestamps) > 0)
    assert log.poses[0].tolist() == pytest.approx([1.5, 1.5, 0.0])
    assert np.nanmax(log.ranges) == pytest.approx(5.0)


def test_reading_reports_the_bytes_read_of_the_file() -> None:
    calls: list[tuple[str, int, int]] = []
    read_sonar_log(DATA / "example_log.txt", 16, units=MM, progress=lambda *c: calls.append(c))
    size = (DATA / "example_log.txt").stat().st_size
    assert calls[-1] == ("reading example_log.txt", size, size)


def test_a_leaping_pose_and_a_repeated_timestamp_cost_their_rows(tmp_path: Path) -> None:
    rows = [f"{t} {0.1 * t:.1f} 0 0 1.0 2.0" for t in range(6)]
    rows[2] = "2 3000 0 0 1.0 2.0"
    rows.insert(4, rows[3])  # line 5 repeats line 4
    (tmp_path / "log.txt").write_text("\n".join(rows) + "\n")
    log = read_sonar_log(tmp_path / "log.txt", 2)
    reasons = {row.line: row.reason for row in log.skipped}
    assert sorted(reasons) == [3, 5] or sorted(reasons) == [3, 4]
    assert "leaps over 5 m away and back" in reasons[3]
    assert any("repeats line" in reason for reason in reasons.values())
    assert np.all(np.abs(log.poses[:, 0]) < 1.0)


def test_strict_mode_aborts_at_the_first_bad_row() -> None:
    with pytest.raises(FormatError) as info:
        read_sonar_log(DATA / "example_log.txt", 16, units=MM, strict=True)
    assert info.value.line == 13 and "example_log.txt" in str(info.value)


def test_a_pose_file_without_poses_is_named(tmp_path: Path) -> None:
    for text, words in (("", "no pose rows"), ("# t x y\n1 a 2 3\n", r"no usable pose rows \(1")):
        poses = tmp_path / "poses.txt"
        poses.write_text(text)
        with pytest.raises(FormatError, match=words) as info:
            read_sonar_log(DATA / "example_ranges.csv", 16, poses_path=poses)
        assert info.value.path == str(poses)


def test_two_files_joined_by_timestamp_report_missing_poses() -> None:
    units = LogUnits(range_unit="cm", position_unit="cm", heading_unit="rad")
    log = read_sonar_log(
        DATA / "example_ranges.csv",
        16,
        poses_path=DATA / "example_poses.csv",
        units=units,
        time_tolerance=1e-6,
        max_pose_gap=0.0,
    )
    single = read_sonar_log(DATA / "example_log.txt", 16, units=MM)
    assert [row.line for row in log.skipped] == [8, 9]
    assert all("no pose" in row.reason or "max pose gap" in row.reason for row in log.skipped)
    # With interpolation across the missing poses the same rows are kept.
    joined = read_sonar_log(
        DATA / "example_ranges.csv", 16, poses_path=DATA / "example_poses.csv", units=units
    )
    assert joined.skipped == () and len(joined.timestamps) == len(log.timestamps) + 2
    common = np.intersect1d(log.timestamps, single.timestamps)
    a = np.isin(log.timestamps, common)
    b = np.isin(single.timestamps, common)
    assert np.allclose(log.ranges[a], single.ranges[b], atol=1e-6)
    assert np.allclose(log.poses[a, :2], single.poses[b, :2], atol=1e-6)
    assert np.allclose(log.poses[a, 2], single.poses[b, 2], atol=1e-6)


@pytest.mark.parametrize(
    ("units", "scale", "angle"),
    [
        (LogUnits("mm", "cm", "decideg"), (1e-3, 1e-2), math.pi / 1800),
        (LogUnits("m", "m", "rad"), (1, 1), 1.0),
    ],
)
def test_units_are_converted_once(
    tmp_path: Path, units: LogUnits, scale: tuple[float, float], angle: float
) -> None:
    path = tmp_path / "log.txt"
    path.write_text("1 10 20 900 1000 2000\r\n\n# c\n2,11,21,450,1500,inf")
    log = read_sonar_log(path, 2, units=units)
    assert log.ranges[0].tolist() == pytest.approx([1000 * scale[0], 2000 * scale[0]])
    assert math.isinf(log.ranges[1, 1])
    assert log.poses[0].tolist() == pytest.approx([10 * scale[1], 20 * scale[1], 900 * angle])


def test_bad_arguments_and_hopeless_files(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="cannot open"):
        read_sonar_log(tmp_path / "missing.txt", 4)
    with pytest.raises(FormatError, match="not a regular file"):
        read_sonar_log(tmp_path, 4)
    with pytest.raises(InputError):
        LogUnits(range_unit="furlong")  # type: ignore[arg-type]
    empty = tmp_path / "empty.txt"
    empty.write_text("# nothing\n\n")
    with pytest.raises(FormatError):
        read_sonar_log(empty, 4)


finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    rows=st.integers(1, 12),
    n=st.integers(1, 6),
    data=st.data(),
    delimiter=st.sampled_from([" ", ",", "\t", ", "]),
)
def test_write_then_read_round_trips(
    tmp_path: Path, rows: int, n: int, data: st.DataObject, delimiter: str
) -> None:
    t = np.cumsum(data.draw(st.lists(st.floats(0.01, 100), min_size=rows, max_size=rows)))
    poses = np.array(
        data.draw(st.lists(st.tuples(finite, finite, finite), min_size=rows, max_size=rows))
    )
    assume(not isolated_jumps(poses[:, :2]).any())  # SI metres: a leap out and back is skipped
    ranges = np.array(
        data.draw(
            st.lists(
                st.lists(st.floats(0, 1e4), min_size=n, max_size=n), min_size=rows, max_size=rows
            )
        )
    )
    path = write_sonar_log(tmp_path / "rt.txt", t, ranges, poses, units=MM, delimiter=delimiter)
    log = read_sonar_log(path, n, units=MM)
    assert log.skipped == () and len(log.timestamps) == rows
    assert np.allclose(log.ranges, ranges, rtol=1e-8, atol=1e-9)
    assert np.allclose(log.poses[:, :2], poses[:, :2], rtol=1e-8, atol=1e-9)


junk_line = st.one_of(
    st.text(max_size=60),
    st.lists(
        st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.text(max_size=5)),
        max_size=8,
    ).map(" ".join),
    st.lists(
        st.floats(allow_nan=False, allow_infinity=False, width=32).map(str), min_size=5, max_size=5
    ).map(",".join),
)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(lines=st.lists(junk_line, max_size=15), strict=st.booleans(), binary=st.binary(max_size=30))
def test_fuzzed_files_never_crash(
    tmp_path: Path, lines: list[str], strict: bool, binary: bytes
) -> None:
    path = tmp_path / "fuzz.txt"
    path.write_bytes("\n".join(lines).encode("utf-8", errors="surrogatepass") + binary)
    try:
        log = read_sonar_log(path, 1, strict=strict)
    except (FormatError, InputError):
        return
    assert isinstance(log, SonarLog)
    assert len(log.timestamps) == len(log.poses) == len(log.ranges) >= 1
    assert np.all(np.diff(log.timestamps) > 0)
    assert not np.isnan(log.ranges).any() and np.all(log.ranges >= 0)
    assert all(row.line >= 1 for row in log.skipped)


def _write_ring_log(path: Path, times: np.ndarray, n: int = 2) -> None:
    rows = [f"{float(t)!r} {0.1 * i} 0 0 " + " ".join(["1.5"] * n) for i, t in enumerate(times)]
    path.write_text("\n".join(rows) + "\n")


def test_one_corrupt_timestamp_costs_its_row_only(tmp_path: Path) -> None:
    times = np.arange(100) * 0.1
    times[15] = 9.9e9  # a corrupt clock value
    path = tmp_path / "log.txt"
    _write_ring_log(path, times)
    log = read_sonar_log(path, 2)
    assert [row.line for row in log.skipped] == [16]
    assert len(log.timestamps) == 99
    with pytest.raises(FormatError) as info:
        read_sonar_log(path, 2, strict=True)
    assert info.value.line == 16


def test_strict_names_the_first_bad_line_whatever_the_fault(tmp_path: Path) -> None:
    times = np.arange(30) * 0.1
    times[20] = -5.0
    path = tmp_path / "log.txt"
    _write_ring_log(path, times)
    lines = path.read_text().splitlines()
    lines[25] = lines[25] + " 7"  # a column too many, later in the file
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError) as info:
        read_sonar_log(path, 2, strict=True)
    assert info.value.line == 21


def _pose_file(path: Path, times: np.ndarray, heading_deg: np.ndarray) -> None:
    rows = [
        f"{float(t)!r} {float(t)} {2 * float(t)} {float(h)!r}"
        for t, h in zip(times, heading_deg, strict=True)
    ]
    path.write_text("\n".join(rows) + "\n")


def test_poses_are_interpolated_with_a_clock_offset_and_half_rate(tmp_path: Path) -> None:
    ranges = tmp_path / "ranges.txt"
    t = np.arange(1, 41) * 0.1
    ranges.write_text("\n".join(f"{float(v)!r} 1.0 2.0" for v in t) + "\n")
    poses = tmp_path / "poses.txt"
    pose_t = np.arange(0, 22) * 0.2 + 0.001  # half the rate, 1 ms late
    _pose_file(poses, pose_t, np.full(len(pose_t), 10.0))
    units = LogUnits(heading_unit="deg")
    log = read_sonar_log(ranges, 2, poses_path=poses, units=units)
    assert log.skipped == () and len(log.timestamps) == 40
    assert np.allclose(log.poses[:, 0], t, atol=1e-9)
    assert np.allclose(log.poses[:, 1], 2 * t, atol=1e-9)


def test_heading_is_interpolated_along_the_shortest_arc(tmp_path: Path) -> None:
    ranges = tmp_path / "ranges.txt"
    ranges.write_text("0.5 1.0\n")
    poses = tmp_path / "poses.txt"
    _pose_file(poses, np.array([0.0, 1.0]), np.array([170.0, -170.0]))
    log = read_sonar_log(ranges, 1, poses_path=poses, units=LogUnits(heading_unit="deg"))
    assert abs(math.remainder(log.poses[0, 2] - math.pi, 2 * math.pi)) < 1e-9


def test_pose_gaps_beyond_the_limit_cost_their_rows(tmp_path: Path) -> None:
    ranges = tmp_path / "ranges.txt"
    ranges.write_text("1.0 1.0\n5.0 1.0\n9.0 1.0\n")
    poses = tmp_path / "poses.txt"
    _pose_file(poses, np.array([0.9, 1.1, 8.0, 9.0]), np.zeros(4))
    log = read_sonar_log(ranges, 1, poses_path=poses, max_pose_gap=1.0)
    assert [row.line for row in log.skipped] == [2]
    assert "max pose gap" in log.skipped[0].reason
    assert len(read_sonar_log(ranges, 1, poses_path=poses, max_pose_gap=10.0).timestamps) == 3


@pytest.mark.parametrize("field", ["1_0", "Infinity", "nan", "0x10", "\u0663", "1e5e"])
def test_numbers_are_plain_decimals(tmp_path: Path, field: str) -> None:
    """Only ASCII decimals are numbers (``inf`` only as a no-echo range): anything Python's
    ``float`` would also read costs its row, and ``--strict`` names that line."""
    path = tmp_path / "log.txt"
    path.write_text(f"1 0 0 0 1.5 inf\n2 0 0 0 {field} 2.0\n3 0 0 0 1.0 1.0\n", encoding="utf-8")
    log = read_sonar_log(path, 2)
    assert log.timestamps.tolist() == [1.0, 3.0]
    assert [(row.line, "plain decimal" in row.reason) for row in log.skipped] == [(2, True)]
    with pytest.raises(FormatError, match="line 2"):
        read_sonar_log(path, 2, strict=True)


def test_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "log.fifo"
    os.mkfifo(fifo)
    with pytest.raises(FormatError, match="not a regular file"):
        read_sonar_log(fifo, 2)


def test_a_gzipped_log_reads_as_the_plain_one_whatever_its_name(tmp_path: Path) -> None:
    plain = read_sonar_log(DATA / "example_log.txt", 16, units=MM)
    packed = gzip.compress((DATA / "example_log.txt").read_bytes())
    for name in ("log.txt.gz", "renamed.txt"):
        (tmp_path / name).write_bytes(packed)
        calls: list[tuple[str, int, int]] = []
        log = read_sonar_log(tmp_path / name, 16, units=MM, progress=lambda *c: calls.append(c))  # noqa: B023
        assert np.array_equal(log.ranges, plain.ranges, equal_nan=True)
        assert np.array_equal(log.poses, plain.poses)
        assert [(r.line, r.reason) for r in log.skipped] == [
            (r.line, r.reason) for r in plain.skipped
        ]
        assert calls[-1] == (f"reading {name}", len(packed), len(packed))


def test_a_gzipped_log_cut_short_names_the_file_and_line(tmp_path: Path) -> None:
    rows = "".join(f"{t} 0 0 0 1.0 2.0\n" for t in range(20_000))
    packed = gzip.compress(rows.encode())
    (tmp_path / "cut.txt.gz").write_bytes(packed[: len(packed) // 2])
    with pytest.raises(FormatError, match="gzip stream is cut short") as info:
        read_sonar_log(tmp_path / "cut.txt.gz", 2)
    assert "cut.txt.gz" in str(info.value) and info.value.line is not None
    assert info.value.line > 1000
    damaged = bytearray(packed)
    damaged[len(packed) // 2 : len(packed) // 2 + 64] = bytes(64)
    (tmp_path / "damaged.txt.gz").write_bytes(bytes(damaged))
    with pytest.raises(FormatError, match="gzip stream is corrupt") as info:
        read_sonar_log(tmp_path / "damaged.txt.gz", 2)
    assert info.value.line is not None and "\n" not in str(info.value)
    (tmp_path / "bomb.txt.gz").write_bytes(gzip.compress(b"1" * (64 << 20)))
    with pytest.raises(FormatError, match="longer than") as info:
        read_sonar_log(tmp_path / "bomb.txt.gz", 2)
    assert info.value.line == 1


def test_a_log_of_bad_rows_names_a_few_and_counts_the_rest(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    rows = [f"{t} 0 0 0 1.0 2.0" if t % 2 else f"{t} 0 0 0 1.0 oops" for t in range(200)]
    (tmp_path / "log.txt").write_text("\n".join(rows) + "\n")
    with caplog.at_level("WARNING", logger="bayesmap.sonar.logs"):
        log = read_sonar_log(tmp_path / "log.txt", 2)
    assert len(log.skipped) == 100 and len(caplog.records) == SHOWN_SKIPS + 1
    assert "100 of 200 rows skipped (50.0 %); the first 10 are named above" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="bayesmap.sonar.logs"):
        with pytest.raises(FormatError) as info:
            read_sonar_log(tmp_path / "log.txt", 2, strict=True)
    assert info.value.line == 1 and not caplog.records  # stopped at once, nothing printed


def test_the_summary_names_the_file_whose_rows_were_skipped(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    (tmp_path / "ranges.txt").write_text("".join(f"{t} 1.0 2.0\n" for t in range(10)))
    poses = "t x y heading\n" + "".join(f"{t} 0 0 0\n" for t in range(10))
    (tmp_path / "poses.txt").write_text(poses)
    with caplog.at_level("WARNING", logger="bayesmap.sonar.logs"):
        log = read_sonar_log(tmp_path / "ranges.txt", 2, poses_path=tmp_path / "poses.txt")
    assert [(Path(row.path).name, row.line) for row in log.skipped] == [("poses.txt", 1)]
    summary = caplog.records[-1].getMessage()
    assert "poses.txt: 1 row skipped" in summary and "ranges.txt" not in summary


def test_headings_in_degrees_read_as_radians_get_a_hint(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level("WARNING", logger="bayesmap.sonar.logs"):
        read_sonar_log(DATA / "example_log.txt", 16, units=replace(MM, heading_unit="rad"))
    assert "if they are in degrees, give --heading-unit deg" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="bayesmap.sonar.logs"):
        read_sonar_log(DATA / "example_log.txt", 16, units=MM)
    assert "headings reach" not in caplog.text


def test_timestamps_in_nanoseconds_join_with_the_time_unit(tmp_path: Path) -> None:
    """Two files stamped in ns (as ``rostopic echo -p`` writes): read as seconds every row
    is dropped, and the error says to give the unit; with it the log joins."""
    ns = replace(LogUnits(), time_unit="ns")
    t = 1.7e9 + 0.1 * np.arange(40)
    poses = np.column_stack([0.05 * np.arange(40), np.zeros(40), np.zeros(40)])
    ranges = write_sonar_log(tmp_path / "r.txt", t, np.full((40, 2), 1.5), units=ns)
    pose_file = write_sonar_log(tmp_path / "p.txt", t + 0.001, np.zeros((40, 0)), poses, units=ns)
    with pytest.raises(FormatError, match="give --time-unit"):
        read_sonar_log(ranges, 2, poses_path=pose_file)
    log = read_sonar_log(ranges, 2, poses_path=pose_file, units=ns)
    assert len(log.timestamps) == 40 and np.allclose(log.timestamps, t, atol=1e-6)
    assert np.allclose(log.poses[:, 0], poses[:, 0], atol=1e-3)
    with pytest.raises(InputError, match="unknown time unit 'fortnight'"):
        LogUnits(time_unit="fortnight")  # type: ignore[arg-type]


def test_semicolons_separate_fields_as_commas_do(tmp_path: Path) -> None:
    rows = [f"{t};{0.1 * t:.1f};0;0;1.0;2.0" for t in range(8)]
    (tmp_path / "semi.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "comma.csv").write_text("\n".join(r.replace(";", ", ") for r in rows) + "\n")
    semi, comma = (
        read_sonar_log(tmp_path / "semi.csv", 2),
        read_sonar_log(tmp_path / "comma.csv", 2),
    )
    assert semi.skipped == () and np.array_equal(semi.ranges, comma.ranges)
    assert np.array_equal(semi.poses, comma.poses)


def test_positions_in_metres_read_as_millimetres_are_pointed_out(tmp_path: Path, caplog) -> None:
    rows = [f"{k * 0.1:.1f} {k * 0.2:.2f} 1.0 0.0 " + " ".join(["2.0"] * 8) for k in range(30)]
    path = tmp_path / "drive.txt"
    path.write_text("\n".join(rows) + "\n")
    with caplog.at_level("WARNING"):
        read_sonar_log(path, 8, units=LogUnits(position_unit="mm"))
    assert "give --position-unit m (not mm)" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING"):
        read_sonar_log(path, 8, units=LogUnits(position_unit="m"))
    assert "position-unit" not in caplog.text
