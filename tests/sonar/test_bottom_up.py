"""Tests of Acceptability and Agreeability."""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import box

from bayesmap.sim.polygons import _make
from bayesmap.sim.sonar import EchoKind, SonarRing, h
from bayesmap.sonar.bottom_up import Verdict, acceptability, agreeability, neighbour_bounds
from bayesmap.sonar.geometry import SonarGeometry

HALF = math.radians(12.5)
CRIT = math.radians(15.0)


def test_bounds_contain_the_neighbours_true_reading_of_a_flat_wall() -> None:
    """Facing a flat wall, a direct neighbour's noiseless reading lies inside the bounds."""
    w = _make("test-wall", box(-50.0, 0.0, 50.0, 20.0), [], [(0.0, 1.0), (1.0, 1.0)])
    ring = SonarRing.ring(16, radius=0.15, fan=61)
    geometry = SonarGeometry(angles=ring.angles, radius=ring.radius)
    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(60):
        pose = np.array([0.0, rng.uniform(0.5, 3.0), rng.uniform(-math.pi, math.pi)])
        scan = h(w, pose[None], ring)
        centres, axis = geometry.sensors(pose)
        direct = scan.kind[0] == EchoKind.DIRECT
        for k in np.flatnonzero(direct):
            n = (k + 1) % 16
            if not direct[n]:
                continue
            lo, hi = neighbour_bounds(
                scan.ranges[0, k : k + 1],
                centres[k : k + 1],
                axis[k : k + 1],
                centres[n : n + 1],
                axis[n : n + 1],
                half_width=HALF,
                critical_angle=CRIT,
                tilts=41,
            )
            assert lo[0] - 0.02 <= scan.ranges[0, n] <= hi[0] + 0.02
            checked += 1
    assert checked > 20


RING8 = SonarGeometry(angles=tuple(2 * math.pi * k / 8 for k in range(8)), sigma=0.02)


def _acceptability(ranges: np.ndarray) -> Verdict:
    """Acceptability on the 8-transducer ring at the origin."""
    centres, axis = RING8.sensors(np.zeros(3))
    left, right = RING8.neighbours()
    return acceptability(
        ranges,
        RING8.echo(ranges),
        centres,
        axis,
        left,
        right,
        sigma=0.02,
        half_width=HALF,
        critical_angle=CRIT,
    )


def test_acceptability_discards_a_phantom_only_when_both_neighbours_refute_it() -> None:
    ranges = np.full(8, 2.0)
    ranges[3] = 4.0  # a far phantom between two neighbours that see a wall at 2 m
    verdict = _acceptability(ranges)
    assert verdict.discard.tolist() == [k == 3 for k in range(8)]
    ranges[4] = 4.0  # now neighbour 4 supports 3: both kept, each flagged by its other neighbour
    verdict = _acceptability(ranges)
    assert not verdict.discard.any()
    assert verdict.flag[3] and verdict.flag[4]


def test_acceptability_never_judges_no_echo_readings() -> None:
    ranges = np.full(8, 5.0)
    ranges[::2] = 1.0
    verdict = _acceptability(ranges)
    assert not verdict.discard[1::2].any() and not verdict.flag[1::2].any()


def test_agreeability_rules() -> None:
    left, right = RING8.neighbours()
    echo = np.array([True, False, True, False, False, True, True, True])
    verdict = agreeability(echo, left, right)
    # 1: both neighbours echo -> discard; 3: neighbour 2 echoes -> flag; 4: 5 echoes -> flag
    assert verdict.discard.tolist() == [False, True, False, False, False, False, False, False]
    assert verdict.flag.tolist() == [False, False, False, True, True, False, False, False]


def test_open_arc_ends_are_flagged_never_discarded() -> None:
    geometry = SonarGeometry(
        angles=tuple(math.radians(a) for a in (90, 50, 30, 10, -10, -30, -50, -90))
    )
    assert not geometry.is_closed
    left, right = geometry.neighbours()
    assert left[0] == -1 and right[-1] == -1
    echo = np.array([False, True, True, True, True, True, True, False])
    verdict = agreeability(echo, left, right)
    assert not verdict.discard.any()
    assert verdict.flag[0] and verdict.flag[7]
