"""Logged drives and IR calibrations: the real-data path of ``bayesmap rover map``."""

from __future__ import annotations

import gzip
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from bayesmap._io import verify_run_folder
from bayesmap.cli import app
from bayesmap.errors import FormatError, InputError
from bayesmap.grid import OccupancyGrid
from bayesmap.rover.logs import read_calibration, read_rover_log
from bayesmap.sensing.ir import RAW_FIT, fit_calibration, raw_from_range
from bayesmap.sim import rover as sim_rover
from bayesmap.sim.world2d import box_world

runner = CliRunner()


def _drive_log(path: Path, rng: np.random.Generator) -> None:
    """A simulated drive past the paper's box at (7, 10), written in cm and degrees."""
    world = box_world("rover-field-obstacles-v1")
    params = sim_rover.SimulatedRoverParams()
    state = sim_rover.initial([4.0, 10.0, 0.0], params, rng=rng)
    lines = ["t,x,y,heading,ir_0,ir_1,ir_2"]
    for k in range(60):
        obs = sim_rover.observe(world, state, params, rng=rng)
        x, y, heading = obs.pose
        lines.append(
            f"{0.4 * k:.1f},{100 * x:.2f},{100 * y:.2f},{math.degrees(heading):.3f},"
            + ",".join(f"{v:.0f}" for v in obs.raw)
        )
        command = (0.25, 0.0) if k < 25 else (0.0, 0.8)  # approach, then turn in place
        state = sim_rover.transition(state, command, params, rng=rng)
    lines.insert(10, "1.0,nan,3,4,5,6,7")  # line 11: a NaN
    lines.insert(20, "# a comment")
    lines.insert(30, "2.0,100,100,0,5,6")  # line 31: a field short
    lines.insert(40, "3.0,100,100,0,5,6,300")  # line 41: reading out of range
    path.write_text("\n".join(lines) + "\n")


def test_fit_recovers_the_paper_calibration() -> None:
    rng = np.random.default_rng(0)
    distance = np.linspace(0.1, 2.0, 40)
    raw = raw_from_range(distance) + rng.normal(0, 0.3, distance.size)
    fit = fit_calibration(raw, distance)
    np.testing.assert_allclose(raw_from_range(distance, fit), raw_from_range(distance), atol=0.5)
    with pytest.raises(InputError):
        fit_calibration([1.0, 2.0], [0.5, 1.0])
    with pytest.raises(InputError, match="every raw reading of the IR calibration is 0"):
        fit_calibration([0.0, 0.0, 0.0, 0.0], [0.5, 1.0, 1.5, 2.0])
    with warnings.catch_warnings():  # three pairs fit exactly: no covariance, no warning
        warnings.simplefilter("error")
        three = np.array([0.3, 0.8, 1.6])
        np.testing.assert_allclose(fit_calibration(raw_from_range(three), three), RAW_FIT)


def test_map_command_replays_a_log_with_a_fitted_calibration(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    _drive_log(tmp_path / "drive.csv", rng)
    distance = np.linspace(10, 200, 25)  # cm
    pairs = ["raw,distance"] + [
        f"{r:.2f},{d:.1f}" for r, d in zip(raw_from_range(distance / 100), distance, strict=True)
    ]
    (tmp_path / "cal.csv").write_text("\n".join(pairs) + "\n")
    out = tmp_path / "out"
    args = ["rover", "map", str(tmp_path / "drive.csv"), "--out", str(out)]
    units = ["--position-unit", "cm", "--heading-unit", "deg"]
    calibration = ["--calibration", str(tmp_path / "cal.csv"), "--distance-unit", "cm"]
    result = runner.invoke(app, [*args, *units, *calibration])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert [row["line"] for row in summary["skipped"]] == [11, 31, 41]
    assert summary["rows"] == 60
    np.testing.assert_allclose([summary["calibration"][k] for k in "abc"], RAW_FIT, rtol=5e-3)
    grid = OccupancyGrid.load_npz(out / "map.npz")
    box = grid.world_to_cell(6.6, 10.0)  # the face of the 1 m box at (7, 10) it drove at
    before = grid.world_to_cell(5.5, 10.0)
    assert grid.probability[box] > 0.5 > 0.1 > grid.probability[before]
    verify_run_folder(out)  # written whole, with its manifest
    strict = runner.invoke(app, [*args, *units, "--strict"])
    assert strict.exit_code == 1 and "line 11" in strict.output
    assert json.loads((out / "summary.json").read_text()) == summary  # the failed run left it
    (out / "drive.csv").write_bytes((tmp_path / "drive.csv").read_bytes())  # the log moved in
    moved = ["rover", "map", str(out / "drive.csv"), "--out", str(out), *units]
    refused = runner.invoke(app, moved)
    assert refused.exit_code != 0 and "holds 'drive.csv'" in refused.output
    assert (out / "drive.csv").exists()
    in_cm = runner.invoke(app, [*args, *units, "--resolution", "50"])
    assert in_cm.exit_code == 1 and "Traceback" not in in_cm.output
    assert "--resolution is 50 m" in in_cm.output and "cm or mm" in in_cm.output


def test_a_gzipped_log_reads_as_the_plain_one(tmp_path: Path) -> None:
    _drive_log(tmp_path / "drive.csv", np.random.default_rng(4))
    (tmp_path / "drive.csv.gz").write_bytes(gzip.compress((tmp_path / "drive.csv").read_bytes()))
    plain = read_rover_log(tmp_path / "drive.csv", 3, position_unit="cm", heading_unit="deg")
    packed = read_rover_log(tmp_path / "drive.csv.gz", 3, position_unit="cm", heading_unit="deg")
    assert np.array_equal(plain.raw, packed.raw) and np.array_equal(plain.poses, packed.poses)
    assert [(r.line, r.reason) for r in plain.skipped] == [
        (r.line, r.reason) for r in packed.skipped
    ]
    rows = b"x,y,heading,ir_0,ir_1,ir_2\n" + b"1.0,2.0,0.5,10,20,30\n" * 50_000
    packed = gzip.compress(rows)
    (tmp_path / "cut.csv.gz").write_bytes(packed[: len(packed) // 2])
    with pytest.raises(FormatError, match="cut.csv.gz.*gzip stream is cut short") as info:
        read_rover_log(tmp_path / "cut.csv.gz", 3)
    assert info.value.line is not None and info.value.line > 1000


def test_bad_logs_and_calibrations_are_format_errors(tmp_path: Path) -> None:
    (tmp_path / "a.csv").write_text("x,y,heading,ir_0\n1,2,3,4\n")
    with pytest.raises(FormatError, match="ir_1"):
        read_rover_log(tmp_path / "a.csv", 3)
    (tmp_path / "c.json").write_text('{"a": 1, "b": "x"}')
    with pytest.raises(FormatError):
        read_calibration(tmp_path / "c.json")
    (tmp_path / "c.csv").write_text("raw,distance\n10,1\n20,oops\n")
    with pytest.raises(FormatError, match="line 3|two numbers"):
        read_calibration(tmp_path / "c.csv")
    for flat in ({"a": 0, "b": 0, "c": 0}, {"a": 1, "b": 1, "c": 1}, {"a": -8, "b": 57, "c": -1}):
        (tmp_path / "c.json").write_text(json.dumps(flat))
        with pytest.raises(FormatError, match="does not fall with range"):
            read_calibration(tmp_path / "c.json")
    (tmp_path / "c.csv").write_text("raw,distance\n50,10\n30,30\n20,60\n10,150\n")
    with pytest.raises(FormatError, match="distances up to 150 m.*--distance-unit"):
        read_calibration(tmp_path / "c.csv")
    assert len(read_calibration(tmp_path / "c.csv", distance_unit="cm")) == 3


@pytest.mark.parametrize("field", ["1_0", "Infinity", "nan", "\u0663"])
def test_numbers_are_plain_decimals(tmp_path: Path, field: str) -> None:
    """Only ASCII decimals are numbers: a field Python's ``float`` would also read costs its
    row (with ``strict``, names its line); a calibration given as such text is refused."""
    (tmp_path / "a.csv").write_text(f"x,y,heading,ir_0\n1,2,0,40\n1,2,0,{field}\n3,2,0,41\n")
    log = read_rover_log(tmp_path / "a.csv", 1)
    assert log.raw.ravel().tolist() == [40.0, 41.0]
    assert [row.line for row in log.skipped] == [3]
    with pytest.raises(FormatError, match="line 3"):
        read_rover_log(tmp_path / "a.csv", 1, strict=True)
    (tmp_path / "c.csv").write_text(f"raw,distance\n10,1\n{field},2\n")
    with pytest.raises(FormatError, match="two numbers"):
        read_calibration(tmp_path / "c.csv")
    (tmp_path / "c.json").write_text(json.dumps({"a": "1_0", "b": 1.0, "c": 0.0}))
    with pytest.raises(FormatError, match="numbers"):
        read_calibration(tmp_path / "c.json")


def test_a_pose_that_leaps_away_and_back_costs_its_row(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    rows = [f"{0.1 * k:.1f},1,0,40" for k in range(6)]
    rows[3] = "3000,1,0,40"  # a dropped decimal point
    (tmp_path / "a.csv").write_text("x,y,heading,ir_0\n" + "\n".join(rows) + "\n")
    log = read_rover_log(tmp_path / "a.csv", 1)
    assert [row.line for row in log.skipped] == [5] and "leaps" in log.skipped[0].reason
    assert log.poses[:, 0].tolist() == pytest.approx([0.0, 0.1, 0.2, 0.4, 0.5])
    with pytest.raises(FormatError, match="line 5: the position leaps"):
        read_rover_log(tmp_path / "a.csv", 1, strict=True)
    millimetres = [f"{100 * k},1000,0,40" for k in range(6)]
    (tmp_path / "mm.csv").write_text("x,y,heading,ir_0\n" + "\n".join(millimetres) + "\n")
    read_rover_log(tmp_path / "mm.csv", 1)
    assert "are the positions in cm or mm?" in caplog.text


def test_a_folder_is_not_a_log(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="not a regular file"):
        read_rover_log(tmp_path, 1)


def test_fields_padded_with_control_whitespace_are_read(tmp_path: Path) -> None:
    """Found by fuzzing: a field such as ``"\\x1f20"`` is 20 once stripped, as the check sees it."""
    (tmp_path / "c.csv").write_text("raw,distance\n\x1f120,0.1\n80,0.2\n50,0.35\n30,0.6\n")
    assert len(read_calibration(tmp_path / "c.csv")) == 3
    (tmp_path / "a.csv").write_text("x,y,heading,ir_0\n1,2,0,\x1f40\n")
    assert read_rover_log(tmp_path / "a.csv", 1).raw.tolist() == [[40.0]]


def test_a_lone_carriage_return_ends_a_line(tmp_path: Path) -> None:
    """Found by fuzzing: ``\\r`` ends a line as in text mode, so a file saved with old Mac
    line ends or a stray ``\\r`` reads as its lines instead of stopping the csv parser."""
    (tmp_path / "c.csv").write_bytes(b"\raw,distance\n120,0.1\n80,0.2\n50,0.35\n30,0.6\n")
    with pytest.raises(FormatError, match="c.csv, line 2: .*lacks the column"):
        read_calibration(tmp_path / "c.csv")
    (tmp_path / "mac.csv").write_bytes(b"raw,distance\r120,0.1\r80,0.2\r\n50,0.35\r30,0.6\r")
    (tmp_path / "unix.csv").write_bytes(b"raw,distance\n120,0.1\n80,0.2\n50,0.35\n30,0.6\n")
    assert read_calibration(tmp_path / "mac.csv") == read_calibration(tmp_path / "unix.csv")
    (tmp_path / "a.csv").write_bytes(b"x,y,heading,ir_0\r1,2,0,40\r\r# note\r1,2,0,\r")
    log = read_rover_log(tmp_path / "a.csv", 1)
    assert log.raw.tolist() == [[40.0]] and [row.line for row in log.skipped] == [5]


def test_bytes_that_are_not_utf8_cost_only_their_row(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    lines = [b"# logged by the r\xf6ver (Latin-1)", b"x,y,heading,ir_0,ir_1,ir_2"]
    lines += [b"%d.0,1.0,0.5,10,20,30" % k for k in range(30)]
    lines[10] = b"8.0,1.0,0.5,1\xb00,20,30"
    (tmp_path / "drive.csv").write_bytes(b"\n".join(lines) + b"\n")
    calls: list[tuple[str, int, int]] = []
    with caplog.at_level("WARNING", logger="bayesmap.rover.logs"):
        log = read_rover_log(tmp_path / "drive.csv", 3, progress=lambda *c: calls.append(c))
    assert [row.line for row in log.skipped] == [11] and len(log.poses) == 29
    assert calls[-1] == ("reading drive.csv", 1, 1)
    assert "headings reach" not in caplog.text


def test_headings_in_degrees_read_as_radians_get_a_hint(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    rows = ["x,y,heading,ir_0,ir_1,ir_2"] + [f"{0.1 * k},1.0,{3 * k},10,20,30" for k in range(60)]
    (tmp_path / "drive.csv").write_text("\n".join(rows) + "\n")
    with caplog.at_level("WARNING", logger="bayesmap.rover.logs"):
        read_rover_log(tmp_path / "drive.csv", 3)
    assert "headings reach 177 rad: if they are in degrees, give --heading-unit deg" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="bayesmap.rover.logs"):
        read_rover_log(tmp_path / "drive.csv", 3, heading_unit="deg")
    assert not caplog.records


def test_a_bad_field_is_named_by_its_column_and_a_doubled_column_is_refused(
    tmp_path: Path,
) -> None:
    path = tmp_path / "drive.csv"
    path.write_text("x,y,heading,ir_0,ir_1,ir_2\n1,1,0,10,abc,30\n1,1,0,10,20,300\n1,1,0,1,2,3\n")
    data = read_rover_log(path, 3)
    assert [(row.line, row.reason) for row in data.skipped] == [
        (2, "column ir_1: 'abc' is not a finite plain decimal number"),
        (3, "column ir_2: the IR reading 300 is outside 0..255"),
    ]
    path.write_text("x,y,heading,ir_0,ir_1,ir_2,ir_0\n1,1,0,10,20,30,40\n")
    with pytest.raises(FormatError, match="names the column ir_0 more than once"):
        read_rover_log(path, 3)


def test_a_drive_in_metres_read_as_millimetres_is_pointed_out(tmp_path: Path, caplog) -> None:
    path = tmp_path / "drive.csv"
    rows = [f"{1 + 0.1 * k:.1f},2.0,0.0,10,20,30" for k in range(30)]
    path.write_text("x,y,heading,ir_0,ir_1,ir_2\n" + "\n".join(rows) + "\n")
    with caplog.at_level("WARNING"):
        read_rover_log(path, 3, position_unit="mm")
    assert "the positions span 0.0029 m over 30 rows" in caplog.text
