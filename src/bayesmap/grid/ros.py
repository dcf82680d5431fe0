"""ROS map_server maps: YAML + PGM, written and read the way ROS tools do.

Writing follows ROS 1 ``map_saver`` in trinary mode: a cell whose occupancy is at most
``save_free`` is free (pixel 254), one at least ``save_occupied`` is occupied (pixel 0),
anything else, and every cell of ``unknown_mask``, is unknown (pixel 205). The YAML carries
``occupied_thresh: 0.65`` and ``free_thresh: 0.196`` so that map_server reloads pixel 205
(p = 50/255 = 0.19608) as unknown, not free. ``origin`` is the lower-left corner of cell
(0, 0) and image row 0 is the *top* of the map, so rows are flipped on the way out and in.

Reading follows ``map_server``'s ``image_loader``: ``p = (255 - x) / 255`` (or ``x / 255``
with ``negate: 1``), ``x`` the mean of the colour channels; :func:`classify` applies its
trinary thresholds (``p > occupied_thresh`` → 100, ``p < free_thresh`` → 0, else −1).
"""

from __future__ import annotations

import io
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from PIL import Image, UnidentifiedImageError

from bayesmap._io import read_input, write_bytes, write_text
from bayesmap._typing import FloatArray
from bayesmap.errors import FormatError, InputError
from bayesmap.limits import DEFAULT_LIMITS, ReadLimits, check_size

FREE_PIXEL = 254
OCCUPIED_PIXEL = 0
UNKNOWN_PIXEL = 205
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196
SAVE_FREE = 0.25
SAVE_OCCUPIED = 0.65
MODES = ("trinary", "scale", "raw")
"""map_server's interpretations of a map image."""


class RosMap(NamedTuple):
    """A map read from ROS files: probability ``(ny, nx)``, resolution [m], origin (x, y) [m]."""

    probability: FloatArray
    resolution: float
    origin: tuple[float, float]


@dataclass(frozen=True)
class RosMapMetadata:
    """The fields of a map_server YAML file."""

    image: Path
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str


def write_ros_map(
    stem: str | Path,
    probability: npt.ArrayLike,
    resolution: float,
    origin: tuple[float, float] = (0.0, 0.0),
    *,
    unknown_mask: npt.ArrayLike | None = None,
    save_free: float = SAVE_FREE,
    save_occupied: float = SAVE_OCCUPIED,
) -> tuple[Path, Path]:
    """Write ``stem.yaml`` and ``stem.pgm`` as ROS 1 ``map_saver`` writes them (trinary).

    Parameters
    ----------
    stem
        Path without extension; the YAML names the PGM by its file name (relative path).
    probability
        ``(ny, nx)`` occupancy probabilities, row 0 at the bottom (lowest y).
    resolution
        Cell side [m].
    origin
        World ``(x, y)`` [m] of the lower-left corner of cell (0, 0); yaw is written as 0.
    unknown_mask
        ``(ny, nx)`` booleans: cells to write as unknown whatever their probability.
    save_free, save_occupied
        ``map_saver``'s ``--free 25 --occ 65`` thresholds, as probabilities.

    Returns
    -------
    (yaml_path, pgm_path)
    """
    pixels = ros_pixels(
        probability, unknown_mask=unknown_mask, save_free=save_free, save_occupied=save_occupied
    )
    if not (math.isfinite(resolution) and resolution > 0):
        raise InputError(f"map resolution must be a positive number of metres, got {resolution!r}")
    stem_path = Path(stem)
    pgm_path = stem_path.with_name(stem_path.name + ".pgm")
    yaml_path = stem_path.with_name(stem_path.name + ".yaml")
    height, width = pixels.shape
    header = f"P5\n# CREATOR: Map_generator.cpp {resolution:.3f} m/pix\n{width} {height}\n255\n"
    write_bytes(pgm_path, header.encode("ascii") + np.ascontiguousarray(pixels[::-1]).tobytes())
    write_text(
        yaml_path,
        f"image: {pgm_path.name}\n"
        f"resolution: {resolution:f}\n"
        f"origin: [{float(origin[0]):f}, {float(origin[1]):f}, {0.0:f}]\n"
        "negate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH}\n"
        f"free_thresh: {FREE_THRESH}\n\n",
    )
    return yaml_path, pgm_path


def ros_pixels(
    probability: npt.ArrayLike,
    *,
    unknown_mask: npt.ArrayLike | None = None,
    save_free: float = SAVE_FREE,
    save_occupied: float = SAVE_OCCUPIED,
) -> npt.NDArray[np.uint8]:
    """Trinary ``map_saver`` pixel values ``(ny, nx)`` (row 0 at the bottom, not yet flipped)."""
    p = np.asarray(probability, dtype=np.float64)
    if p.ndim != 2 or p.size == 0:
        raise InputError(f"a ROS map needs a non-empty 2-D probability array, got shape {p.shape}")
    if not np.all((p >= 0.0) & (p <= 1.0)):
        raise InputError("a ROS map's probabilities must lie in [0, 1] (no NaN)")
    if not 0.0 <= save_free < save_occupied <= 1.0:
        raise InputError(
            f"need 0 <= save_free < save_occupied <= 1, got {save_free}, {save_occupied}"
        )
    # map_saver works on integer occupancy 0..100; round the same way.
    occupancy = np.rint(p * 100.0)
    pixels = np.full(p.shape, UNKNOWN_PIXEL, dtype=np.uint8)
    pixels[occupancy <= round(save_free * 100)] = FREE_PIXEL
    pixels[occupancy >= round(save_occupied * 100)] = OCCUPIED_PIXEL
    if unknown_mask is not None:
        mask = np.asarray(unknown_mask, dtype=bool)
        if mask.shape != p.shape:
            raise InputError(f"unknown_mask has shape {mask.shape}, the map {p.shape}")
        pixels[mask] = UNKNOWN_PIXEL
    return pixels


def classify(
    probability: npt.ArrayLike,
    occupied_thresh: float = OCCUPIED_THRESH,
    free_thresh: float = FREE_THRESH,
) -> npt.NDArray[np.int8]:
    """map_server's trinary rule: p > occupied_thresh → 100, p < free_thresh → 0, else -1."""
    p = np.asarray(probability, dtype=np.float64)
    cells = np.full(p.shape, -1, dtype=np.int8)
    cells[p > occupied_thresh] = 100
    cells[p < free_thresh] = 0
    return cells


def saved_classes(
    probability: npt.ArrayLike,
    *,
    unknown_mask: npt.ArrayLike | None = None,
    save_free: float = SAVE_FREE,
    save_occupied: float = SAVE_OCCUPIED,
) -> npt.NDArray[np.int8]:
    """The {−1, 0, 100} cells that :func:`write_ros_map` stores for ``probability``."""
    pixels = ros_pixels(
        probability, unknown_mask=unknown_mask, save_free=save_free, save_occupied=save_occupied
    )
    cells = np.full(pixels.shape, -1, dtype=np.int8)
    cells[pixels == FREE_PIXEL] = 0
    cells[pixels == OCCUPIED_PIXEL] = 100
    return cells


def read_ros_metadata(yaml_path: str | Path, *, limits: ReadLimits | None = None) -> RosMapMetadata:
    """Parse a map_server YAML file (the flat ``key: value`` subset ROS writes).

    ``mode`` must be one of :data:`MODES` and ``0 <= free_thresh < occupied_thresh <= 1``.
    """
    path = Path(yaml_path)
    text = _yaml_text(path, limits or DEFAULT_LIMITS)
    fields: dict[str, tuple[str, int]] = {}
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        key, sep, value = line.partition(":")
        if not sep or not key.strip():
            raise FormatError(f"expected 'key: value', got {raw.strip()!r}", path=path, line=lineno)
        fields[key.strip()] = (value.strip().strip("'\""), lineno)
    for key in ("image", "resolution", "origin"):
        if key not in fields:
            raise FormatError(f"map YAML lacks the required field {key!r}", path=path, element=key)

    def number(key: str, default: float | None = None) -> float:
        if key not in fields:
            assert default is not None
            return default
        value, line = fields[key]
        try:
            result = float(value)
        except ValueError:
            raise FormatError(
                f"{key} must be a number, got {value!r}", path=path, line=line, element=key
            ) from None
        if not math.isfinite(result):
            raise FormatError(
                f"{key} must be finite, got {value!r}", path=path, line=line, element=key
            )
        return result

    origin_text, origin_line = fields["origin"]
    match = re.fullmatch(r"\[(.*)\]", origin_text)
    parts = [part.strip() for part in match.group(1).split(",")] if match else []
    try:
        origin = tuple(float(part) for part in parts)
    except ValueError:
        origin = ()
    if len(origin) != 3 or not all(math.isfinite(v) for v in origin):
        raise FormatError(
            f"origin must be [x, y, yaw], got {origin_text!r}",
            path=path,
            line=origin_line,
            element="origin",
        )
    resolution = number("resolution")
    if resolution <= 0:
        raise FormatError(
            f"resolution must be positive, got {resolution}",
            path=path,
            line=fields["resolution"][1],
            element="resolution",
        )
    negate_text = fields.get("negate", ("0", 0))[0].lower()
    if negate_text not in ("0", "1", "true", "false"):
        raise FormatError(
            f"negate must be 0 or 1, got {negate_text!r}",
            path=path,
            line=fields["negate"][1],
            element="negate",
        )
    image = Path(fields["image"][0])
    occupied_thresh = number("occupied_thresh", OCCUPIED_THRESH)
    free_thresh = number("free_thresh", FREE_THRESH)
    _check_thresholds(free_thresh, occupied_thresh, path)
    mode, mode_line = fields.get("mode", ("trinary", 0))
    _check_mode(mode, path, mode_line)
    return RosMapMetadata(
        image=image if image.is_absolute() else path.parent / image,
        resolution=resolution,
        origin=(origin[0], origin[1], origin[2]),
        negate=negate_text in ("1", "true"),
        occupied_thresh=occupied_thresh,
        free_thresh=free_thresh,
        mode=mode,
    )


def _yaml_text(path: Path, limits: ReadLimits) -> str:
    """The text of a map YAML: a regular file, at most ``limits.max_bytes``, UTF-8."""
    data = read_input(path, max_bytes=limits.max_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise FormatError(f"map YAML is not UTF-8 text ({error})", path=path) from None


def _check_thresholds(free_thresh: float, occupied_thresh: float, path: Path) -> None:
    """map_server's thresholds are probabilities with ``free_thresh < occupied_thresh``."""
    if not 0.0 <= free_thresh < occupied_thresh <= 1.0:
        raise FormatError(
            f"need 0 <= free_thresh < occupied_thresh <= 1, got free_thresh {free_thresh} "
            f"and occupied_thresh {occupied_thresh}",
            path=path,
            element="free_thresh/occupied_thresh",
        )


def _check_mode(mode: str, path: Path, line: int) -> None:
    """``mode`` is one of map_server's: trinary, scale or raw."""
    if mode not in MODES:
        raise FormatError(
            f"mode must be one of {', '.join(MODES)}, got {mode!r}",
            path=path,
            line=line or None,
            element="mode",
        )


def read_ros_map(yaml_path: str | Path, *, limits: ReadLimits | None = None) -> RosMap:
    """Read a map_server map: ``p = (255 - x) / 255`` per pixel, rows flipped to y-up.

    ``limits`` (:class:`~bayesmap.limits.ReadLimits`) caps the bytes of both files and the
    pixels of the image, checked from the image header before it is decoded (Pillow's
    own decompression-bomb cap, about 179 million pixels, also applies).

    Returns
    -------
    RosMap
        ``(probability, resolution, origin)`` with ``probability[0]`` the bottom row.

    Raises
    ------
    FormatError
        Unreadable, non-regular or malformed YAML or image, or one past a limit.
    """
    limits = limits or DEFAULT_LIMITS
    meta = read_ros_metadata(yaml_path, limits=limits)
    pixels = _image_grey_levels(meta.image, limits)
    if pixels.ndim != 2 or pixels.size == 0:
        raise FormatError(
            f"map image must be a non-empty 2-D image, got {pixels.shape}", path=meta.image
        )
    p = pixels / 255.0 if meta.negate else (255.0 - pixels) / 255.0
    return RosMap(np.ascontiguousarray(p[::-1]), meta.resolution, (meta.origin[0], meta.origin[1]))


def _image_grey_levels(path: Path, limits: ReadLimits) -> FloatArray:
    """Grey levels of the image file ``path``, its pixel count checked before decoding."""
    data = read_input(path, max_bytes=limits.max_bytes)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(io.BytesIO(data)) as image:
                width, height = image.size
                check_size(
                    "pixels in the map image",
                    width * height,
                    limits.max_cells,
                    "max_cells",
                    path=str(path),
                )
                image.load()
                return _grey_levels(image)
    except FormatError:
        raise
    except Image.DecompressionBombError as error:
        raise FormatError(f"map image too large to decode safely ({error})", path=path) from None
    except UnidentifiedImageError as error:
        raise FormatError(f"not an image Pillow can read ({error})", path=path) from None
    except Exception as error:  # noqa: BLE001 - Pillow's decoders raise many types on corrupt data
        raise FormatError(
            f"cannot decode map image ({type(error).__name__}: {error})", path=path
        ) from None


def _grey_levels(image: Image.Image) -> FloatArray:
    """Pixel values 0..255 as floats: the mean of the colour channels (alpha ignored)."""
    if image.mode in ("1", "L", "P"):
        return np.asarray(image.convert("L"), dtype=np.float64)
    if image.mode in ("I", "I;16", "I;16B", "F"):
        raw = np.asarray(image, dtype=np.float64)
        return raw * (255.0 / 65535.0) if raw.max(initial=0) > 255 else raw
    rgb = np.asarray(image.convert("RGB"), dtype=np.float64)
    return np.asarray(rgb.mean(axis=2))
