"""Sonar logs from ROS bags: ``sensor_msgs/Range`` per transducer plus odometry or tf.

Reads ROS 1 bags, ROS 2 bags (sqlite3 or MCAP storage) through the ``rosbags`` library's
:class:`~rosbags.highlevel.AnyReader`. Each transducer publishes its own ``Range`` topic, in
ring order, or transducers share topics and are told apart by their messages' header
``frame_id`` (``frames``, in ring order: a driver that publishes the whole ring on one
topic); a *ring* is formed at each message of the first transducer from every transducer's
reading nearest in time (within half the first one's median period), and a ring with a
transducer silent for that long is skipped and reported, like a bad row of a text log. A
driver that sends the whole ring as one ``sensor_msgs/PointCloud`` or ``PointCloud2`` a
message, each echo a point in the robot frame in transducer order (RosAria, ROS's driver
for Pioneer robots), is read from that one topic, each range the point's distance from its
transducer. Poses come from
``nav_msgs/Odometry`` (``pose.pose``) or from ``tf2_msgs/TFMessage`` transforms between two
named frames, and are joined to the rings as in :func:`bayesmap.sonar.logs.read_sonar_log`
(interpolation across gaps up to ``max_pose_gap``, else the nearest pose within
``time_tolerance``). Ranges are in metres (ROS convention, REP 103) and read as REP 117
says: ``+inf`` or a reading above the message's ``max_range`` is no echo; ``-inf`` (too
close), NaN (invalid) and a reading below the message's ``min_range`` measured nothing,
kept as 0 m, which :func:`~bayesmap.sonar.pipeline.map_log` never maps. A message whose
``max_range`` is not above its ``min_range`` (a driver that left it unset) sets no bound:
the ring's max range applies.
"""

from __future__ import annotations

import logging
import math
import struct
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from bayesmap._io import open_input
from bayesmap._typing import FloatArray
from bayesmap.errors import BayesmapError, FormatError, InputError
from bayesmap.sonar.logs import SkippedRow, SonarLog, join_poses

__all__ = ["bag_kind", "read_sonar_bag"]

logger = logging.getLogger(__name__)


_BAG_MAGIC = {
    b"#ROSBAG": "a ROS 1 bag",
    b"\x89MCAP": "an MCAP file",
    b"SQLite format 3\x00": "a ROS 2 bag (sqlite3)",
}
"""How each bag storage begins (the ROS 1 bag format 2.0, the MCAP spec, SQLite's header)."""


def bag_kind(path: str | Path) -> str | None:
    """What kind of ROS bag ``path`` is (``"a ROS 1 bag"``, ...), or ``None`` if none: a
    folder holding a ``metadata.yaml``, or a file that opens with a bag's magic bytes."""
    where = Path(path)
    if where.is_dir():
        return "a ROS 2 bag folder" if (where / "metadata.yaml").is_file() else None
    try:
        handle, _ = open_input(where)
    except FormatError:
        return None
    with handle:
        head = handle.read(16)
    return next((kind for magic, kind in _BAG_MAGIC.items() if head.startswith(magic)), None)


def _range(message: Any) -> float:
    """A ``sensor_msgs/Range`` reading [m] as the module docstring says: ``inf`` for no
    echo, 0 for a reading that measured nothing."""
    r = float(message.range)
    low, high = float(message.min_range), float(message.max_range)
    bounded = high > max(low, 0.0)  # an unset max_range (0, NaN) bounds nothing
    if math.isnan(r) or r < low or r <= 0.0:
        return 0.0
    if r == math.inf or (bounded and r > high):
        return math.inf
    return r


def _stamp(message: Any, fallback_ns: int) -> float:
    header = getattr(message, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is None:
        return fallback_ns * 1e-9
    sec = getattr(stamp, "sec", getattr(stamp, "secs", 0))
    nsec = getattr(stamp, "nanosec", getattr(stamp, "nsecs", 0))
    t = float(sec) + 1e-9 * float(nsec)
    return t if t > 0 else fallback_ns * 1e-9


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def read_sonar_bag(
    path: str | Path,
    topics: Sequence[str],
    *,
    pose_topic: str = "/odom",
    tf_frames: tuple[str, str] = ("odom", "base_link"),
    strict: bool = False,
    time_tolerance: float = 0.05,
    max_pose_gap: float = 1.0,
    frames: Sequence[str] | None = None,
    positions: npt.ArrayLike | None = None,
) -> SonarLog:
    """Read rings and poses from a ROS 1 bag, a ROS 2 bag folder or an MCAP bag.

    Parameters
    ----------
    path
        ``.bag`` file (ROS 1) or ROS 2 bag folder (sqlite3 or MCAP storage).
    topics
        One ``sensor_msgs/Range`` topic per transducer, in ring order; with ``frames``, the
        topic (or topics) the transducers share; or one ``sensor_msgs/PointCloud`` or
        ``PointCloud2`` topic whose every message is a ring, point ``k`` the echo of
        transducer ``k`` in the robot frame (as ROS's driver for Pioneer robots, RosAria,
        publishes its sonar): its range is the point's distance from the transducer
        (``positions``).
    pose_topic
        A ``nav_msgs/Odometry`` topic, or a ``tf2_msgs/TFMessage`` topic (``/tf``) from which
        the transform ``tf_frames[0] → tf_frames[1]`` is taken.
    strict
        Abort at the first ring that cannot be formed or joined.
    time_tolerance, max_pose_gap
        Pose join settings [s], as for :func:`~bayesmap.sonar.logs.read_sonar_log`.
    frames
        The transducers' header ``frame_id`` values, in ring order (a leading ``/`` is
        ignored): a message on any of ``topics`` is the reading of the transducer its frame
        names; messages of other frames are counted in one warning and left out.
    positions
        ``(n, 2)`` the transducers' positions [m] in the robot frame, for a point-cloud topic
        (:meth:`SonarGeometry.sensors <bayesmap.sonar.geometry.SonarGeometry.sensors>` at the
        origin).
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    channels = list(topics) if frames is None else [f.lstrip("/") for f in frames]
    if len(channels) < 2 and not (frames is None and len(topics) == 1):  # one topic: a cloud?
        what = "Range topics" if frames is None else "frames"
        raise InputError(f"a sonar ring needs at least two {what}, got {channels}")
    repeated = sorted({c for c in channels if channels.count(c) > 1})
    if repeated:
        what = "topic" if frames is None else "frame"
        raise InputError(f"{what} {repeated[0]} is named twice; each transducer has its own")
    if not topics:
        raise InputError("give the Range topic (or topics) the frames are published on")
    bag = Path(path)
    if not bag.exists():
        raise InputError(f"cannot read bag {bag}: no such file or folder")
    readings: dict[str, list[tuple[float, float]]] = {channel: [] for channel in channels}
    clouds: list[tuple[float, FloatArray]] = []
    other_frames: dict[str, int] = {}
    cloud = False  # whether the ring comes as one point cloud a message
    pose_rows: list[tuple[float, float, float, float]] = []
    try:
        with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            known = {c.topic: c for c in reader.connections}
            missing = [t for t in [*topics, pose_topic] if t not in known]
            if missing:
                raise FormatError(
                    f"topic(s) {', '.join(missing)} not in the bag; it has: "
                    f"{', '.join(sorted(known))}",
                    path=bag,
                )
            cloud = frames is None and len(topics) == 1 and _is_cloud(known[topics[0]].msgtype)
            for topic in topics if not cloud else ():
                if not known[topic].msgtype.endswith("/Range"):
                    raise FormatError(
                        f"topic {topic} carries {known[topic].msgtype}, not sensor_msgs/Range"
                        + (" or a point cloud" if len(topics) == 1 else ""),
                        path=bag,
                    )
            if len(channels) < 2 and not cloud:
                raise InputError(f"a sonar ring needs at least two Range topics, got {channels}")
            if cloud and positions is None:
                raise InputError(
                    f"{topics[0]} carries the ring as a point cloud: its transducers' positions "
                    "are needed to read ranges from it (give the ring)"
                )
            wanted = [c for c in reader.connections if c.topic in topics or c.topic == pose_topic]
            for connection, timestamp, raw in reader.messages(connections=wanted):
                message: Any = reader.deserialize(raw, connection.msgtype)
                if cloud and connection.topic in topics:
                    clouds.append((_stamp(message, timestamp), _cloud_points(message, bag)))
                elif connection.topic in topics:
                    channel = connection.topic
                    if frames is not None:
                        channel = str(message.header.frame_id).lstrip("/")
                        if channel not in readings:
                            other_frames[channel] = other_frames.get(channel, 0) + 1
                            continue
                    readings[channel].append((_stamp(message, timestamp), _range(message)))
                elif connection.msgtype.endswith("Odometry"):
                    pose = message.pose.pose
                    pose_rows.append(
                        (
                            _stamp(message, timestamp),
                            float(pose.position.x),
                            float(pose.position.y),
                            _yaw(pose.orientation),
                        )
                    )
                elif connection.msgtype.endswith("TFMessage"):
                    for transform in message.transforms:
                        if (
                            transform.header.frame_id.lstrip("/") == tf_frames[0]
                            and transform.child_frame_id.lstrip("/") == tf_frames[1]
                        ):
                            move = transform.transform
                            pose_rows.append(
                                (
                                    _stamp(transform, timestamp),
                                    float(move.translation.x),
                                    float(move.translation.y),
                                    _yaw(move.rotation),
                                )
                            )
                else:
                    raise FormatError(
                        f"pose topic {pose_topic} carries {connection.msgtype}, not "
                        "nav_msgs/Odometry or tf2_msgs/TFMessage",
                        path=bag,
                    )
    except BayesmapError:
        raise
    except AnyReaderError as error:
        raise FormatError(f"cannot read the bag: {error}", path=bag) from None
    except (OSError, UnicodeDecodeError, ValueError, TypeError, struct.error) as error:
        # what rosbags raises on a damaged file, or a ROS 2 folder without its metadata
        hint = (
            "; a ROS 2 bag folder needs its metadata.yaml (or pass its .db3 / .mcap file)"
            if bag.is_dir()
            else ""
        )
        detail = " ".join(str(error).split()) or type(error).__name__
        raise FormatError(f"cannot read the bag ({detail}){hint}", path=bag) from None
    if cloud:
        if not clouds:
            raise FormatError(f"no messages on {topics[0]}", path=bag)
        return _cloud_rings(
            bag, clouds, np.asarray(positions, dtype=np.float64), pose_rows, strict,
            time_tolerance, max_pose_gap,
        )  # fmt: skip
    if other_frames:
        logger.warning(
            "%s: %d Range messages from frames not in the ring (%s) left out",
            bag,
            sum(other_frames.values()),
            ", ".join(f"{name or '(empty)'}: {n}" for name, n in sorted(other_frames.items())),
        )
    silent = [c for c in channels if not readings[c]]
    if frames is not None and silent:
        seen = sorted([c for c in channels if readings[c]] + list(other_frames))
        raise FormatError(
            f"no Range messages from frame(s) {', '.join(silent)} on {', '.join(topics)}; "
            f"frames seen: {', '.join(seen) or 'none'}",
            path=bag,
        )
    return _assemble(bag, channels, readings, pose_rows, strict, time_tolerance, max_pose_gap)


def _is_cloud(msgtype: str) -> bool:
    return msgtype.endswith(("/PointCloud", "/PointCloud2"))


_CLOUD_TYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}
"""``sensor_msgs/PointField`` datatype codes and the numpy types they name."""


def _cloud_points(message: Any, bag: Path) -> FloatArray:
    """``(m, 2)`` the x, y of a ``PointCloud`` or ``PointCloud2`` message's points [m]."""
    if hasattr(message, "points"):  # sensor_msgs/PointCloud: geometry_msgs/Point32 points
        return np.array([(p.x, p.y) for p in message.points], dtype=np.float64).reshape(-1, 2)
    fields = {f.name: f for f in message.fields}
    n = int(message.width) * int(message.height)
    raw = np.asarray(message.data, dtype=np.uint8).tobytes()
    points = np.empty((n, 2))
    for k, name in enumerate(("x", "y")):
        field = fields.get(name)
        code = None if field is None else _CLOUD_TYPES.get(int(field.datatype))
        if field is None or code is None:
            raise FormatError(
                f"a PointCloud2 ring needs numeric x and y fields, it has {', '.join(fields)}",
                path=bag,
            )
        kind = np.dtype((">" if message.is_bigendian else "<") + code)
        points[:, k] = np.ndarray(
            (n,), kind, buffer=raw, offset=int(field.offset), strides=(int(message.point_step),)
        )
    return points


def _cloud_rings(
    bag: Path,
    clouds: list[tuple[float, FloatArray]],
    positions: FloatArray,
    pose_rows: list[tuple[float, float, float, float]],
    strict: bool,
    time_tolerance: float,
    max_pose_gap: float,
) -> SonarLog:
    """Rings from point-cloud messages: transducer ``k``'s range is the distance of point
    ``k`` from its position (a point that is not finite measured nothing: 0 m)."""
    clouds.sort(key=lambda cloud: cloud[0])
    n = len(positions)
    stamps = np.array([t for t, _ in clouds])
    ranges = np.zeros((len(clouds), n))
    reasons = [""] * len(clouds)
    for i, (t, points) in enumerate(clouds):
        if len(points) != n:
            reasons[i] = f"ring at t={t:.3f} s holds {len(points)} points, the ring {n} transducers"
            continue
        r = np.hypot(*(points - positions).T)
        ranges[i] = np.where(np.isfinite(r), r, 0.0)
    return _join(bag, stamps, ranges, reasons, pose_rows, strict, time_tolerance, max_pose_gap)


def _assemble(
    bag: Path,
    channels: Sequence[str],
    readings: dict[str, list[tuple[float, float]]],
    pose_rows: list[tuple[float, float, float, float]],
    strict: bool,
    time_tolerance: float,
    max_pose_gap: float,
) -> SonarLog:
    """Rings from each transducer's ``(stamp, range)`` readings (``channels``: its topic or
    frame, in ring order), joined to the poses."""
    series = {c: np.asarray(sorted(readings[c]), dtype=np.float64).reshape(-1, 2) for c in channels}
    silent = [t for t, s in series.items() if len(s) == 0]
    if silent:
        raise FormatError(f"no Range messages on {', '.join(silent)}", path=bag)
    base = series[channels[0]][:, 0]
    period = float(np.median(np.diff(base))) if len(base) > 1 else 1.0
    window = 0.5 * period
    ranges = np.full((len(base), len(channels)), np.nan)
    for k, channel in enumerate(channels):
        t, r = series[channel][:, 0], series[channel][:, 1]
        right = np.clip(np.searchsorted(t, base), 0, len(t) - 1)
        left = np.clip(right - 1, 0, len(t) - 1)
        nearest = np.where(np.abs(t[left] - base) <= np.abs(t[right] - base), left, right)
        ok = np.abs(t[nearest] - base) <= window
        ranges[ok, k] = r[nearest[ok]]
    reasons = [""] * len(base)
    for i in np.flatnonzero(np.isnan(ranges).any(axis=1)):
        quiet = [channels[int(k)] for k in np.flatnonzero(np.isnan(ranges[i]))]
        reasons[i] = f"ring at t={base[i]:.3f} s: no reading from {', '.join(quiet)}"
    return _join(bag, base, ranges, reasons, pose_rows, strict, time_tolerance, max_pose_gap)


def _join(
    bag: Path,
    stamps: FloatArray,
    ranges: FloatArray,
    reasons: list[str],
    pose_rows: list[tuple[float, float, float, float]],
    strict: bool,
    time_tolerance: float,
    max_pose_gap: float,
) -> SonarLog:
    """Rings (``stamps`` ascending; ``reasons``: why a ring cannot be used, or ``""``)
    joined to the poses; a ring stamped as the one before it is left out (a driver that
    restamps, or one message recorded twice), every ring left out is reported."""
    if not pose_rows:
        raise FormatError("no poses in the bag (check the pose topic and tf frames)", path=bag)
    for i in np.flatnonzero(np.diff(stamps) <= 0) + 1:
        if not reasons[i]:
            reasons[i] = f"ring at t={stamps[i]:.3f} s has the stamp of the ring before it"
    complete = np.array([not why for why in reasons], dtype=bool)
    pose_data = np.asarray(sorted(pose_rows), dtype=np.float64)
    poses, why = join_poses(stamps, pose_data[:, 0], pose_data[:, 1:], time_tolerance, max_pose_gap)
    for i in np.flatnonzero(complete & (why != "")):
        reasons[i] = str(why[i])
    skipped = [SkippedRow(str(bag), i + 1, why) for i, why in enumerate(reasons) if why]
    if strict and skipped:
        raise FormatError(skipped[0].reason + " (drop --strict to skip it)", path=bag)
    for row in skipped:
        logger.warning("%s, ring %d: %s; skipped", bag, row.line, row.reason)
    keep = np.array([not why for why in reasons], dtype=bool)
    if not keep.any():
        raise FormatError(f"no usable rings ({len(skipped)} skipped)", path=bag)
    out_ranges: FloatArray = ranges[keep]
    return SonarLog(stamps[keep], poses[keep], out_ranges, len(stamps), tuple(skipped))
