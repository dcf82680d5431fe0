"""Fuzzed sonar logs: tolerant and strict reads give a log or a BayesmapError, within budget."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from _fuzzing import FUZZ, mutated, read_within_budget
from bayesmap.errors import BayesmapError, InputError
from bayesmap.sonar.logs import SonarLog, read_sonar_log
from bayesmap.sonar.pipeline import grid_for_poses

DATA = Path(__file__).parent / "data"
SEEDS = [
    b"".join((DATA / "example_log.txt").read_bytes().splitlines(keepends=True)[:12]),
    b"# t x y heading r1 r2\n0 0 0 0 1.5 2.0\n0.5 0.1 0 0.1 1.4 nan\n1.0 0.2 0 0.2 1.3 1.9\n",
]


@FUZZ
@given(data=st.data(), strict=st.booleans())
def test_mutated_sonar_logs(tmp_path_factory, data: st.DataObject, strict: bool) -> None:
    path = tmp_path_factory.mktemp("log") / "log.txt"
    blob = data.draw(mutated(SEEDS))
    path.write_bytes(blob)
    n_ranges = 16 if blob.startswith(b"# sonar") else 2
    outcome = read_within_budget(lambda: read_sonar_log(path, n_ranges, strict=strict))
    assert isinstance(outcome, (SonarLog, BayesmapError))


def test_a_pose_far_away_is_a_clear_error_not_a_memory_error() -> None:
    poses = np.array([[0.0, 0.0, 0.0], [1.0e6, 5.0, 0.0]])  # one pose 1,000 km away
    with pytest.raises(InputError, match="cells .* over the limit .* look like millimetres"):
        grid_for_poses(poses, 5.0, 0.05)
