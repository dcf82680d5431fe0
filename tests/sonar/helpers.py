"""Shared by the sonar tests: the data folder, its recording scripts, simulated Player and
CARMEN logs."""

from __future__ import annotations

import functools
import importlib.util
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import NamedTuple

import numpy as np
import pytest
from hypothesis import strategies as st

from bayesmap.errors import FormatError
from bayesmap.sensing.sonar_rings import PIONEER_RING16
from bayesmap.sonar.logs import RingLog
from bayesmap.sonar.pipeline import PIPELINES

DATA = Path(__file__).parent / "data"


def pipelines_as_recorded(monkeypatch: pytest.MonkeyPatch) -> None:
    """Give ``default`` and ``streaming`` the symmetric occupied arc they had when the golden
    maps were recorded (before ``sigma_front``), and ``default``'s sweep the 3 m its
    silences then cleared, with no stop at the echoes' surfaces (``forward_echo_stop``), and
    a verdict that counts every cell of the map as a surface (``transient_pairs`` 0), so the
    records still pin every other step of the computation bit for bit."""
    for name in ("default", "streaming"):
        pipeline = PIPELINES[name]
        assert pipeline.map_verdict is not None
        verdict = replace(pipeline.map_verdict, transient_pairs=0)
        monkeypatch.setitem(
            PIPELINES, name, replace(pipeline, sigma_front=None, map_verdict=verdict)
        )
    monkeypatch.setitem(
        PIPELINES,
        "default",
        replace(PIPELINES["default"], forward_no_echo=3.0, forward_echo_stop=False),
    )


def recorder(name: str) -> ModuleType:
    """The script ``tests/sonar/data/NAME.py`` that wrote a golden record, as a module."""
    spec = importlib.util.spec_from_file_location(name, DATA / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class Drive(NamedTuple):
    """A simulated Pioneer drive, rounded as Player's ``writelog`` rounds it."""

    times: np.ndarray  # (n,) ring times [s]
    ranges: np.ndarray  # (n, 16) [m], to the millimetre
    pose_times: np.ndarray  # (m,) odometry times [s]: every other ring (and the last), 3 ms late
    poses: np.ndarray  # (m, 3) odometry [m, m, rad]


@functools.cache
def simulated_drive(rings: int = 240) -> Drive:
    """The first ``rings`` rings of a 16-sonar Pioneer driving the L corridor, and its odometry."""
    from bayesmap.sim.polygons import world
    from bayesmap.sim.sonar import SonarRing
    from bayesmap.sim.sonar_log import Realism, simulate_log

    log = simulate_log(
        world("sonar-lcorridor-v2"), SonarRing.pioneer(16), Realism(stops=1, people=0), rng=3
    )
    times = np.round(log.times[:rings] + 100.0, 3)
    pose_index = np.unique(np.r_[np.arange(0, rings, 2), rings - 1])
    return Drive(
        times=times,
        ranges=np.round(log.ranges[:rings], 3),
        pose_times=np.round(times[pose_index] + 0.003, 3),
        poses=np.round(log.odometry[pose_index], 3),
    )


def player_lines(drive: Drive, version: str = "0.3.0", geometry: bool = True) -> list[str]:
    """The lines a Player ``writelog`` of file version 0.3.0 (Player 2-3) or 0.2.0 (Player 1.6)
    would write for ``drive``: odometry on position device 0, the ring on sonar 0, a laser
    on the side; the ring's geometry is Player's (the Pioneer ring, to the millimetre)."""
    layout = [(round(x, 3), round(y, 3), round(a, 4)) for x, y, a in PIONEER_RING16]
    geom = f"{len(layout)} " + " ".join(f"{x:+07.3f} {y:+07.3f} {a:+07.4f}" for x, y, a in layout)
    if version == "0.2.0":  # server time, host name, port, ..., data time; geometry on each line
        head = "{t:014.3f} robot 6665 {name} {index:02d} {t:014.3f} "
        position, prefix = "position", (geom if geometry else "0") + " "
    else:
        head = "{t:014.3f} 0 6665 {name} {index:02d} {kind} "
        position, prefix = "position2d", ""
    lines = [
        f"## Player version {'1.6.5' if version == '0.2.0' else '3.0.2'} ",
        f"## File version {version} ",
        "## written by the tests: time host robot interface index (type subtype) payload",
    ]
    if version == "0.3.0" and geometry:
        lines.append(head.format(t=drive.times[0], name="sonar", index=0, kind="004 001") + geom)
    timed: list[tuple[float, int, str]] = []
    for t, (x, y, a) in zip(drive.pose_times, drive.poses, strict=True):
        body = f"{x:+07.3f} {y:+07.3f} {a:+04.3f} +00.400 +00.000 +00.000 0"
        line = head.format(t=t, name=position, index=0, kind="001 001") + body
        timed.append((float(t), 0, line))
    for t, r in zip(drive.times, drive.ranges, strict=True):
        body = f"{prefix}{len(r)} " + " ".join(f"{v:.3f}" for v in r)
        timed.append((float(t), 1, head.format(t=t, name="sonar", index=0, kind="001 001") + body))
        laser = head.format(t=t, name="laser", index=0, kind="001 001") + "0001 -1.5708 +1.5708"
        timed.append((float(t), 2, laser))
    lines.extend(line + " " for _, _, line in sorted(timed))
    return lines


def carmen_lines(drive: Drive, cone: float = 0.4363) -> list[str]:
    """The lines CARMEN's logger would write for ``drive``: its header, a few PARAM lines,
    ODOM and SONAR (the Pioneer ring's offsets, beams ``cone`` rad wide) with ipc stamps at
    the drive's times and logger stamps 0.5 ms later, from the log's start, and a laser
    on the side."""
    start = float(drive.times[0]) - 1.0
    offsets = " ".join(f"{x:.3f} {y:.3f} {a:f}" for x, y, a in PIONEER_RING16)

    def stamps(t: float) -> str:
        return f"{t:f} robot {t - start + 0.0005:f}"

    lines = [
        "# CARMEN Logfile",
        "# file format is one message per line",
        "# message_name [message contents] ipc_timestamp ipc_hostname logger_timestamp",
        "# SONAR cone_angle num_sonars [sonar_reading] [sonar_offsets x y theta]",
        f"PARAM robot_sensor_angle {cone} {stamps(start)}",
        f"PARAM robot_use_sonar on {stamps(start)}",
        f"SYNC start {stamps(start)}",
    ]
    timed: list[tuple[float, int, str]] = []
    for t, (x, y, a) in zip(drive.pose_times, drive.poses, strict=True):
        timed.append(
            (float(t), 0, f"ODOM {x:f} {y:f} {a:f} 0.400000 0.000000 0.000000 {stamps(t)}")
        )
    for t, r in zip(drive.times, drive.ranges, strict=True):
        ranges = " ".join(f"{v:.3f}" for v in r)
        sonar = f"SONAR {cone:f} {len(r)} {ranges} {offsets} {stamps(t)}"
        timed.append((float(t), 1, sonar))
        timed.append((float(t), 2, f"FLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 {stamps(t)}"))
    lines.extend(line for _, _, line in sorted(timed))
    return lines


def write_log_lines(path: Path, lines: list[str]) -> Path:
    """Write ``lines`` as a log file (LF line ends, as ``writelog`` and CARMEN's logger
    write them)."""
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def junk_lines(words: list[str]) -> st.SearchStrategy[str]:
    """Lines a log reader must survive: any text, or ``words`` of its format in any order."""
    return st.one_of(st.text(max_size=50), st.lists(st.sampled_from(words)).map(" ".join))


def read_with_junk(
    read: Callable[..., RingLog],
    path: Path,
    lines: list[str],
    extra: list[tuple[int, str]],
    strict: bool,
    first: int = 0,
) -> None:
    """Insert ``extra`` lines (position, text) into ``lines``, none before line ``first``
    (a header that must open the file), write them to ``path`` and read them with ``read``:
    a clean :class:`FormatError`, or a log whose rows are all usable."""
    lines = list(lines)
    for at, line in extra:
        lines.insert(max(at, first), line)
    write_log_lines(path, lines)
    try:
        log = read(path, strict=strict).log
    except FormatError:
        return
    assert np.all(np.diff(log.timestamps) > 0) and np.all(log.ranges >= 0)
    assert len(log.timestamps) == len(log.poses) == len(log.ranges) >= 1
