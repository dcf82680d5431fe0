"""Hostile grid files (.npz, ROS YAML + PGM/PNG): clear errors, nothing allocated first."""

from __future__ import annotations

import io
import os
import struct
import threading
import zipfile
import zlib

import numpy as np
import pytest

from bayesmap.errors import ConfigError, FormatError
from bayesmap.grid.occupancy import OccupancyGrid
from bayesmap.grid.ros import read_ros_map, write_ros_map
from bayesmap.limits import ReadLimits


def _saved_grid(tmp_path, **override) -> bytes:
    arrays = {
        "probability": np.full((3, 4), 0.5),
        "entropy": np.ones((3, 4)),
        "resolution": np.float64(0.5),
        "origin": np.zeros(2),
        "prior": np.float64(0.5),
    }
    arrays.update(override)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def _npy(header_shape: tuple[int, ...], payload: bytes, descr: str = "<f8") -> bytes:
    header = repr({"descr": descr, "fortran_order": False, "shape": header_shape})
    header = header.ljust(118) + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + payload


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ({"origin": np.array([np.nan, 0.0])}, "origin"),
        ({"origin": np.array([0.0, np.inf])}, "origin"),
        ({"resolution": np.float64(np.nan)}, "resolution"),
        ({"resolution": np.float64(-1.0)}, "resolution"),
        ({"prior": np.float64(np.nan)}, "prior"),
        ({"probability": np.full((3, 4), np.nan)}, "no NaN"),
        ({"probability": np.array(["a"] * 12).reshape(3, 4)}, "not numbers"),
    ],
    ids=[
        "nan-origin",
        "inf-origin",
        "nan-res",
        "negative-res",
        "nan-prior",
        "nan-cells",
        "strings",
    ],
)
def test_npz_values_that_cannot_be_a_grid_are_refused(tmp_path, override, message) -> None:
    path = tmp_path / "g.npz"
    path.write_bytes(_saved_grid(tmp_path, **override))
    with pytest.raises(FormatError, match=message) as caught:
        OccupancyGrid.load_npz(path)
    assert caught.value.path == str(path)


def test_an_npz_header_claiming_a_huge_array_is_refused_before_reading(tmp_path) -> None:
    buffer = io.BytesIO(_saved_grid(tmp_path))
    out = io.BytesIO()
    with zipfile.ZipFile(buffer) as source, zipfile.ZipFile(out, "w") as target:
        for info in source.infolist():
            data = source.read(info)
            if info.filename == "probability.npy":
                data = _npy((100_000, 100_000), b"\0" * 64)
            target.writestr(info.filename, data)
    path = tmp_path / "huge.npz"
    path.write_bytes(out.getvalue())
    with pytest.raises(FormatError, match="array 'probability'.*max_cells"):
        OccupancyGrid.load_npz(path)


def test_an_npz_with_an_unknown_compression_method_is_a_format_error(tmp_path) -> None:
    data = bytearray(_saved_grid(tmp_path))
    # Set the compression method of every local and central header to 99 (unknown).
    for signature, offset in ((b"PK\x03\x04", 8), (b"PK\x01\x02", 10)):
        start = 0
        while (start := data.find(signature, start)) >= 0:
            data[start + offset : start + offset + 2] = struct.pack("<H", 99)
            start += 4
    path = tmp_path / "method.npz"
    path.write_bytes(bytes(data))
    with pytest.raises(FormatError, match="cannot read .npz"):
        OccupancyGrid.load_npz(path)


def test_npz_limits_are_configurable(tmp_path) -> None:
    path = tmp_path / "g.npz"
    path.write_bytes(_saved_grid(tmp_path))
    with pytest.raises(FormatError, match="max_cells"):
        OccupancyGrid.load_npz(path, limits=ReadLimits(max_cells=11))
    assert OccupancyGrid.load_npz(path, limits=ReadLimits(max_cells=12)).shape == (3, 4)


@pytest.mark.parametrize(
    ("width", "height", "resolution"),
    [(10.0, 10.0, 1e-5), (1e300, 1e300, 1e-300), (2e6, 1.0, 1e-2)],
)
def test_a_grid_past_the_cell_limit_is_a_config_error(width, height, resolution) -> None:
    with pytest.raises(ConfigError, match="max_cells"):
        OccupancyGrid(width, height, resolution)


def _map_files(tmp_path, image_bytes: bytes, **yaml_fields: str):
    write_ros_map(tmp_path / "map", np.full((2, 3), 0.5), 0.1)
    image = tmp_path / "map.pgm"
    image.write_bytes(image_bytes)
    yaml = tmp_path / "map.yaml"
    text = yaml.read_text()
    for key, value in yaml_fields.items():
        text += f"{key}: {value}\n"
    yaml.write_text(text)
    return yaml


def _png(width: int, height: int) -> bytes:
    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(b"\0" * 16))
        + chunk(b"IEND", b"")
    )


@pytest.mark.parametrize(
    "image",
    [b"P5\n100000 100000\n255\n" + b"\0" * 100, _png(60_000, 60_000), _png(20_000, 20_000)],
    ids=["pgm-huge", "png-bomb", "png-large"],
)
def test_map_images_claiming_huge_sizes_are_refused(tmp_path, image: bytes) -> None:
    yaml = _map_files(tmp_path, image)
    with pytest.raises(FormatError, match="max_cells|too large") as caught:
        read_ros_map(yaml)
    assert caught.value.path == str(tmp_path / "map.pgm")


@pytest.mark.parametrize(
    "image", [b"", b"P5\n3 2\n255\n\0", b"\x89PNG\r\n\x1a\n" + b"\0" * 40, b"GIF89a\xff\xff"]
)
def test_corrupt_map_images_are_format_errors(tmp_path, image: bytes) -> None:
    with pytest.raises(FormatError, match="image"):
        read_ros_map(_map_files(tmp_path, image))


def test_map_images_must_be_regular_files(tmp_path) -> None:
    yaml = _map_files(tmp_path, b"")
    yaml.write_text(yaml.read_text().replace("image: map.pgm", "image: /dev/zero"))
    with pytest.raises(FormatError, match="regular file"):
        read_ros_map(yaml)
    fifo = tmp_path / "fifo.pgm"
    os.mkfifo(fifo)
    yaml.write_text(yaml.read_text().replace("image: /dev/zero", "image: fifo.pgm"))
    outcome: list[BaseException] = []

    def read() -> None:
        try:
            read_ros_map(yaml)
        except BaseException as error:  # noqa: BLE001 - handed to the test thread
            outcome.append(error)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(10)
    assert not reader.is_alive(), "reading a FIFO map image blocked"
    assert isinstance(outcome[0], FormatError) and "regular file" in str(outcome[0])


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"mode": "fancy"}, "mode must be one of"),
        ({"mode": "[x]"}, "mode must be one of"),
        ({"free_thresh": "0.9"}, "free_thresh < occupied_thresh"),
        ({"occupied_thresh": "1.5"}, "occupied_thresh <= 1"),
        ({"free_thresh": "-0.1"}, "0 <= free_thresh"),
    ],
)
def test_ros_mode_and_thresholds_are_checked(tmp_path, fields, message) -> None:
    yaml = _map_files(tmp_path, b"P5\n3 2\n255\n" + bytes(6), **fields)
    with pytest.raises(FormatError, match=message):
        read_ros_map(yaml)
