"""World files (JSON Schema) and the stress-world generator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bayesmap.errors import FormatError
from bayesmap.sim.rover_worlds import generate_world, load_world, save_world
from bayesmap.sim.world2d import box_distance

ISSUE_EXAMPLE = {
    "size": [20.0, 20.0],
    "resolution": 0.5,
    "obstacles": [[[14.0, 16.0], [15.0, 16.0], [15.0, 17.0], [14.0, 17.0]]],
    "start": [1.0, 1.0, 0.0],
}


def test_the_issue_example_loads(tmp_path: Path) -> None:
    path = tmp_path / "w.json"
    path.write_text(json.dumps(ISSUE_EXAMPLE))
    spec = load_world(path)
    np.testing.assert_array_equal(spec.world.boxes, [[14.0, 16.0, 15.0, 17.0]])
    assert spec.start == (1.0, 1.0, 0.0) and spec.resolution == 0.5
    assert spec.world.name == "w"


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"size": [20.0]}, "size"),
        ({"start": [1.0, 1.0]}, "start"),
        ({"obstacles": [[[0, 0], [1, 0], [0.5, 1]]]}, "obstacles/0"),
        ({"obstacles": [[[0, 0], [1, 0.2], [1, 1], [0, 1]]]}, "obstacles/0"),
        ({"start": [14.5, 16.5, 0.0]}, "start"),
        ({"start": [30.0, 1.0, 0.0]}, "outside"),
        ({"colour": "red"}, "colour"),
    ],
)
def test_bad_worlds_name_the_field(tmp_path: Path, change: dict, words: str) -> None:  # type: ignore[type-arg]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({**ISSUE_EXAMPLE, **change}))
    with pytest.raises(FormatError, match=words):
        load_world(path)


def test_broken_json_reports_the_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.json"
    path.write_text('{\n "size": [20, 20],\n "start": [1, 1 0]\n}')
    with pytest.raises(FormatError, match="line 3"):
        load_world(path)


@pytest.mark.parametrize("seed", range(8))
def test_generated_worlds_keep_passages_and_round_trip(tmp_path: Path, seed: int) -> None:
    spec = generate_world(seed)
    side = spec.world.width
    boxes = spec.world.boxes
    assert 20.0 <= side <= 60.0 and len(boxes) >= 3
    assert (boxes[:, :2] >= 1.2 - 1e-9).all() and (boxes[:, 2:] <= side - 1.2 + 1e-9).all()
    assert box_distance(boxes, *spec.start[:2]) >= 1.7
    back = load_world(save_world(tmp_path / "w.json", spec))
    np.testing.assert_allclose(back.world.boxes, np.round(boxes, 4))
    assert back.world.name == spec.world.name


def test_generator_is_reproducible() -> None:
    a, b = generate_world(3, size=25.0), generate_world(3, size=25.0)
    np.testing.assert_array_equal(a.world.boxes, b.world.boxes)
    assert a.world.width == 25.0
