"""ROS map_server maps: YAML + PGM, written and read the way ROS tools do.

Writing follows ROS 1 ``map_saver`` in trinary mode: a cell whose occupancy is at most
``save_free`` is free (pixel 254), one at least ``save_occupied`` is occupied (pixel 0),
anything else, and every cell of ``unknown_mask``, is unknown (pixel 205). The YAML carries
``occupied_thresh: 0.65`` and ``free_thresh: 0.196`` so that map_server reloads pixel 205
(p = 50/255 = 0.19608) as unknown, not free. ``origin`` is the lower-left corner of cell
(0, 0) and image row 0 is the *top* of the map, so rows are flipped on the way out and in.

Written maps are honest about certainty: with ``entropy`` given, a cell is written free or
occupied only when its entropy is below ``certain_below`` (0.3 bits by default, i.e.
``p < 0.053`` or ``p > 0.947``), unknown otherwise; the YAML says ``mode: trinary``.

Reading follows ``map_server``'s ``image_loader``: the YAML is parsed with PyYAML's safe
loader; ``p = (255 - x) / 255`` (or ``x / 255`` with ``negate: 1``), ``x`` the mean of the
colour channels; :func:`occupancy_values` applies the YAML's ``mode``: ``trinary``
(``p > occupied_thresh`` → 100, ``p < free_thresh`` → 0, else −1, as :func:`classify`),
``scale`` (between the thresholds, ``99 (p - free) / (occupied - free)``) or ``raw`` (the
pixel value, after ``negate``). The origin's yaw is returned with the map.
"""

from __future__ import annotations

import io
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt
import yaml

from bayesmap._io import read_input, write_bytes, write_text
from bayesmap._numbers import PlainNumberLoader
from bayesmap._typing import FloatArray
from bayesmap.errors import FormatError, InputError
from bayesmap.limits import DEFAULT_LIMITS, ReadLimits, check_size

if TYPE_CHECKING:
    from PIL import Image

FREE_PIXEL = 254
OCCUPIED_PIXEL = 0
UNKNOWN_PIXEL = 205
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196
SAVE_FREE = 0.25
SAVE_OCCUPIED = 0.65
CERTAIN_BELOW = 0.3
"""Entropy [bits] below which a written cell may be free or occupied (else unknown)."""
MODES = ("trinary", "scale", "raw")


class RosMap(NamedTuple):
    """A map read from ROS files.

    Attributes
    ----------
    probability
        ``(ny, nx)`` occupancy probability by map_server's rule, row 0 at the bottom.
    resolution
        Cell side [m].
    origin
        ``(x, y)`` [m] of the lower-left corner of cell (0, 0).
    yaw
        Rotation of the map about its origin [rad] (the third ``origin`` value).
    occupancy
        ``(ny, nx)`` int16 values map_server would publish for the YAML's ``mode``.
    """

    probability: FloatArray
    resolution: float
    origin: tuple[float, float]
    yaw: float = 0.0
    occupancy: npt.NDArray[np.int16] | None = None


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
    entropy: npt.ArrayLike | None = None,
    certain_below: float = CERTAIN_BELOW,
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
    entropy, certain_below
        ``(ny, nx)`` entropy [bits]: cells at or above ``certain_below`` are written unknown.
    save_free, save_occupied
        ``map_saver``'s ``--free 25 --occ 65`` thresholds, as probabilities.

    Returns
    -------
    (yaml_path, pgm_path)
    """
    if entropy is not None:
        uncertain = np.asarray(entropy, dtype=np.float64) >= certain_below
        unknown_mask = uncertain if unknown_mask is None else uncertain | np.asarray(unknown_mask)
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
        "mode: trinary\n"
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


def _yaml_fields(path: Path, limits: ReadLimits) -> dict[str, object]:
    """The YAML mapping of a map_server file (a regular file within ``limits``), parsed with
    PyYAML's safe loader."""
    data = read_input(path, max_bytes=limits.max_bytes)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise FormatError(f"map YAML is not UTF-8 text ({error})", path=path) from None
    try:
        fields = yaml.load(text, Loader=PlainNumberLoader)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = None if mark is None else mark.line + 1
        problem = getattr(error, "problem", None) or "invalid YAML"
        raise FormatError(f"not valid YAML: {problem}", path=path, line=line) from None
    if not isinstance(fields, dict):
        raise FormatError("map YAML must be a mapping of 'key: value' fields", path=path)
    for key in ("image", "resolution", "origin"):
        if key not in fields:
            raise FormatError(f"map YAML lacks the required field {key!r}", path=path, element=key)
    return fields


def _number(fields: dict[str, object], key: str, path: Path, default: float | None = None) -> float:
    value = fields.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise FormatError(f"{key} must be a finite number, got {value!r}", path=path, element=key)
    return float(value)


def read_ros_metadata(yaml_path: str | Path, *, limits: ReadLimits | None = None) -> RosMapMetadata:
    """Parse and check a map_server YAML file (PyYAML safe loader), within ``limits``."""
    path = Path(yaml_path)
    fields = _yaml_fields(path, limits or DEFAULT_LIMITS)
    origin = fields["origin"]
    if not (isinstance(origin, list) and len(origin) == 3):
        raise FormatError(
            f"origin must be [x, y, yaw], got {origin!r}", path=path, element="origin"
        )
    x, y, yaw = (_number({"origin": v}, "origin", path) for v in origin)
    resolution = _number(fields, "resolution", path)
    if resolution <= 0:
        raise FormatError(
            f"resolution must be positive, got {resolution}", path=path, element="resolution"
        )
    negate = fields.get("negate", 0)
    if negate not in (0, 1):  # True and False compare equal to 1 and 0
        raise FormatError(f"negate must be 0 or 1, got {negate!r}", path=path, element="negate")
    occupied = _number(fields, "occupied_thresh", path, OCCUPIED_THRESH)
    free = _number(fields, "free_thresh", path, FREE_THRESH)
    if not 0.0 <= free < occupied <= 1.0:
        raise FormatError(
            f"need 0 <= free_thresh < occupied_thresh <= 1, got {free} and {occupied}",
            path=path,
            element="free_thresh",
        )
    mode = fields.get("mode", "trinary")
    if mode not in MODES:
        raise FormatError(
            f"mode must be one of {', '.join(MODES)}, got {mode!r}", path=path, element="mode"
        )
    if not isinstance(fields["image"], str) or not fields["image"]:
        raise FormatError("image must name the map's image file", path=path, element="image")
    image = Path(fields["image"])
    return RosMapMetadata(
        image=image if image.is_absolute() else path.parent / image,
        resolution=resolution,
        origin=(x, y, yaw),
        negate=bool(negate),
        occupied_thresh=occupied,
        free_thresh=free,
        mode=str(mode),
    )


def occupancy_values(pixels: npt.ArrayLike, meta: RosMapMetadata) -> npt.NDArray[np.int16]:
    """The values map_server publishes for grey levels ``pixels`` (0..255) under ``meta.mode``."""
    x = np.asarray(pixels, dtype=np.float64)
    x = 255.0 - x if meta.negate else x
    if meta.mode == "raw":
        return np.asarray(np.rint(x), dtype=np.int16)
    p = (255.0 - x) / 255.0
    values = classify(p, meta.occupied_thresh, meta.free_thresh).astype(np.int16)
    if meta.mode == "scale":
        between = values == -1
        ratio = (p[between] - meta.free_thresh) / (meta.occupied_thresh - meta.free_thresh)
        values[between] = np.rint(99.0 * ratio).astype(np.int16)
    return values


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
    return RosMap(
        np.ascontiguousarray(p[::-1]),
        meta.resolution,
        (meta.origin[0], meta.origin[1]),
        meta.origin[2],
        np.ascontiguousarray(occupancy_values(pixels, meta)[::-1]),
    )


def _image_grey_levels(path: Path, limits: ReadLimits) -> FloatArray:
    """Grey levels of the image file ``path``, its pixel count checked before decoding."""
    from PIL import Image, UnidentifiedImageError  # Pillow loads only to read a map image

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
