"""Tests of ring files and presets: offsets, units, overrides, and clear errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from bayesmap.errors import BayesmapError, ConfigError, FormatError, InputError
from bayesmap.sonar.bottom_up import neighbour_bounds
from bayesmap.sonar.ring import load_ring, preset, preset_with_bearings, ring_from_mapping


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


TWO = "transducers:\n  - {x: 0, y: 0, heading: 0}\n  - {x: 0, y: 0, heading: 90}"
"""A minimal list of transducers, for files whose other keys are under test."""


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
        (f"max_rnage: 3\n{TWO}", FormatError, "bad.yaml: unknown key.s. max_rnage"),
        (f"beam_width: -25\n{TWO}", FormatError, "bad.yaml: beam_width -25 deg must lie"),
        (
            f"length_unit: mm\nmin_range: 6000\nmax_range: 5000\n{TWO}",
            FormatError,
            "min_range 6000 mm and max_range 5000 mm",
        ),
        (f"max_range: 5000\n{TWO}", FormatError, "max_range 5000 m .* is length_unit right"),
        (f"max_range: 0.05\nmin_range: 0.01\n{TWO}", FormatError, "0.05 m, shorter than any sonar"),
        (f"sigma: 0\n{TWO}", FormatError, "sigma must be above 0, got sigma 0 m"),
        (
            "transducers:\n  - {x: 1.0e9, y: 0, heading: 0}\n  - {x: 0, y: 0, heading: 1}",
            FormatError,
            "a transducer sits 1e.09 m from the centre",
        ),
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
    with pytest.raises(InputError, match="pioneer16") as info:
        load_ring(tmp_path / "nope.yaml")
    assert "did you mean" not in str(info.value)
    with pytest.raises(InputError, match="did you mean the preset 'pioneer16'"):
        load_ring("pionner16")


values = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-10, 10),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
)
transducer = st.dictionaries(
    st.sampled_from(["x", "y", "heading", "sigma", "beam_width", "max_range", "colour"]), values
)
ring_doc = st.dictionaries(
    st.sampled_from(
        ["transducers", "length_unit", "angle_unit", "sigma", "max_range", "min_range"]
    ),
    st.one_of(values, st.lists(st.one_of(transducer, values), max_size=5)),
)


@settings(max_examples=150, deadline=None)
@given(data=st.one_of(ring_doc, values, st.lists(values, max_size=3)))
@example(data={"transducers": [{"x": 0, "y": 0, "heading": 0}, {"x": 0, "y": 0, "heading": 1}]})
def test_fuzzed_ring_documents_fail_only_with_bayesmap_errors(data: object) -> None:
    try:
        ring = ring_from_mapping(data, "fuzz")
    except BayesmapError:
        return
    assert ring.n >= 2 and ring.offsets is not None


def test_a_presets_bearings_are_recognised_in_order_and_nothing_else() -> None:
    for name in ("pioneer8", "pioneer16"):
        angles = tuple(preset(name).angles)
        assert preset_with_bearings(angles) == name
        assert preset_with_bearings(tuple(a + 0.01 for a in angles)) == name
        assert preset_with_bearings(tuple(a + 2 * math.pi for a in angles)) == name
        assert preset_with_bearings(angles[::-1]) is None  # another order
        assert preset_with_bearings(tuple(a + 0.05 for a in angles)) is None
    assert preset_with_bearings(tuple(math.radians(22.5 * k) for k in range(16))) is None
