"""The explorer's drive: safe headings, backing off, retreats when hemmed in, pivots."""

from __future__ import annotations

import numpy as np
import pytest

from bayesmap.grid import OccupancyGrid
from bayesmap.rover.explorer import Explorer
from bayesmap.rover.params import RoverParams
from bayesmap.rover.safety import Safety, drive_command, retreat_command
from bayesmap.rover.targets import EntropyTarget

PARAMS = RoverParams(n_headings=36)


def _explorer() -> Explorer:
    return Explorer(
        OccupancyGrid(10.0, 10.0, 0.5, prior=PARAMS.prior), PARAMS, EntropyTarget(PARAMS)
    )


def _safety(*, retreat: bool, ahead: bool, back_clear: bool, here: float) -> Safety:
    safe = np.zeros(PARAMS.n_headings, dtype=bool)
    safe[18] = True  # only the heading behind
    return Safety(safe, np.zeros(PARAMS.n_headings), here, ahead, back_clear, retreat)


def test_a_retreat_pivots_onto_its_heading_instead_of_arcing() -> None:
    safety = _safety(retreat=True, ahead=False, back_clear=True, here=0.2)
    heading = float(np.asarray(PARAMS.headings)[18])
    psi = heading - 0.2  # the drive law would arc toward it; a retreat pivots onto it
    command = _explorer()._drive(heading, psi, safety, 18)
    assert command == retreat_command(heading, psi, PARAMS)
    assert command[0] == 0.0 and command[1] == pytest.approx(0.2 / PARAMS.dt)
    assert drive_command(heading, psi, PARAMS)[0] > 0.0


def test_backing_off_comes_before_a_retreat_when_the_obstacle_is_ahead() -> None:
    safety = _safety(retreat=True, ahead=True, back_clear=True, here=0.2)
    assert _explorer()._drive(np.pi, 0.0, safety, 18) == (-PARAMS.speed, 0.0)


def test_a_safe_heading_outside_a_retreat_follows_the_drive_law() -> None:
    safety = _safety(retreat=False, ahead=True, back_clear=True, here=0.5)
    heading = float(np.asarray(PARAMS.headings)[18])
    assert _explorer()._drive(heading, 0.5, safety, 18) == drive_command(heading, 0.5, PARAMS)
