"""Fuzzed rover drive logs and IR calibrations: a result or a BayesmapError, within budget."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from _fuzzing import FUZZ, mutated, read_within_budget
from bayesmap.errors import BayesmapError
from bayesmap.rover.logs import RoverLog, read_calibration, read_rover_log

LOGS = [
    b"x,y,heading,ir_0,ir_1\n1.0,2.0,0.0,40,41\n1.1,2.0,0.1,42,43\n# note\n1.2,2.1,0.2,44,45\n",
    b"# a drive\nheading,x,y,ir_1,ir_0,extra\n0,0,0,10,20,a\n0.5,1e-1,2.5,11,21,b\n",
]
CALIBRATIONS = [
    b"raw,distance\n120,0.1\n80,0.2\n50,0.35\n30,0.6\n",
    b'{"a": 2.0, "b": 0.1, "c": 3.0}',
]


@FUZZ
@given(data=st.data(), strict=st.booleans())
def test_mutated_drive_logs(tmp_path_factory, data: st.DataObject, strict: bool) -> None:
    path = tmp_path_factory.mktemp("log") / "drive.csv"
    path.write_bytes(data.draw(mutated(LOGS)))
    outcome = read_within_budget(lambda: read_rover_log(path, 2, strict=strict))
    assert isinstance(outcome, (RoverLog, BayesmapError))


@FUZZ
@given(data=st.data())
def test_mutated_calibrations(tmp_path_factory, data: st.DataObject) -> None:
    blob = data.draw(mutated(CALIBRATIONS))
    path = tmp_path_factory.mktemp("cal") / (
        "ir.json" if blob.lstrip().startswith(b"{") else "ir.csv"
    )
    path.write_bytes(blob)
    outcome = read_within_budget(lambda: read_calibration(path))
    assert isinstance(outcome, (tuple, BayesmapError))
