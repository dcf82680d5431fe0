"""Tests of bayesmap.grid.ros: ROS map_server YAML + PGM, written and read as ROS does."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from bayesmap.errors import FormatError
from bayesmap.grid import OccupancyGrid
from bayesmap.grid.ros import (
    classify,
    read_ros_map,
    read_ros_metadata,
    saved_classes,
    write_ros_map,
)


def test_files_are_written_as_map_saver_writes_them(tmp_path: Path) -> None:
    p = np.array([[0.0, 0.25, 0.26, 0.64], [0.65, 1.0, 0.5, 0.1]])  # row 0 is the bottom row
    yaml_path, pgm_path = write_ros_map(tmp_path / "map", p, 0.5, (-1.0, 2.0))
    assert yaml_path.name == "map.yaml" and pgm_path.name == "map.pgm"
    assert yaml_path.read_text() == (
        "image: map.pgm\nresolution: 0.500000\norigin: [-1.000000, 2.000000, 0.000000]\n"
        "mode: trinary\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n\n"
    )
    data = pgm_path.read_bytes()
    header = b"P5\n# CREATOR: Map_generator.cpp 0.500 m/pix\n4 2\n255\n"
    assert data.startswith(header)
    image = np.frombuffer(data[len(header) :], dtype=np.uint8).reshape(2, 4)
    # image row 0 is the top of the map: map row 1
    assert image.tolist() == [[0, 0, 205, 254], [254, 254, 205, 205]]


def test_unknown_reloads_as_unknown_and_round_trip_gives_same_cells(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    p = rng.uniform(size=(13, 17))
    unknown = rng.uniform(size=p.shape) < 0.3
    yaml_path, _ = write_ros_map(tmp_path / "m", p, 0.25, (3.0, 4.0), unknown_mask=unknown)
    loaded = read_ros_map(yaml_path)
    assert loaded.resolution == 0.25 and loaded.origin == (3.0, 4.0)
    assert loaded.probability.shape == p.shape
    meta = read_ros_metadata(yaml_path)
    cells = classify(loaded.probability, meta.occupied_thresh, meta.free_thresh)
    np.testing.assert_array_equal(cells, saved_classes(p, unknown_mask=unknown))
    assert np.all(cells[unknown] == -1)
    # pixel 205 gives p = 50/255 = 0.19608, just above free_thresh 0.196
    assert loaded.probability[unknown][0] == pytest.approx(50 / 255)


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    arrays(np.float64, st.tuples(st.integers(1, 9), st.integers(1, 9)), elements=st.floats(0, 1))
)
def test_round_trip_property(tmp_path: Path, p: np.ndarray) -> None:
    yaml_path, _ = write_ros_map(tmp_path / "prop", p, 0.5)
    loaded = read_ros_map(yaml_path)
    np.testing.assert_array_equal(classify(loaded.probability), saved_classes(p))
    # re-saving a loaded map, its unknown cells marked unknown, is a fixed point
    unknown = classify(loaded.probability) == -1
    yaml2, _ = write_ros_map(tmp_path / "prop2", loaded.probability, 0.5, unknown_mask=unknown)
    np.testing.assert_array_equal(read_ros_map(yaml2).probability, loaded.probability)


def test_grid_cell_zero_is_bottom_left_pixel(tmp_path: Path) -> None:
    grid = OccupancyGrid(3.0, 2.0, 1.0, prior=0.0)
    grid.probability[0, 0] = 1.0
    yaml_path, pgm_path = write_ros_map(
        tmp_path / "g", grid.probability, grid.resolution, grid.origin
    )
    raw = pgm_path.read_bytes()
    image = np.frombuffer(raw[-6:], dtype=np.uint8).reshape(2, 3)
    assert image[1, 0] == 0 and image[0, 0] == 254
    assert read_ros_map(yaml_path).probability[0, 0] == 1.0


def test_negate_and_comments(tmp_path: Path) -> None:
    write_ros_map(tmp_path / "n", np.array([[1.0, 0.0]]), 1.0)
    (tmp_path / "n.yaml").write_text(
        "# a comment\nimage: 'n.pgm'\nresolution: 1.0\norigin: [0.0, 0.0, 0.0]\nnegate: 1\n"
    )
    loaded = read_ros_map(tmp_path / "n.yaml")
    np.testing.assert_allclose(loaded.probability, [[0.0, 254 / 255]])


@pytest.mark.parametrize(
    "yaml_text",
    [
        "resolution: 0.5\norigin: [0, 0, 0]\n",
        "image: x.pgm\nresolution: abc\norigin: [0, 0, 0]\n",
        "image: x.pgm\nresolution: 0.5\norigin: [0, 0]\n",
        "image: x.pgm\nresolution: -1\norigin: [0, 0, 0]\n",
        "image: missing.pgm\nresolution: 0.5\norigin: [0, 0, 0]\n",
        "just text without colon\n",
        "image: x.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nmode: fancy\n",
        "image: x.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nnegate: 2\n",
        "image: x.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nfree_thresh: 0.7\n",
        "image: x.pgm\nresolution: 0.5\norigin: [0, 0, .nan]\n",
        "image: x.pgm\nresolution: [0.5\n",
    ],
)
def test_bad_yaml_raises_format_error(tmp_path: Path, yaml_text: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(yaml_text)
    with pytest.raises(FormatError):
        read_ros_map(path)


@settings(
    max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.binary(max_size=200), st.text(max_size=120))
@example(image=b"P5\n2 2\n255\n" + bytes([0, 254, 205, 0]), yaml_text="")  # one that loads
def test_fuzzed_files_raise_only_format_error(tmp_path: Path, image: bytes, yaml_text: str) -> None:
    (tmp_path / "f.pgm").write_bytes(image)
    for text in (yaml_text, "image: f.pgm\nresolution: 0.5\norigin: [0, 0, 0]\n" + yaml_text):
        (tmp_path / "f.yaml").write_text(text)
        try:
            loaded = read_ros_map(tmp_path / "f.yaml")
        except FormatError:
            continue
        assert loaded.probability.ndim == 2
        assert np.all((loaded.probability >= 0) & (loaded.probability <= 1))


def test_uncertain_cells_are_written_unknown(tmp_path: Path) -> None:
    """A cell is free or occupied in the file only when its entropy is below 0.3 bits."""
    p = np.array([[0.2, 0.2, 0.97, 0.97]])
    entropy = np.array([[1.0, 0.1, 0.9, 0.15]])  # never seen, seen free, doubtful, certain
    yaml_path, _ = write_ros_map(tmp_path / "m", p, 0.5, entropy=entropy)
    assert read_ros_map(yaml_path).occupancy.tolist() == [[-1, 0, -1, 100]]


def test_modes_negate_and_yaw_follow_map_server(tmp_path: Path) -> None:
    pgm = b"P5\n4 1\n255\n" + bytes([0, 100, 180, 254])
    (tmp_path / "m.pgm").write_bytes(pgm)
    head = "image: m.pgm\nresolution: 0.1\norigin: [1.0, 2.0, 0.5]\n"
    expected = {
        "mode: trinary\n": [100, -1, -1, 0],
        "mode: scale\n": [100, 90, 21, 0],  # p = 155/255, 75/255 -> 99 (p - 0.196) / 0.454
        "mode: raw\n": [0, 100, 180, 254],
        "mode: raw\nnegate: 1\n": [255, 155, 75, 1],
        "mode: trinary\nnegate: 1\n": [0, -1, 100, 100],
    }
    for extra, values in expected.items():
        (tmp_path / "m.yaml").write_text(head + extra)
        loaded = read_ros_map(tmp_path / "m.yaml")
        assert loaded.occupancy.tolist() == [values], extra
        assert loaded.yaw == 0.5 and loaded.origin == (1.0, 2.0)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("resolution", "1_0"),
        ("resolution", "0x1"),
        ("resolution", ".inf"),
        ("resolution", "1:30"),
        ("occupied_thresh", "\u0660.\u0666"),
        ("origin", "[1_0, 0, 0]"),
    ],
)
def test_yaml_numbers_are_plain_decimals(tmp_path: Path, field: str, value: str) -> None:
    """YAML 1.1 reads ``1_0`` as 10, ``0x1`` as 1 and ``1:30`` as 90; a map file holds plain
    decimals, so these are refused by name instead of read as some other number."""
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 1\n255\n" + bytes([0, 254]))
    fields = {"image": "m.pgm", "resolution": "0.1", "origin": "[0.0, 0.0, 0.0]"}
    fields[field] = value
    (tmp_path / "m.yaml").write_text("".join(f"{k}: {v}\n" for k, v in fields.items()))
    with pytest.raises(FormatError, match=field):
        read_ros_map(tmp_path / "m.yaml")
    fields[field] = {"origin": "[1, 0, 0]", "occupied_thresh": "0.65"}.get(field, "1e-1")
    (tmp_path / "m.yaml").write_text("".join(f"{k}: {v}\n" for k, v in fields.items()))
    assert read_ros_map(tmp_path / "m.yaml").occupancy.shape == (1, 2)
