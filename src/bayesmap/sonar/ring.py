"""Ring files: where each transducer sits, how wide its beam is, its range and noise (YAML).

A ring file describes a robot's sonar ring as the mapping code needs it::

    name: pioneer-3dx-16
    length_unit: m          # m, cm or mm, for every length in the file
    angle_unit: deg         # deg or rad
    beam_width: 25          # defaults for every transducer ...
    min_range: 0.1
    max_range: 5.0
    sigma: 0.02
    transducers:            # ... in ring order (neighbours are adjacent entries)
      - {x: 0.069, y: 0.136, heading: 90}
      - {x: 0.114, y: 0.119, heading: 50, beam_width: 25}   # per-transducer override
      ...

``x`` forward, ``y`` left, from the robot's centre; ``heading`` is the beam axis from the
robot's heading. Each transducer may override ``beam_width``, ``min_range``, ``max_range``
and ``sigma``; the mapping models take one value per ring, so overrides must agree (a ring
that mixes transducer types is refused with a message saying which value differs). Presets
``pioneer8`` and ``pioneer16`` (ARIA ``p3dx.p``) need no file.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from bayesmap._numbers import PlainNumberLoader
from bayesmap.errors import ConfigError, FormatError, InputError
from bayesmap.sensing.sonar_rings import PIONEER_FRONT8, PIONEER_RING16, Layout
from bayesmap.sonar.geometry import SonarGeometry

__all__ = [
    "PRESETS",
    "load_ring",
    "logged_ring",
    "preset",
    "preset_with_bearings",
    "ring_from_layout",
    "ring_from_mapping",
]

_LENGTH = {"m": 1.0, "cm": 0.01, "mm": 0.001}
_ANGLE = {"deg": math.pi / 180.0, "rad": 1.0}
_SHARED = ("beam_width", "min_range", "max_range", "sigma")
_DEFAULTS = {"beam_width": math.radians(25.0), "min_range": 0.1, "max_range": 5.0, "sigma": 0.02}

MAX_SONAR_REACH = 50.0
"""Longest max range and farthest transducer offset [m] a ring file may give: air sonars
read to about 10 m and sit on a robot's body, so a larger number is a length in cm or mm
given without its ``length_unit``."""
MIN_SONAR_REACH = 0.1
"""Shortest max range [m] a ring may have: air sonars read to 0.5 m at least, so a smaller
number is a length in m given as cm or mm."""


def reach_problem(max_range: float) -> str | None:
    """Why a ring's max range [m] cannot be a sonar's (a unit mistake), or ``None``."""
    if max_range > MAX_SONAR_REACH:
        return "beyond any sonar's reach"
    if max_range < MIN_SONAR_REACH:
        return "shorter than any sonar's reach"
    return None


_TOP_KEYS = {"name", "length_unit", "angle_unit", "transducers", *_SHARED}

PRESETS: dict[str, Layout] = {"pioneer8": PIONEER_FRONT8, "pioneer16": PIONEER_RING16}
"""Rings known by name: the Pioneer 3-DX front array and full ring."""


def preset(name: str) -> SonarGeometry:
    """The preset ring ``name`` (``pioneer8``, ``pioneer16``): 25° beams, 0.1–5 m, σ 2 cm."""
    if name not in PRESETS:
        raise ConfigError(f"unknown ring preset {name!r}; choose from: {', '.join(PRESETS)}")
    return ring_from_layout(PRESETS[name])


def preset_with_bearings(angles: tuple[float, ...], tolerance: float = 0.02) -> str | None:
    """The preset whose transducers point at ``angles`` [rad], in order, to within
    ``tolerance`` [rad] (about 1°), or ``None``.

    A user who knows a Pioneer's bearings but not where its transducers sit may give the
    bearings alone, placing every transducer at the centre; the preset puts each where the
    robot has it, 0.15–0.26 m out, which the maps need.
    """
    for name, layout in PRESETS.items():
        if len(layout) == len(angles) and all(
            abs(math.remainder(a - bearing, 2 * math.pi)) <= tolerance
            for a, (_, _, bearing) in zip(angles, layout, strict=True)
        ):
            return name
    return None


def ring_from_layout(layout: Layout, beam_width: float | None = None) -> SonarGeometry:
    """A ring of transducers at ``layout``'s ``(x [m], y [m], heading [rad])``, in ring order.

    Beam width (unless given, in radians), ranges and noise are the presets' (25°, 0.1–5 m,
    σ 2 cm).
    """
    return SonarGeometry(
        angles=tuple(a for _, _, a in layout),
        offsets=tuple((x, y) for x, y, _ in layout),
        beam_width=_DEFAULTS["beam_width"] if beam_width is None else beam_width,
        min_range=_DEFAULTS["min_range"],
        max_range=_DEFAULTS["max_range"],
        sigma=_DEFAULTS["sigma"],
    )


def logged_ring(layout: Layout, n: int, beam_width: float | None = None) -> SonarGeometry | str:
    """The ring a robot's log describes (:func:`ring_from_layout`) for its rings of ``n``
    ranges, or why the description cannot be that ring."""
    if len(layout) != n:
        return f"sonar geometry of {len(layout)} transducers for rings of {n} ranges"
    try:
        return ring_from_layout(layout, beam_width)
    except ConfigError as error:
        return f"sonar geometry: {error}"


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise FormatError(f"{where} must be a finite number, got {value!r}")
    return float(value)


def ring_from_mapping(data: Any, source: str = "ring") -> SonarGeometry:
    """Build a :class:`SonarGeometry` from a parsed ring file (see module docstring)."""
    if not isinstance(data, dict):
        raise FormatError(
            f"{source}: a ring file is a mapping with 'transducers', got {type(data).__name__}"
        )
    unknown_top = set(map(str, data)) - _TOP_KEYS
    if unknown_top:
        raise FormatError(
            f"{source}: unknown key(s) {', '.join(sorted(unknown_top))}; a ring file has "
            f"{', '.join(sorted(_TOP_KEYS))}"
        )
    length_unit = data.get("length_unit", "m")
    angle_unit = data.get("angle_unit", "deg")
    if not isinstance(length_unit, str) or length_unit not in _LENGTH:
        raise FormatError(f"{source}: length_unit {length_unit!r} is not one of m, cm, mm")
    if not isinstance(angle_unit, str) or angle_unit not in _ANGLE:
        raise FormatError(f"{source}: angle_unit {angle_unit!r} is not one of deg, rad")
    metres, radians = _LENGTH[length_unit], _ANGLE[angle_unit]
    scale = {"beam_width": radians, "min_range": metres, "max_range": metres, "sigma": metres}
    shared = dict(_DEFAULTS)
    for key in _SHARED:
        if key in data:
            shared[key] = _number(data[key], f"{source}: {key}") * scale[key]
    items = data.get("transducers")
    if not isinstance(items, list) or len(items) < 2:
        raise FormatError(f"{source}: 'transducers' must list at least two transducers")
    angles, offsets = [], []
    for index, item in enumerate(items):
        where = f"{source}: transducer {index}"
        if not isinstance(item, dict):
            raise FormatError(f"{where} must be a mapping with x, y and heading")
        missing = [k for k in ("x", "y", "heading") if k not in item]
        if missing:
            raise FormatError(f"{where} lacks {', '.join(missing)}")
        unknown = set(item) - {"x", "y", "heading", *_SHARED}
        if unknown:
            raise FormatError(f"{where}: unknown key(s) {', '.join(sorted(unknown))}")
        offsets.append(
            (_number(item["x"], f"{where} x") * metres, _number(item["y"], f"{where} y") * metres)
        )
        angles.append(_number(item["heading"], f"{where} heading") * radians)
        for key in _SHARED:
            if key in item:
                value = _number(item[key], f"{where} {key}") * scale[key]
                if not math.isclose(value, shared[key], rel_tol=1e-9):
                    raise ConfigError(
                        f"{where}: {key} differs from the ring's ({item[key]} vs the shared "
                        "value); the sonar models take one value per ring"
                    )
    _check_shared(shared, source, length_unit, angle_unit)
    far = max(math.hypot(x, y) for x, y in offsets)
    if far > MAX_SONAR_REACH:
        raise FormatError(
            f"{source}: a transducer sits {far / metres:g} {length_unit} from the centre; is "
            "length_unit right?"
        )
    return SonarGeometry(
        angles=tuple(angles),
        offsets=tuple(offsets),
        beam_width=shared["beam_width"],
        min_range=shared["min_range"],
        max_range=shared["max_range"],
        sigma=shared["sigma"],
    )


def _check_shared(shared: dict[str, float], source: str, length_unit: str, angle_unit: str) -> None:
    """The ring's beam width, ranges and noise, checked and reported in the file's units."""
    metres, radians = _LENGTH[length_unit], _ANGLE[angle_unit]

    def length(key: str) -> str:
        return f"{key} {shared[key] / metres:g} {length_unit}"

    if not 0 < shared["beam_width"] < math.pi:
        width = f"{shared['beam_width'] / radians:g} {angle_unit}"
        raise FormatError(f"{source}: beam_width {width} must lie between 0 and a half turn")
    if not 0 <= shared["min_range"] < shared["max_range"]:
        raise FormatError(
            f"{source}: need 0 <= min_range < max_range, got {length('min_range')} and "
            f"{length('max_range')}"
        )
    problem = reach_problem(shared["max_range"])
    if problem is not None:
        raise FormatError(
            f"{source}: {length('max_range')} is {shared['max_range']:g} m, {problem}; "
            "is length_unit right?"
        )
    if not shared["sigma"] > 0:
        raise FormatError(f"{source}: sigma must be above 0, got {length('sigma')}")


def load_ring(spec: str | Path) -> SonarGeometry:
    """A ring from a preset name (``pioneer8``, ``pioneer16``) or a YAML ring file."""
    if str(spec) in PRESETS:
        return preset(str(spec))
    path = Path(spec)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        import difflib  # only on the error path

        close = difflib.get_close_matches(str(spec).lower(), list(PRESETS), n=1)
        hint = f"; did you mean the preset {close[0]!r}?" if close else ""
        raise InputError(
            f"cannot read ring file {path}: {error.strerror or error} "
            f"(or name a preset: {', '.join(PRESETS)}){hint}"
        ) from None
    try:
        data = yaml.load(text, Loader=PlainNumberLoader)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = f", line {mark.line + 1}" if mark is not None else ""
        raise FormatError(
            f"{path}{line}: not valid YAML ({getattr(error, 'problem', error)})"
        ) from None
    return ring_from_mapping(data, str(path))
