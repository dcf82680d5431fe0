"""Every file reader bayesmap fuzzes: its seed files, how to mutate them, and poisons.

Shared by the atheris harnesses (``fuzz/fuzz_*.py``) and the campaign that writes
docs/reliability.md (``fuzz/campaign.py``). A :class:`Target` reads bytes the way a user's
file reaches the reader (through a file in a scratch folder when the reader takes a path).

*Mutations* (random byte edits of a seed) may give a result or a
:class:`~bayesmap.errors.BayesmapError`; anything else is a crash. *Poisons* are edits
known to make a seed invalid (a NaN probability, an empty state name, a duplicate row, an
entity, a NaN origin, reversed thresholds, an image claiming more pixels than it holds):
a reader that returns a result for one has accepted bad input silently.
"""

from __future__ import annotations

import gzip
import io
import re
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from bayesmap.bn import io as bn_io
from bayesmap.bn.io import bif, uai, xbn, xdsl, xmlbif
from bayesmap.bn.io import net as hugin
from bayesmap.bn.model import BayesNet
from bayesmap.grid.occupancy import OccupancyGrid
from bayesmap.grid.ros import read_ros_map
from bayesmap.sonar.carmen import read_carmen_log
from bayesmap.sonar.logs import read_sonar_log, write_sonar_log
from bayesmap.sonar.player import read_player_log

Mutator = Callable[[bytes, np.random.Generator], bytes]

TOKENS = [
    b"nan", b"NaN", b"inf", b"-Infinity", b"1_0", "\u0661".encode(), b"1e999", b"0x1",
    b"-0.5", b"99999999999999999999", b"", b"\x00", b"\xff\xfe", b'"', b"\\", b"{", b"}",
    b"(", b")", b";", b",", b"|", b"=", b"/*", b"*/", b"//", b"<", b">", b"&", b"&e;",
    b"<!ENTITY e 'x'>", b"<!DOCTYPE x [", b"]>", b"<![CDATA[", b"]]>", b"<!--", b"-->",
    b"default", b"table", b"probability", b"variable", b"[ 2 ]", b"\n", b"\r\n", b"\t",
    b"P5", b"255", b"65535", b"IHDR", b"PK\x03\x04", b"mode: scale", b"negate: 1",
]  # fmt: skip


def mutate(data: bytes, rng: np.random.Generator, *, splice: bytes = b"") -> bytes:
    """``data`` after 1-4 random edits: byte flips, token inserts, cuts, copies, splices."""
    out = bytearray(data)
    for _ in range(int(rng.integers(1, 5))):
        n = len(out)
        i = int(rng.integers(0, n + 1))
        j = min(n, i + int(rng.integers(0, 64)))
        op = int(rng.integers(0, 6))
        if op == 0 and n:
            out[min(i, n - 1)] = int(rng.integers(0, 256))
        elif op == 1:
            out[i:i] = TOKENS[int(rng.integers(0, len(TOKENS)))]
        elif op == 2:
            del out[i:j]
        elif op == 3:
            out[j:j] = out[i:j] * int(rng.integers(1, 4))
        elif op == 4:
            del out[i:]
        elif splice:
            k = int(rng.integers(0, len(splice) + 1))
            out[i:j] = splice[k : k + int(rng.integers(0, 128))]
    return bytes(out)


@dataclass(frozen=True)
class Target:
    """One reader: ``read(data, scratch)`` parses ``data`` as a user's file would reach it."""

    name: str
    read: Callable[[bytes, Path], object]
    seeds: list[bytes]
    poisons: list[Mutator] = field(default_factory=list)


# ---------------------------------------------------------------------------- networks
def _network_seeds(
    dumps: Callable[..., str], root: str = "a b", states: tuple[str, str] = ("<0.5m", ">=0.5m")
) -> list[bytes]:
    """A tiny network with awkward names and properties, and a chain of eight variables
    (``root`` and ``states``: the tiny network's first variable and its states; NET cannot
    name it ``a b``, XDSL its states ``<0.5m``, ``>=0.5m`` either)."""
    tiny = BayesNet("tiny [/m]")
    tiny.properties["author"] = 'x "y" <z> [/m]'
    tiny.add_variable(root, list(states), cpt=[0.25, 0.75], kind="B")
    tiny.add_variable(
        "c", ["x", "y", "z"], parents=[root], cpt=[[0.5, 0.125], [0.25, 0.5], [0.25, 0.375]]
    )
    tiny.variable("c").properties["note"] = "a; b } c"
    chain = BayesNet("chain")
    chain.add_variable("v0", ["no", "yes"], cpt=[0.5, 0.5])
    for k in range(1, 8):
        parents = [f"v{k - 1}"] + ([f"v{k - 2}"] if k > 1 else [])
        shape = (2,) * len(parents)
        yes = np.linspace(0.1, 0.9, 2 ** len(parents)).reshape(shape)
        chain.add_variable(f"v{k}", ["no", "yes"], parents=parents, cpt=np.stack([1 - yes, yes]))
    return [dumps(tiny).encode(), dumps(chain).encode()]


def _sub_one(pattern: str, replace: Callable[[re.Match[bytes], np.random.Generator], bytes]):
    """A poison replacing one random match of ``pattern`` (a seed without one is unchanged)."""
    regex = re.compile(pattern.encode())

    def poison(data: bytes, rng: np.random.Generator) -> bytes:
        matches = list(regex.finditer(data))
        if not matches:
            raise ValueError(f"seed has no {pattern!r}")
        m = matches[int(rng.integers(0, len(matches)))]
        return data[: m.start()] + replace(m, rng) + data[m.end() :]

    return poison


BAD_NUMBERS = [b"nan", b"NaN", b"inf", b"Infinity", b"1_0", "\u0661".encode(), b"1e999", b"0x1"]
_NUMBER = r"(?<=[\s>,])(?:0\.[0-9]+|1\.0)(?=[\s,;<])"  # a table entry


def _bad_number(m: re.Match[bytes], rng: np.random.Generator) -> bytes:
    return BAD_NUMBERS[int(rng.integers(0, len(BAD_NUMBERS)))]


def _duplicate(m: re.Match[bytes], rng: np.random.Generator) -> bytes:
    return m.group() + m.group()


def _entity(data: bytes, rng: np.random.Generator) -> bytes:
    head, _, body = data.partition(b"?>")
    root = body.lstrip().split(b">")[0].split()[0][1:]
    body = re.sub(rb">([^<>\s]+)<", rb">&e;<", body, count=1)
    return head + b"?><!DOCTYPE " + root + b' [<!ENTITY e "x">]>' + body


BIF_POISONS: list[Mutator] = [
    _sub_one(_NUMBER, _bad_number),
    _sub_one(r"\{ ([^{};,]+),", lambda m, r: b'{ "",'),
    _sub_one(r"\n  \([^\n]*;", _duplicate),
    lambda data, rng: data + b"\n/* never closed",
]
XMLBIF_POISONS: list[Mutator] = [
    _sub_one(_NUMBER, _bad_number),
    _sub_one(r"<OUTCOME>[^<]*</OUTCOME>", lambda m, r: b"<OUTCOME></OUTCOME>"),
    _entity,
]
NET_POISONS: list[Mutator] = [
    _sub_one(r"(?<=[\s(])(?:0\.[0-9]+|1\.0)(?=[\s)])", _bad_number),  # NET lists: (0.5 0.5)
    _sub_one(r'states = \("[^"]*"', lambda m, r: b'states = (""'),
    _sub_one(r"\npotential \([^\n]*\n\{[^}]*\}", _duplicate),
    lambda data, rng: data + b'\nnode late { states = ("a); }',
]
XDSL_POISONS: list[Mutator] = [
    _sub_one(_NUMBER, _bad_number),
    _sub_one(r'<state id="[^"]*"', lambda m, r: b'<state id=""'),
    _sub_one(r"(?s)<cpt id=[^>]*>.*?</cpt>", _duplicate),
    _entity,
]
UAI_POISONS: list[Mutator] = [
    _sub_one(_NUMBER, _bad_number),
    lambda data, rng: data.replace(b"BAYES", b"MARKOV", 1),  # not a Bayesian network
    _sub_one(r"\n([0-9]+)\n ", lambda m, r: b"\n" + str(int(m.group(1)) + 1).encode() + b"\n "),
]
XBN_POISONS: list[Mutator] = [
    _sub_one(_NUMBER, _bad_number),
    _sub_one(r"<STATENAME>[^<]*</STATENAME>", lambda m, r: b"<STATENAME></STATENAME>"),
    _sub_one(r'<DPI INDEXES="[^"]*">[^<]*</DPI>', _duplicate),
    _entity,
]


def _read_gz(data: bytes, scratch: Path) -> object:
    path = scratch / "net.bif.gz"
    path.write_bytes(data)
    return bn_io.read(path)


# ---------------------------------------------------------------------------- grids
def _npz(**override: object) -> bytes:
    arrays: dict[str, object] = {
        "probability": np.linspace(0, 1, 12).reshape(3, 4),
        "entropy": np.full((3, 4), 0.5),
        "resolution": np.float64(0.25),
        "origin": np.array([-1.0, 2.0]),
        "prior": np.float64(0.5),
    }
    arrays.update(override)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)  # type: ignore[arg-type]
    return buffer.getvalue()


def _read_npz(data: bytes, scratch: Path) -> object:
    path = scratch / "grid.npz"
    path.write_bytes(data)
    return OccupancyGrid.load_npz(path)


NPZ_POISONS: list[Mutator] = [
    lambda d, r: _npz(origin=np.array([np.nan, 0.0])),
    lambda d, r: _npz(origin=np.array([0.0, np.inf])),
    lambda d, r: _npz(resolution=np.float64(np.nan)),
    lambda d, r: _npz(resolution=np.float64(-1.0)),
    lambda d, r: _npz(probability=np.full((3, 4), np.nan)),
    lambda d, r: _npz(prior=np.float64(2.0)),
    lambda d, r: _npz(probability=np.array(["x"] * 12).reshape(3, 4)),
]

_YAML = (
    "image: map.pgm\nresolution: 0.050000\norigin: [-1.0, 2.0, 0.0]\nnegate: 0\n"
    "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
)


def _pgm(width: int = 5, height: int = 4) -> bytes:
    pixels = np.arange(width * height, dtype=np.uint8) * 12
    return f"P5\n{width} {height}\n255\n".encode() + pixels.tobytes()


def _png() -> bytes:
    buffer = io.BytesIO()
    Image.fromarray(np.arange(20, dtype=np.uint8).reshape(4, 5) * 12).save(buffer, "PNG")
    return buffer.getvalue()


def _read_ros_yaml(data: bytes, scratch: Path) -> object:
    (scratch / "map.pgm").write_bytes(_pgm())
    (scratch / "map.yaml").write_bytes(data)
    return read_ros_map(scratch / "map.yaml")


def _read_ros_image(data: bytes, scratch: Path) -> object:
    (scratch / "map.yaml").write_text(_YAML.replace("map.pgm", "map.img"))
    (scratch / "map.img").write_bytes(data)
    return read_ros_map(scratch / "map.yaml")


def _yaml_field(key: str, value: str) -> Mutator:
    return lambda d, r: re.sub(rf"(?m)^{key}:.*$".encode(), f"{key}: {value}".encode(), d)


ROS_YAML_POISONS: list[Mutator] = [
    lambda d, r: d + b"mode: fancy\n",
    _yaml_field("free_thresh", "0.9"),
    _yaml_field("occupied_thresh", "1.5"),
    _yaml_field("resolution", "-0.05"),
    _yaml_field("resolution", "nan"),
    _yaml_field("origin", "[nan, 0.0, 0.0]"),
    _yaml_field("negate", "2"),
]
ROS_IMAGE_POISONS: list[Mutator] = [
    lambda d, r: _pgm()[:-7],  # fewer pixels than the header claims
    lambda d, r: b"P5\n100000 100000\n255\n" + bytes(64),
    lambda d, r: b"P5\n5 4\n255\n",
]


# ---------------------------------------------------------------------------- sonar logs
def _sonar_seed() -> bytes:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "log.txt"
        t = np.arange(6) * 0.25
        ranges = np.linspace(0.5, 4.0, 24).reshape(6, 4)
        poses = np.column_stack([t, t * 0.5, np.zeros(6)])
        write_sonar_log(path, t, ranges, poses, comments=["test log"])
        return path.read_bytes()


def _read_sonar(data: bytes, scratch: Path) -> object:
    path = scratch / "log.txt"
    path.write_bytes(data)
    return read_sonar_log(path, 4)


_RING4 = [(0.1, 0.1, 0.8), (0.12, 0.0, 0.0), (0.1, -0.1, -0.8), (-0.1, 0.0, 3.1)]
"""A four-transducer ring for the Player and CARMEN seeds: x, y [m], bearing [rad]."""


def _player_seed() -> bytes:
    """A small Player 3 log: the ring's geometry, then odometry and rings at 4 Hz."""
    head = "{t:.3f} 16777343 6665 {device} 00 {kind} "
    geometry = " ".join(f"{x:+.3f} {y:+.3f} {a:+.4f}" for x, y, a in _RING4)
    lines = ["## Player version 3.0.2", "## File version 0.3.0"]
    lines.append(head.format(t=0.0, device="sonar", kind="004 001") + f"4 {geometry}")
    for k in range(6):
        t = 0.25 * k
        pose = f"{0.1 * k:+.3f} +0.000 +0.000 +0.400 +0.000 +0.000 0"
        lines.append(head.format(t=t, device="position2d", kind="001 001") + pose)
        ranges = " ".join(f"{1.0 + 0.1 * (k + i):.3f}" for i in range(4))
        lines.append(head.format(t=t + 0.01, device="sonar", kind="001 001") + f"4 {ranges}")
    return ("\n".join(lines) + "\n").encode()


def _carmen_seed() -> bytes:
    """A small CARMEN log: its header, a PARAM line, then odometry and rings at 4 Hz."""
    offsets = " ".join(f"{x:.3f} {y:.3f} {a:f}" for x, y, a in _RING4)
    lines = ["# CARMEN Logfile", "PARAM robot_sensor_angle 0.4363 0.000000 robot 0.000000"]
    for k in range(6):
        t = 100.0 + 0.25 * k
        stamps = f"{t:f} robot {t - 100.0:f}"
        lines.append(f"ODOM {0.1 * k:f} 0.000000 0.000000 0.400000 0.000000 0.000000 {stamps}")
        ranges = " ".join(f"{1.0 + 0.1 * (k + i):.2f}" for i in range(4))
        lines.append(f"SONAR 0.436300 4 {ranges} {offsets} {t + 0.01:f} robot {t - 99.99:f}")
    return ("\n".join(lines) + "\n").encode()


def _read_log_with(reader: Callable[[Path], object]) -> Callable[[bytes, Path], object]:
    """A target reading bytes as a log file through ``reader``."""

    def read(data: bytes, scratch: Path) -> object:
        path = scratch / "robot.log"
        path.write_bytes(data)
        return reader(path)

    return read


def _loads(module: object, name: str) -> Callable[[bytes, Path], object]:
    return lambda data, scratch: module.loads(data, path=name)  # type: ignore[attr-defined]


def targets() -> dict[str, Target]:
    """Every fuzzed reader by name."""
    bif_seeds = _network_seeds(bif.dumps)
    return {
        "bif": Target("bif", _loads(bif, "f.bif"), bif_seeds, BIF_POISONS),
        "xmlbif": Target(
            "xmlbif", _loads(xmlbif, "f.xml"), _network_seeds(xmlbif.dumps), XMLBIF_POISONS
        ),
        "xbn": Target("xbn", _loads(xbn, "f.xbn"), _network_seeds(xbn.dumps), XBN_POISONS),
        "bif.gz": Target("bif.gz", _read_gz, [gzip.compress(s) for s in bif_seeds]),
        "npz grid": Target("npz grid", _read_npz, [_npz()], NPZ_POISONS),
        "ROS yaml": Target("ROS yaml", _read_ros_yaml, [_YAML.encode()], ROS_YAML_POISONS),
        "ROS image": Target("ROS image", _read_ros_image, [_pgm(), _png()], ROS_IMAGE_POISONS),
        "sonar log": Target("sonar log", _read_sonar, [_sonar_seed()]),
        "net": Target(
            "net", _loads(hugin, "f.net"), _network_seeds(hugin.dumps, "a_b"), NET_POISONS
        ),
        "xdsl": Target(
            "xdsl",
            _loads(xdsl, "f.xdsl"),
            _network_seeds(xdsl.dumps, "a_b", ("near", "far")),
            XDSL_POISONS,
        ),
        "uai": Target("uai", _loads(uai, "f.uai"), _network_seeds(uai.dumps), UAI_POISONS),
        "Player log": Target("Player log", _read_log_with(read_player_log), [_player_seed()]),
        "CARMEN log": Target("CARMEN log", _read_log_with(read_carmen_log), [_carmen_seed()]),
    }  # fmt: skip
