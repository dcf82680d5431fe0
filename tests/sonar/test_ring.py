"""Tests of ring files and presets: offsets, units, overrides, and clear errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bayesmap.errors import ConfigError, FormatError, InputError
from bayesmap.sonar.bottom_up import neighbour_bounds
from bayesmap.sonar.ring import load_ring, preset


def test_pioneer_presets_put_transducers_where_aria_does() -> None:
    front = preset("pioneer8")
    assert front.n == 8 and not front.is_closed
    centres, axis = front.sensors(np.array([0.0, 0.0, 0.0]))
    assert centres[0].tolist() == pytest.approx([0.069, 0.136])
    assert math.degrees(axis[3]) == pytest.approx(10.0)
    full = preset("pioneer16")
    assert full.n == 16 and full.is_closed
    # Turned by 90°, the front-left transducer moves to the back-left of the frame.
    centres, _ = full.sensors(np.array([1.0, 1.0, math.pi / 2]))
    assert centres[0].tolist() == pytest.approx([1.0 - 0.136, 1.0 + 0.069])
    with pytest.raises(ConfigError):
        preset("roomba")


def test_yaml_ring_in_millimetres_matches_the_preset(tmp_path: Path) -> None:
    body = ["length_unit: mm", "beam_width: 25", "min_range: 100", "max_range: 5000", "sigma: 20"]
    body.append("transducers:")
    for x, y, a in ((69, 136, 90), (114, 119, 50), (148, 78, 30), (166, 27, 10)):
        body.append(f"  - {{x: {x}, y: {y}, heading: {a}, beam_width: 25}}")
    path = tmp_path / "ring.yaml"
    path.write_text("\n".join(body) + "\n")
    ring = load_ring(path)
    expected = preset("pioneer8")
    assert np.allclose(ring.offsets, expected.offsets[:4])
    assert ring.angles == pytest.approx(expected.angles[:4])
    assert ring.max_range == pytest.approx(5.0) and ring.sigma == pytest.approx(0.02)


def test_acceptability_uses_the_true_offsets() -> None:
    ring = preset("pioneer8")
    centres, axis = ring.sensors(np.array([0.0, 0.0, 0.0]))
    at_centre = np.zeros_like(centres)
    # Transducers 3 and 4 face a wall 1 m ahead: offsets matter by ~0.17 m.
    d = np.array([1.0 - 0.166])
    low_true, _ = neighbour_bounds(
        d, centres[3:4], axis[3:4], centres[4:5], axis[4:5], half_width=0.22, critical_angle=0.26
    )
    low_centre, _ = neighbour_bounds(
        d,
        at_centre[3:4],
        axis[3:4],
        at_centre[4:5],
        axis[4:5],
        half_width=0.22,
        critical_angle=0.26,
    )
    assert not np.allclose(low_true, low_centre)


@pytest.mark.parametrize(
    ("text", "error", "words"),
    [
        ("transducers: [{x: 0, y: 0, heading: 0}]", FormatError, "at least two"),
        (
            "transducers:\n  - {x: 0, y: 0}\n  - {x: 0, y: 0, heading: 1}",
            FormatError,
            "lacks heading",
        ),
        (
            "transducers:\n  - {x: a, y: 0, heading: 0}\n  - {x: 0, y: 0, heading: 1}",
            FormatError,
            "x",
        ),
        (
            "transducers:\n  - {x: 0, y: 0, heading: 0, sigma: 0.5}\n  - {x: 0, y: 0, heading: 1}",
            ConfigError,
            "sigma differs",
        ),
        ("length_unit: furlong\ntransducers: []", FormatError, "length_unit"),
        ("transducers: [", FormatError, "line"),
    ],
)
def test_bad_ring_files_say_where_and_what(
    tmp_path: Path, text: str, error: type[Exception], words: str
) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(error, match=words):
        load_ring(path)


def test_missing_ring_file_names_the_presets(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="pioneer16"):
        load_ring(tmp_path / "nope.yaml")
