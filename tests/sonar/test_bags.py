"""Tests of ROS bag reading: bags written with rosbags' own writers (ROS 1, ROS 2, MCAP)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore
from typer.testing import CliRunner, Result

from bayesmap.cli import app
from bayesmap.errors import FormatError, InputError
from bayesmap.sonar.bags import _range, bag_kind, read_sonar_bag

TOPICS = [f"/sonar/{k}" for k in range(4)]
RINGS = 20


def _messages(
    store: str, *, tf: bool = False, codes: tuple[float, ...] = (), shared: str | None = None
) -> list[tuple[str, str, int, object]]:
    """The drive's messages; ``codes``: transducer 0's readings of the first rings;
    ``shared``: one topic for the whole ring (transducer k's frame ``sonark``), plus a
    fifth sensor's messages (frame ``bumper_ir``) on it."""
    ts = get_typestore(Stores.ROS1_NOETIC if store == "ros1" else Stores.ROS2_HUMBLE)
    t = ts.types
    ros1 = store == "ros1"
    time_type = t["builtin_interfaces/msg/Time"]

    def header(ns: int, frame: str) -> object:
        stamp = time_type(sec=ns // 10**9, nanosec=ns % 10**9)
        if ros1:
            return t["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)
        return t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    out: list[tuple[str, str, int, object]] = []
    for i in range(RINGS):
        base = 10**9 + i * 100_000_000  # 10 Hz
        frames = [f"sonar{k}" for k in range(len(TOPICS))] + (["bumper_ir"] if shared else [])
        for k, frame in enumerate(frames):
            topic = shared or TOPICS[k]
            ns = base + k * 5_000_000  # each transducer fires 5 ms after the last
            value = 9.9 if k == 3 else 1.0 + 0.1 * k  # transducer 3: a no-echo code
            if k == 0 and i < len(codes):
                value = codes[i]
            msg = t["sensor_msgs/msg/Range"](
                header=header(ns, frame),
                radiation_type=0,
                field_of_view=0.44,
                min_range=0.1,
                max_range=5.0,
                range=value,
            )
            out.append((topic, "sensor_msgs/msg/Range", ns, msg))
        if i % 2 == 0:  # poses at half the rate, 1 ms off
            ns = base + 1_000_000
            x, yaw = 0.05 * i, 0.0
            point = t["geometry_msgs/msg/Point"](x=x, y=0.0, z=0.0)
            quat = t["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
            )
            if tf:
                move = t["geometry_msgs/msg/Transform"](
                    translation=t["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.0), rotation=quat
                )
                stamped = t["geometry_msgs/msg/TransformStamped"](
                    header=header(ns, "odom"), child_frame_id="base_link", transform=move
                )
                out.append(
                    (
                        "/tf",
                        "tf2_msgs/msg/TFMessage",
                        ns,
                        t["tf2_msgs/msg/TFMessage"](transforms=[stamped]),
                    )
                )
            else:
                cov = np.zeros(36)
                pose = t["geometry_msgs/msg/PoseWithCovariance"](
                    pose=t["geometry_msgs/msg/Pose"](position=point, orientation=quat),
                    covariance=cov,
                )
                zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
                twist = t["geometry_msgs/msg/TwistWithCovariance"](
                    twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=cov
                )
                odom = t["nav_msgs/msg/Odometry"](
                    header=header(ns, "odom"), child_frame_id="base_link", pose=pose, twist=twist
                )
                out.append(("/odom", "nav_msgs/msg/Odometry", ns, odom))
    return out


def _write(
    tmp_path: Path,
    kind: str,
    *,
    tf: bool = False,
    codes: tuple[float, ...] = (),
    shared: str | None = None,
) -> Path:
    store = "ros1" if kind == "ros1" else "ros2"
    return _bag(tmp_path, kind, _messages(store, tf=tf, codes=codes, shared=shared))


def _bag(tmp_path: Path, kind: str, messages: list[tuple[str, str, int, object]]) -> Path:
    """``messages`` (topic, type, ns, message) written in time order with rosbags' writer
    of ``kind``: ros1, ros2 (sqlite3) or mcap."""
    ts = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    messages = sorted(messages, key=lambda m: m[2])
    if kind == "ros1":
        path = tmp_path / "log.bag"
        with Writer1(path) as writer:
            conns = {}
            for topic, msgtype, ns, msg in messages:
                if topic not in conns:
                    conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
                writer.write(conns[topic], ns, ts.serialize_ros1(msg, msgtype))
        return path
    path = tmp_path / f"log_{kind}"
    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as writer:
        conns = {}
        for topic, msgtype, ns, msg in messages:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
            writer.write(conns[topic], ns, ts.serialize_cdr(msg, msgtype))
    return path


@pytest.mark.parametrize("kind", ["ros1", "ros2", "mcap"])
def test_range_topics_and_odometry_make_rings_with_poses(tmp_path: Path, kind: str) -> None:
    log = read_sonar_bag(_write(tmp_path, kind), TOPICS)
    assert log.ranges.shape == (RINGS - 1, 4)  # the last ring is past the last pose
    assert np.allclose(log.ranges[:, :3], [1.0, 1.1, 1.2])
    assert np.all(np.isinf(log.ranges[:, 3]))
    t = log.timestamps
    # Interpolated between half-rate poses 1 ms off; the first ring takes the nearest pose.
    assert np.allclose(log.poses[1:, 0], 0.5 * (t[1:] - 1.001), atol=1e-6)
    assert log.poses[0, 0] == 0.0
    assert [row.line for row in log.skipped] == [RINGS]


def test_tf_transforms_give_the_poses(tmp_path: Path) -> None:
    log = read_sonar_bag(_write(tmp_path, "ros2", tf=True), TOPICS, pose_topic="/tf")
    assert len(log.timestamps) == RINGS - 1
    assert np.allclose(log.poses[1:, 0], 0.5 * (log.timestamps[1:] - 1.001), atol=1e-6)


def test_unknown_topics_are_named(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="/sonar/9"):
        read_sonar_bag(_write(tmp_path, "ros1"), [*TOPICS[:3], "/sonar/9"])


def test_a_topic_that_is_not_a_range_is_named(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="topic /odom carries nav_msgs/msg/Odometry, not"):
        read_sonar_bag(_write(tmp_path, "ros2"), ["/odom", *TOPICS[1:]])


def test_damaged_bags_are_one_error(tmp_path: Path) -> None:
    folder = _write(tmp_path, "ros2")
    (folder / "metadata.yaml").unlink()
    with pytest.raises(FormatError, match="needs its metadata.yaml"):
        read_sonar_bag(folder, TOPICS)
    noise = tmp_path / "noise.bag"
    noise.write_bytes(np.random.default_rng(0).bytes(5000))
    with pytest.raises(FormatError, match="cannot read the bag"):
        read_sonar_bag(noise, TOPICS)
    header_only = tmp_path / "header.mcap"
    header_only.write_bytes(b"\x89MCAP0\r\n")
    with pytest.raises(FormatError, match="cannot read the bag"):
        read_sonar_bag(header_only, TOPICS)


def _map_bag(bag: Path, out: Path) -> Result:
    """``bayesmap sonar map`` on a bag of the four-transducer drive."""
    args = [
        "sonar", "map", str(bag), "--topics", ",".join(TOPICS), "--angles-deg", "45,15,-15,-45",
        "--max-range", "5", "--resolution", "0.1", "--out", str(out),
    ]  # fmt: skip
    return CliRunner().invoke(app, args)


def test_sonar_map_reads_a_bag(tmp_path: Path) -> None:
    bag = _write(tmp_path, "mcap")
    result = _map_bag(bag, tmp_path / "out")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "map.png").exists()


@pytest.mark.parametrize(
    ("reading", "low", "high", "read"),
    [
        (1.5, 0.1, 5.0, 1.5),
        (math.inf, 0.1, 5.0, math.inf),  # REP 117: no echo
        (7.0, 0.1, 5.0, math.inf),  # above the message's max: a no-echo code
        (-math.inf, 0.1, 5.0, 0.0),  # REP 117: too close
        (math.nan, 0.1, 5.0, 0.0),  # invalid
        (0.05, 0.1, 5.0, 0.0),  # below the message's min
        (-1.0, 0.0, 5.0, 0.0),
        (0.0, 0.0, 5.0, 0.0),
        (3.0, 0.1, 0.0, 3.0),  # max_range left unset by the driver: no bound
        (3.0, 0.1, math.nan, 3.0),
    ],
)
def test_range_messages_are_read_as_rep_117_says(
    reading: float, low: float, high: float, read: float
) -> None:
    message = SimpleNamespace(range=reading, min_range=low, max_range=high)
    assert _range(message) == read


def test_too_close_and_invalid_readings_are_kept_and_never_mapped(tmp_path: Path) -> None:
    bag = _write(tmp_path, "ros2", codes=(-math.inf, math.nan, -2.0, 0.0))
    log = read_sonar_bag(bag, TOPICS)
    assert log.skipped[-1].line == RINGS and len(log.skipped) == 1  # only the ring past the poses
    assert log.ranges[:4, 0].tolist() == [0.0] * 4
    result = _map_bag(bag, tmp_path / "out")
    assert result.exit_code == 0, result.output
    assert "4 of 76 readings (5.3 %) are 0, negative or below" in result.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["below_min_range"] == 4


@pytest.mark.parametrize(
    ("kind", "said"), [("ros1", "a ROS 1 bag"), ("ros2", "a ROS 2 bag folder")]
)
def test_a_bag_given_without_topics_is_named_as_a_bag(tmp_path: Path, kind: str, said: str) -> None:
    bag = _write(tmp_path, kind)
    args = ["sonar", "map", str(bag), "--ring", "pioneer16", "--out", str(tmp_path / "out")]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 2, result.output
    assert f"is {said}: give --topics" in result.output and result.output.count("\n") <= 2
    assert bag_kind(tmp_path) is None and bag_kind(tmp_path / "missing") is None


FRAMES = [f"sonar{k}" for k in range(4)]


@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_a_ring_on_one_topic_is_told_apart_by_frame(
    tmp_path: Path, kind: str, caplog: pytest.LogCaptureFixture
) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    per_topic = read_sonar_bag(_write(tmp_path / "a", kind), TOPICS)
    shared = _write(tmp_path / "b", kind, shared="/sonar")
    log = read_sonar_bag(shared, ["/sonar"], frames=FRAMES)
    assert np.array_equal(log.ranges, per_topic.ranges)
    assert np.array_equal(log.poses, per_topic.poses)
    assert "20 Range messages from frames not in the ring (bumper_ir: 20) left out" in caplog.text
    backwards = read_sonar_bag(shared, ["/sonar"], frames=["/" + f for f in FRAMES[::-1]])
    assert np.array_equal(backwards.ranges, per_topic.ranges[:, ::-1])  # ring order = frame order


def test_a_frame_the_bag_lacks_is_named_with_the_frames_it_has(tmp_path: Path) -> None:
    shared = _write(tmp_path, "ros2", shared="/sonar")
    said = "frame.s. sonar9 on /sonar; frames seen: bumper_ir, sonar0"
    with pytest.raises(FormatError, match=said):
        read_sonar_bag(shared, ["/sonar"], frames=["sonar0", "sonar9"])
    with pytest.raises(InputError, match="frame sonar0 is named twice"):
        read_sonar_bag(shared, ["/sonar"], frames=["sonar0", "sonar0"])


def test_sonar_map_reads_a_ring_on_one_topic(tmp_path: Path) -> None:
    bag = _write(tmp_path, "mcap", shared="/sonar")
    base = [
        "sonar", "map", str(bag), "--angles-deg", "45,15,-15,-45", "--max-range", "5",
        "--resolution", "0.1", "--out", str(tmp_path / "out"),
    ]  # fmt: skip
    result = CliRunner().invoke(app, [*base, "--topics", "/sonar", "--frames", ",".join(FRAMES)])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "out" / "map.png").exists()
    for extra, said in [
        (["--frames", ",".join(FRAMES)], "--frames is for ROS bags: give --topics"),
        (["--topics", "/sonar", "--frames", "sonar0,sonar1"], "--frames names 2 transducers"),
        (["--topics", "/sonar", "--frames", "sonar0,sonar1,sonar0,sonar3"], "sonar0 twice"),
    ]:
        result = CliRunner().invoke(app, [*base, *extra])
        assert result.exit_code == 2, result.output
        assert said in result.output and result.output.count("\n") <= 2


ANGLES = np.radians([45.0, 15.0, -15.0, -45.0])
POSITIONS = np.array([[0.10, 0.10], [0.15, 0.05], [0.15, -0.05], [0.10, -0.10]])


def _cloud_bag(
    tmp_path: Path, kind: str, *, cloud2: bool, short_ring: int = -1, twice: int = -1
) -> Path:
    """The drive with its ring as one point cloud a message (RosAria's sonar): transducer
    k's echo at range 1 + 0.1 k along its axis; ring ``short_ring`` lost its last point,
    ring ``twice`` is recorded twice."""
    store = "ros1" if kind == "ros1" else "ros2"
    ts = get_typestore(Stores.ROS1_NOETIC if store == "ros1" else Stores.ROS2_HUMBLE)
    t = ts.types
    messages = [m for m in _messages(store) if m[0] == "/odom"]
    for i in range(RINGS):
        ns = 10**9 + i * 100_000_000
        r = 1.0 + 0.1 * np.arange(4)
        xy = POSITIONS + r[:, None] * np.stack([np.cos(ANGLES), np.sin(ANGLES)], axis=1)
        if i == short_ring:
            xy = xy[:-1]
        stamp = t["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        fields = {"stamp": stamp, "frame_id": "base_link"}
        header = t["std_msgs/msg/Header"](**({"seq": 0} if store == "ros1" else {}), **fields)
        if cloud2:
            data = np.zeros((len(xy), 4), dtype="<f4")  # x, y, z, intensity
            data[:, :2] = xy
            field_type = t["sensor_msgs/msg/PointField"]
            msg = t["sensor_msgs/msg/PointCloud2"](
                header=header, height=1, width=len(xy),
                fields=[field_type(name=n, offset=4 * k, datatype=7, count=1)
                        for k, n in enumerate(["x", "y", "z", "intensity"])],
                is_bigendian=False, point_step=16, row_step=16 * len(xy),
                data=data.view(np.uint8).reshape(-1), is_dense=True,
            )  # fmt: skip
            messages.append(("/sonar_cloud", "sensor_msgs/msg/PointCloud2", ns, msg))
        else:
            point = t["geometry_msgs/msg/Point32"]
            msg = t["sensor_msgs/msg/PointCloud"](
                header=header, points=[point(x=float(x), y=float(y), z=0.0) for x, y in xy],
                channels=[],
            )  # fmt: skip
            messages.append(("/sonar_cloud", "sensor_msgs/msg/PointCloud", ns, msg))
        if i == twice:
            messages.append(messages[-1])
    return _bag(tmp_path, kind, messages)


@pytest.mark.parametrize(("kind", "cloud2"), [("ros1", False), ("ros1", True), ("mcap", True)])
def test_a_ring_sent_as_a_point_cloud_is_read_as_ranges_from_each_transducer(
    tmp_path: Path, kind: str, cloud2: bool
) -> None:
    bag = _cloud_bag(tmp_path, kind, cloud2=cloud2, short_ring=5)
    log = read_sonar_bag(bag, ["/sonar_cloud"], positions=POSITIONS)
    assert np.allclose(log.ranges, [1.0, 1.1, 1.2, 1.3], atol=1e-6)  # float32 points
    assert [(row.line, row.reason) for row in log.skipped] == [
        (6, "ring at t=1.500 s holds 3 points, the ring 4 transducers"),
        (RINGS, log.skipped[-1].reason),  # past the last pose
    ]
    at_centre = read_sonar_bag(bag, ["/sonar_cloud"], positions=np.zeros((4, 2)))
    assert not np.allclose(at_centre.ranges, log.ranges, atol=0.05)  # the offsets matter
    with pytest.raises(InputError, match="its transducers' positions are needed"):
        read_sonar_bag(bag, ["/sonar_cloud"])


def test_sonar_map_reads_a_point_cloud_ring_with_the_ring_file(tmp_path: Path) -> None:
    bag = _cloud_bag(tmp_path, "mcap", cloud2=True)
    ring = tmp_path / "ring.yaml"
    rows = "\n".join(
        f"  - {{x: {x}, y: {y}, heading: {np.degrees(a):.1f}}}"
        for (x, y), a in zip(POSITIONS, ANGLES, strict=True)
    )
    ring.write_text(f"angle_unit: deg\nmax_range: 5.0\ntransducers:\n{rows}\n")
    args = [
        "sonar", "map", str(bag), "--topics", "/sonar_cloud", "--ring", str(ring),
        "--resolution", "0.1", "--out", str(tmp_path / "out"),
    ]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert (summary["rows"], summary["readings"]) == (RINGS, 4 * (RINGS - 1))


def test_a_ring_recorded_twice_is_read_once_and_reported(tmp_path: Path) -> None:
    bag = _cloud_bag(tmp_path, "ros1", cloud2=False, twice=3)
    log = read_sonar_bag(bag, ["/sonar_cloud"], positions=POSITIONS)
    assert log.rows == RINGS + 1 and len(log.timestamps) == RINGS - 1
    assert np.all(np.diff(log.timestamps) > 0)
    assert log.skipped[0].reason == "ring at t=1.300 s has the stamp of the ring before it"
