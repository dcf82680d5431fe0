"""Tests of the real-log loader and writer (including hypothesis fuzzing)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bayesmap.errors import FormatError, InputError
from bayesmap.sonar.logs import LogUnits, SonarLog, read_sonar_log, write_sonar_log

DATA = Path(__file__).parent / "data"
MM = LogUnits(range_unit="mm", position_unit="mm", heading_unit="deg")


def test_example_log_reports_every_bad_row_with_its_line() -> None:
    log = read_sonar_log(DATA / "example_log.txt", 16, units=MM)
    lines = [row.line for row in log.skipped]
    assert lines == [13, 21, 31, 41]
    assert "NaN" in log.skipped[0].reason
    assert "non-numeric" in log.skipped[1].reason
    assert "columns" in log.skipped[2].reason
    assert "not after" in log.skipped[3].reason
    assert log.rows == len(log.timestamps) + len(log.skipped)
    assert np.all(np.diff(log.timestamps) > 0)
    assert log.poses[0].tolist() == pytest.approx([1.5, 1.5, 0.0])
    assert np.nanmax(log.ranges) == pytest.approx(5.0)


def test_strict_mode_aborts_at_the_first_bad_row() -> None:
    with pytest.raises(FormatError) as info:
        read_sonar_log(DATA / "example_log.txt", 16, units=MM, strict=True)
    assert info.value.line == 13 and "example_log.txt" in str(info.value)


def test_two_files_joined_by_timestamp_report_missing_poses() -> None:
    units = LogUnits(range_unit="cm", position_unit="cm", heading_unit="rad")
    log = read_sonar_log(
        DATA / "example_ranges.csv", 16, poses_path=DATA / "example_poses.csv", units=units
    )
    single = read_sonar_log(DATA / "example_log.txt", 16, units=MM)
    assert [row.line for row in log.skipped] == [8, 9]
    assert all("no pose" in row.reason for row in log.skipped)
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
    with pytest.raises(InputError):
        read_sonar_log(tmp_path / "missing.txt", 4)
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
