"""Sweep logs: what the simulator writes reads back exactly; bad rows are named."""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from _fuzzing import FUZZ, mutated, read_within_budget
from bayesmap.blackboard.logs import SweepLog, read_sweep_log, write_sweep_log
from bayesmap.errors import BayesmapError, FormatError, InputError
from bayesmap.sim.whisker_worlds import parse_world
from bayesmap.sim.whiskers import condition, observe


def _tour() -> tuple[np.ndarray, list[np.ndarray]]:
    world = parse_world(
        {
            "arena": {"width": 4.0, "height": 3.0},
            "tables": [{"x": 2.0, "y": 1.5, "theta": 0.4, "length": 1.2, "width": 0.8, "leg": 0.1}],
        }
    ).world()
    poses = np.array([[1.0, 0.5, 0.0], [3.0, 0.5, math.pi / 2], [1.0, 2.5, math.pi]])
    rng = np.random.default_rng(5)
    return poses, [observe(world, p, condition("normal"), rng=rng).sweeps for p in poses]


@pytest.mark.parametrize("name", ["log.csv", "log.csv.gz", "log.parquet"])
def test_what_the_simulator_writes_reads_back_exactly(tmp_path: Path, name: str) -> None:
    poses, sweeps = _tour()
    assert any(np.isfinite(s[:, 3]).any() for s in sweeps)  # contacts and misses alike
    read = read_sweep_log(write_sweep_log(tmp_path / name, poses, sweeps))
    np.testing.assert_array_equal(read.poses, poses)
    assert len(read.sweeps) == len(sweeps)
    for got, want in zip(read.sweeps, sweeps, strict=True):
        np.testing.assert_array_equal(got, want)  # NaN where no contact, bit for bit
    assert read.whisker_length == 1.0


def test_units_rows_out_of_order_and_extra_columns(tmp_path: Path) -> None:
    table = pd.DataFrame(
        {
            "time": [0.0, 0.1, 0.2],
            "pose": [7, 3, 7],  # pose 7 first; its rows need not be together
            "x": [1000.0, 2000.0, 1000.0],
            "y": [500.0, 500.0, 500.0],
            "heading": [90.0, 0.0, 90.0],
            "start": [180.0, 45.0, 0.0],
            "stop": [135.0, 10.0, 45.0],
            "length": [1000.0, 1000.0, 1000.0],
            "range": [400.0, None, 800.0],
            "normal": [-45.0, None, 180.0],
        }
    )
    path = tmp_path / "mm.csv"
    path.write_text("# logged by hand\n" + table.to_csv(index=False))
    log = read_sweep_log(path, length_unit="mm", angle_unit="deg")
    np.testing.assert_allclose(log.poses, [[1.0, 0.5, math.pi / 2], [2.0, 0.5, 0.0]])
    first, second = log.sweeps
    np.testing.assert_allclose(first[:, [2, 3]], [[1.0, 0.4], [1.0, 0.8]])
    np.testing.assert_allclose(first[:, 4], [-math.pi / 4, math.pi])
    assert np.isnan(second[0, 3:]).all() and np.isnan(first[:, 5]).all()  # no texture column


GOOD = (
    "pose,x,y,heading,start,stop,length,range,normal\n"
    "0,1,1,0,1.5,0.5,1,0.4,3\n"
    "0,1,1,0,-1.5,-0.5,1,,\n"
)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (GOOD.replace(",normal", ",norm"), r"no column\(s\) \['normal'\]"),
        (GOOD.replace("0.4,3", "abc,3"), "row 1, column range: 'abc' is not a number"),
        (GOOD.replace("0.4,3", "inf,3"), "row 1: range must be a finite number"),
        (GOOD.replace("0.4,3", "-0.4,3"), "row 1: range must be >= 0"),
        (GOOD.replace("0.4,3", "400,3"), "row 1: range is over 10 whisker lengths"),
        (GOOD.replace("0.4,3", "0.4,"), "row 1: a contact needs a normal"),
        (GOOD.replace("-0.5,1,,", "-0.5,0,,"), "row 2: length must be > 0"),
        (GOOD.replace("0,1,1,0,-1.5", "0,1,2,0,-1.5"), "row 2: the pose's x, y and heading"),
        (GOOD.replace("0,1,1,0,-1.5", "0.5,1,1,0,-1.5"), "row 2: pose must be an integer"),
        (GOOD.replace("0,1,1,0,-1.5", "0,1,,0,-1.5"), "row 2: y must be a finite number"),
        (GOOD.splitlines()[0] + "\n", "the log has no rows"),
        ("", "cannot read the log"),
    ],
)
def test_bad_logs_are_one_line_naming_the_row(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(FormatError, match=message) as caught:
        read_sweep_log(path)
    assert caught.value.path == str(path) and "\n" not in str(caught.value)


def test_missing_files_and_unknown_units_are_named(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="no such file"):
        read_sweep_log(tmp_path / "missing.csv")
    (tmp_path / "log.parquet").write_bytes(b"not parquet")
    with pytest.raises(FormatError, match="cannot read the log"):
        read_sweep_log(tmp_path / "log.parquet")
    with pytest.raises(InputError, match="units"):
        read_sweep_log(tmp_path / "log.csv", length_unit="in")


@FUZZ
@given(data=st.data(), suffix=st.sampled_from([".csv", ".parquet"]))
def test_mutated_logs_give_a_log_or_a_clean_error(
    tmp_path_factory, data: st.DataObject, suffix: str
) -> None:
    seeds = [GOOD.encode(), b"# a note\n" + GOOD.replace("range,normal", "range,normal,t").encode()]
    if suffix == ".parquet":
        seeds = [pd.read_csv(io.BytesIO(GOOD.encode())).to_parquet(index=False)]
    path = tmp_path_factory.mktemp("log") / f"tour{suffix}"
    path.write_bytes(data.draw(mutated(seeds)))
    outcome = read_within_budget(lambda: read_sweep_log(path))
    assert isinstance(outcome, (SweepLog, BayesmapError))
