#!/usr/bin/env python3
"""An independent ROS 2 peer for `tether ros2`, built on Eclipse Cyclone DDS (Python
`cyclonedds`), the middleware ROS 2 ships by default in several distributions.

It starts `tether ros2` as a child process, publishes the scans of a ROS 1 bag on
`rt/scan` as `sensor_msgs/msg/LaserScan` (plain CDR, XCDR1, as ROS 2 sends it), and
optionally its odometry on `rt/odom` as `nav_msgs/msg/Odometry`, stamped now, at the
bag's own pace; listens to `cmd_vel`, `tether/target_state`, `tether/people`
and `ros_discovery_info`; then interrupts tether (SIGINT or SIGTERM) and prints what it
saw as one JSON object on stdout.

Run it only in a private network namespace with only loopback up (DDS discovery
multicasts), e.g. `unshare -n sh -c 'ip link set lo up && python3 peer.py ...'`.
"""

import argparse
import json
import math
import os
import signal
import struct
import subprocess
import sys
import time
from dataclasses import dataclass, field

from cyclonedds.core import Listener, Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int32, sequence, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader, InvalidSample
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from rosbags.rosbag1 import Reader
from rosbags.typesys import Stores, get_typestore


# The ROS 2 messages as IDL, named as rosidl names them on DDS (one declaration a type:
# alike in shape, they stay apart because each is its own message).
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class LaserScan(IdlStruct, typename="sensor_msgs::msg::dds_::LaserScan_"):
    header: Header
    angle_min: float32
    angle_max: float32
    angle_increment: float32
    time_increment: float32
    scan_time: float32
    range_min: float32
    range_max: float32
    ranges: sequence[float32]
    intensities: sequence[float32]


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3


@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header
    twist: Twist


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion


@dataclass
class PoseArray(IdlStruct, typename="geometry_msgs::msg::dds_::PoseArray_"):
    header: Header
    poses: sequence[Pose]


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header
    pose: Pose


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose
    covariance: array[float64, 36]


@dataclass
class TwistWithCovariance(
    IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"
):
    twist: Twist
    covariance: array[float64, 36]


@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
class Image(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header
    height: uint32
    width: uint32
    encoding: str
    is_bigendian: uint8
    step: uint32
    data: sequence[uint8]


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


@dataclass
class CompressedImage(IdlStruct, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    header: Header
    format: str
    data: sequence[uint8]


@dataclass
class ColorRGBA(IdlStruct, typename="std_msgs::msg::dds_::ColorRGBA_"):
    r: float32
    g: float32
    b: float32
    a: float32


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: int32
    nanosec: uint32


@dataclass
class UVCoordinate(IdlStruct, typename="visualization_msgs::msg::dds_::UVCoordinate_"):
    u: float32
    v: float32


@dataclass
class MeshFile(IdlStruct, typename="visualization_msgs::msg::dds_::MeshFile_"):
    filename: str
    data: sequence[uint8]


@dataclass
class Marker(IdlStruct, typename="visualization_msgs::msg::dds_::Marker_"):
    header: Header
    ns: str
    id: int32
    type: int32
    action: int32
    pose: Pose
    scale: Vector3
    color: ColorRGBA
    lifetime: Duration
    frame_locked: bool
    points: sequence[Point]
    colors: sequence[ColorRGBA]
    texture_resource: str
    texture: CompressedImage
    uv_coordinates: sequence[UVCoordinate]
    text: str
    mesh_resource: str
    mesh_file: MeshFile
    mesh_use_embedded_materials: bool


@dataclass
class MarkerArray(IdlStruct, typename="visualization_msgs::msg::dds_::MarkerArray_"):
    markers: sequence[Marker]


@dataclass
class Clock(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time


@dataclass
class Point2D(IdlStruct, typename="vision_msgs::msg::dds_::Point2D_"):
    x: float64
    y: float64


@dataclass
class Pose2D(IdlStruct, typename="vision_msgs::msg::dds_::Pose2D_"):
    position: Point2D
    theta: float64


@dataclass
class BoundingBox2D(IdlStruct, typename="vision_msgs::msg::dds_::BoundingBox2D_"):
    center: Pose2D
    size_x: float64
    size_y: float64


@dataclass
class ObjectHypothesis(IdlStruct, typename="vision_msgs::msg::dds_::ObjectHypothesis_"):
    class_id: str
    score: float64


@dataclass
class ObjectHypothesisWithPose(
    IdlStruct, typename="vision_msgs::msg::dds_::ObjectHypothesisWithPose_"
):
    hypothesis: ObjectHypothesis
    pose: PoseWithCovariance


@dataclass
class Detection2D(IdlStruct, typename="vision_msgs::msg::dds_::Detection2D_"):
    header: Header
    results: sequence[ObjectHypothesisWithPose]
    bbox: BoundingBox2D
    id: str


@dataclass
class Detection2DArray(IdlStruct, typename="vision_msgs::msg::dds_::Detection2DArray_"):
    header: Header
    detections: sequence[Detection2D]


@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: array[uint8, 16]


@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: str
    node_name: str
    reader_gid_seq: sequence[Gid]
    writer_gid_seq: sequence[Gid]


@dataclass
class ParticipantEntitiesInfo(
    IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"
):
    gid: Gid
    node_entities_info_seq: sequence[NodeEntitiesInfo]


# Before Iron (Humble), rmw_dds_common's Gid held 24 bytes: the same type name, another
# layout. A reader of one layout cannot read the other's participants.
@dataclass
class GidHumble(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: array[uint8, 24]


@dataclass
class NodeEntitiesInfoHumble(
    IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"
):
    node_namespace: str
    node_name: str
    reader_gid_seq: sequence[GidHumble]
    writer_gid_seq: sequence[GidHumble]


@dataclass
class ParticipantEntitiesInfoHumble(
    IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"
):
    gid: GidHumble
    node_entities_info_seq: sequence[NodeEntitiesInfoHumble]


XCDR1 = Policy.DataRepresentation(use_cdrv0_representation=True)


def qos(reliable, depth, transient_local=False):
    policies = [
        XCDR1,
        Policy.History.KeepLast(depth),
        Policy.Reliability.Reliable(duration(seconds=1))
        if reliable
        else Policy.Reliability.BestEffort,
    ]
    if transient_local:
        policies.append(Policy.Durability.TransientLocal)
    return Qos(*policies)


def valid(samples):
    """The samples that carry data (not the notices of a writer that went away)."""
    return [s for s in samples if not isinstance(s, InvalidSample)]


def bag_messages(path, topics):
    store = get_typestore(Stores.ROS1_NOETIC)
    with Reader(path) as reader:
        conns = [c for c in reader.connections if c.topic in topics]
        if not any(c.topic == topics[0] for c in conns):
            sys.exit(f"peer: {path} has no topic {topics[0]}")
        for conn, t_ns, raw in reader.messages(connections=conns):
            yield conn.topic, t_ns, store.deserialize_ros1(raw, conn.msgtype)


def stamp_now():
    now = time.time_ns()
    return now, Time(sec=now // 1_000_000_000, nanosec=now % 1_000_000_000)


def recorded_odometry(m, stamp):
    """A recorded nav_msgs/Odometry `m` (rosbags) as published now, stamped `stamp`."""
    p, q = m.pose.pose.position, m.pose.pose.orientation
    return odometry(
        stamp,
        (p.x, p.y, p.z),
        (q.x, q.y, q.z, q.w),
        m.twist.twist.linear.x,
        m.twist.twist.angular.z,
    )


def recorded_scan(m, stamp):
    """A recorded sensor_msgs/LaserScan `m` (rosbags) as published now, stamped `stamp`."""
    return LaserScan(
        header=Header(stamp=stamp, frame_id=m.header.frame_id),
        angle_min=m.angle_min,
        angle_max=m.angle_max,
        angle_increment=m.angle_increment,
        time_increment=m.time_increment,
        scan_time=m.scan_time,
        range_min=m.range_min,
        range_max=m.range_max,
        ranges=[float(r) for r in m.ranges],
        intensities=[],
    )


def odometry(stamp, position, orientation, v_x, w_z):
    """nav_msgs/Odometry of base_link in odom: the pose at `position` (x, y, z) turned by
    `orientation` (x, y, z, w), moving at `v_x` along x and turning at `w_z` about z,
    with zero covariances."""
    return Odometry(
        header=Header(stamp=stamp, frame_id="odom"),
        child_frame_id="base_link",
        pose=PoseWithCovariance(
            pose=Pose(
                position=Point(x=position[0], y=position[1], z=position[2]),
                orientation=Quaternion(
                    x=orientation[0], y=orientation[1], z=orientation[2], w=orientation[3]
                ),
            ),
            covariance=[0.0] * 36,
        ),
        twist=TwistWithCovariance(
            twist=Twist(
                linear=Vector3(x=v_x, y=0.0, z=0.0),
                angular=Vector3(x=0.0, y=0.0, z=w_z),
            ),
            covariance=[0.0] * 36,
        ),
    )


def transform(stamp, parent, child, translation, rotation):
    """tf2_msgs/TFMessage with the one transform `parent` -> `child`: `translation`
    (x, y, z) and `rotation` (x, y, z, w)."""
    return transforms(stamp, parent, [(child, translation, rotation)])


def transforms(stamp, parent, children):
    """tf2_msgs/TFMessage with a transform `parent` -> each of `children`, given as
    (child, translation (x, y, z), rotation (x, y, z, w))."""
    return TFMessage(
        transforms=[
            TransformStamped(
                header=Header(stamp=stamp, frame_id=parent),
                child_frame_id=child,
                transform=Transform(
                    translation=Vector3(x=translation[0], y=translation[1], z=translation[2]),
                    rotation=Quaternion(
                        x=rotation[0], y=rotation[1], z=rotation[2], w=rotation[3]
                    ),
                ),
            )
            for child, translation, rotation in children
        ]
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tether", required=True, help="the tether binary")
    ap.add_argument("--bag", required=True, help="a ROS 1 bag with the scans")
    ap.add_argument("--scan-topic", default="/scan")
    ap.add_argument(
        "--extra-scan",
        action="append",
        default=[],
        metavar="TOPIC",
        help="also publish this bag topic's scans, on the topic of the same name (another "
        "scanner: tether -p extra_scan_topics)",
    )
    ap.add_argument(
        "--extra-mount",
        action="append",
        default=[],
        nargs=5,
        metavar=("FRAME", "X", "Y", "YAW", "Z"),
        help="with --mount: also publish base_link -> FRAME on rt/tf_static",
    )
    ap.add_argument(
        "--odom-topic", help="also publish this bag topic's odometry on rt/odom"
    )
    ap.add_argument("--reliable", action="store_true", help="publish scans reliably")
    ap.add_argument("--seconds", type=float, default=20.0, help="of scans to publish")
    ap.add_argument("--signal", choices=["INT", "TERM"], default="INT")
    ap.add_argument(
        "--mount",
        nargs=4,
        type=float,
        metavar=("X", "Y", "YAW", "Z"),
        help="publish base_link -> the scans' frame on rt/tf_static before tether starts "
        "(reliable, transient local: tether joins late and must still get it)",
    )
    ap.add_argument(
        "--images-hz",
        type=float,
        default=0.0,
        help="also publish 640x480 rgb8 frames on rt/image_raw at this rate",
    )
    ap.add_argument(
        "--compressed",
        action="store_true",
        help="publish the frames as JPEG sensor_msgs/CompressedImage on "
        "rt/image_raw/compressed instead (encoded with OpenCV)",
    )
    ap.add_argument(
        "--extra-camera",
        metavar="FRAME",
        help="with --images-hz: also publish each frame on rt/FRAME/image_raw (or "
        "FRAME/image_raw/compressed), its header naming FRAME (another camera: tether -p "
        "extra_camera_topics)",
    )
    ap.add_argument(
        "--stamped",
        action="store_true",
        help="cmd_vel is TwistStamped (tether -p cmd_vel_stamped:=true): measure the "
        "latency from each scan to the command it caused",
    )
    ap.add_argument(
        "--read-tf-static",
        type=float,
        metavar="S",
        help="join rt/tf_static (transient local) S seconds into the scans and report "
        "the transforms received",
    )
    ap.add_argument(
        "--ns",
        default="",
        help="the namespace tether runs in (its -r __ns:=NS): every topic is NS/topic",
    )
    ap.add_argument(
        "--scan-name",
        default="scan",
        help="publish the scans on this topic (tether remaps its scan to it)",
    )
    ap.add_argument(
        "--domain",
        type=int,
        default=0,
        help="the DDS domain of the peer and of tether (ROS_DOMAIN_ID in its environment)",
    )
    ap.add_argument(
        "--odom-as-tf",
        action="store_true",
        help="publish the odometry as the transform odom -> base_link on rt/tf instead "
        "of on rt/odom (as a diff-drive controller does)",
    )
    ap.add_argument(
        "--odom-until",
        type=float,
        metavar="S",
        help="stop publishing the odometry S seconds into the scans",
    )
    ap.add_argument(
        "--humble",
        action="store_true",
        help="read ros_discovery_info as a Humble graph writes it (24-byte gids), as "
        "tether built with `--features humble` must",
    )
    ap.add_argument("tether_args", nargs="*", help="more arguments for tether ros2")
    a = ap.parse_args()

    def rt(name):
        return "rt" + a.ns + "/" + name

    dp = DomainParticipant(a.domain)
    scan_writer = DataWriter(
        dp, Topic(dp, rt(a.scan_name), LaserScan), qos=qos(a.reliable, 5)
    )
    extra_writers = {
        topic: DataWriter(
            dp, Topic(dp, rt(topic.strip("/")), LaserScan), qos=qos(a.reliable, 5)
        )
        for topic in a.extra_scan
    }
    odom_writer = DataWriter(dp, Topic(dp, rt("odom"), Odometry), qos=qos(False, 5))
    tf_writer_dyn = (
        DataWriter(dp, Topic(dp, rt("tf"), TFMessage), qos=qos(True, 100))
        if a.odom_as_tf
        else None
    )
    if a.compressed:
        image_writer = DataWriter(
            dp,
            Topic(dp, rt("image_raw/compressed"), CompressedImage),
            qos=qos(True, 5),
        )
    else:
        image_writer = DataWriter(
            dp, Topic(dp, rt("image_raw"), Image), qos=qos(True, 5)
        )
    # A grey gradient, the same every frame (the detector finds nobody in it). Cyclone's
    # Python serialiser takes ~40 ms for 0.9 MB, too slow for 30 Hz: the frame is
    # serialised by it once, and each frame only gets its stamp written into the bytes
    # (after the 4-byte encapsulation header: sec, nanosec, little-endian).
    frame = Image(
        header=Header(stamp=Time(sec=0, nanosec=0), frame_id="camera"),
        height=480,
        width=640,
        encoding="rgb8",
        is_bigendian=0,
        step=640 * 3,
        data=bytes((x // 3) % 256 for x in range(640 * 3)) * 480,
    )
    if a.compressed:
        import cv2
        import numpy

        rgb = numpy.frombuffer(frame.data, dtype=numpy.uint8).reshape(480, 640, 3)
        ok, jpeg = cv2.imencode(".jpg", rgb[:, :, ::-1])
        assert ok
        frame = CompressedImage(
            header=Header(stamp=Time(sec=0, nanosec=0), frame_id="camera"),
            format="jpeg",
            data=jpeg.tobytes(),
        )
    frame_bytes = bytearray(frame.serialize(use_version_2=False))
    # The other camera's frame: the same picture, its header naming its camera.
    extra_image_writer, extra_bytes = None, None
    if a.extra_camera:
        suffix = "image_raw/compressed" if a.compressed else "image_raw"
        extra_image_writer = DataWriter(
            dp,
            Topic(dp, rt(a.extra_camera + "/" + suffix), type(frame)),
            qos=qos(True, 5),
        )
        frame.header.frame_id = a.extra_camera
        extra_bytes = bytearray(frame.serialize(use_version_2=False))
        frame.header.frame_id = "camera"
    cmd_type = TwistStamped if a.stamped else Twist
    cmds = []

    class CmdListener(Listener):
        """Takes the commands as they arrive (on Cyclone's thread), so that their
        arrival times are not those of a polling loop."""

        def on_data_available(self, reader):
            now = time.monotonic()
            for s in valid(reader.take(N=1000)):
                if a.stamped:
                    stamp = s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec
                    cmds.append([now, s.twist.linear.x, s.twist.angular.z, stamp])
                else:
                    cmds.append([now, s.linear.x, s.angular.z])

    cmd_reader = DataReader(
        dp,
        Topic(dp, rt("cmd_vel"), cmd_type),
        qos=qos(True, 1000),
        listener=CmdListener(),
    )
    state_reader = DataReader(
        dp, Topic(dp, rt("tether/target_state"), String), qos=qos(True, 1000)
    )
    people_reader = DataReader(
        dp, Topic(dp, rt("tether/people"), PoseArray), qos=qos(True, 1000)
    )
    target_pose_reader = DataReader(
        dp, Topic(dp, rt("tether/target_pose"), PoseStamped), qos=qos(True, 1000)
    )
    discovery_reader = DataReader(
        dp,
        Topic(
            dp,
            "ros_discovery_info",
            ParticipantEntitiesInfoHumble if a.humble else ParticipantEntitiesInfo,
        ),
        qos=qos(True, 100, transient_local=True),
    )

    if a.mount:
        mounts = [("laser", *a.mount)] + [
            (m[0], *(float(v) for v in m[1:])) for m in a.extra_mount
        ]
        tf_writer = DataWriter(
            dp,
            Topic(dp, rt("tf_static"), TFMessage),
            qos=qos(True, 1, transient_local=True),
        )
        _, stamp = stamp_now()
        # One message: a latched topic keeps the last one alone.
        tf_writer.write(
            transforms(
                stamp,
                "base_link",
                [
                    (
                        frame,
                        (x, y, z),
                        (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)),
                    )
                    for frame, x, y, yaw, z in mounts
                ],
            )
        )

    env = dict(os.environ)
    if a.domain:
        env["ROS_DOMAIN_ID"] = str(a.domain)
    child = subprocess.Popen(
        [a.tether, "ros2", *a.tether_args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    # Wait until tether's scan reader has matched ours (up to 10 s).
    started = time.monotonic()
    while time.monotonic() - started < 10.0:
        if all(
            w.get_matched_subscriptions()
            for w in [scan_writer, *extra_writers.values()]
        ):
            break
        if child.poll() is not None:
            break
        time.sleep(0.05)
    matched_after_s = time.monotonic() - started

    states, people, target_poses = [], [], []
    nodes = set()
    tf_static_reader = None
    tf_static_seen = []

    def drain():
        if tf_static_reader is not None:
            for s in valid(tf_static_reader.take(N=100)):
                for t in s.transforms:
                    v = t.transform.translation
                    tf_static_seen.append(
                        [t.header.frame_id, t.child_frame_id, v.x, v.y, v.z]
                    )
        for s in valid(state_reader.take(N=1000)):
            states.append([time.monotonic(), s.data])
        for s in valid(people_reader.take(N=1000)):
            people.append([time.monotonic(), len(s.poses), s.header.frame_id])
        for s in valid(target_pose_reader.take(N=1000)):
            stamp = s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec
            target_poses.append([stamp, s.pose.position.x, s.pose.position.y])
        for s in valid(discovery_reader.take(N=100)):
            for n in s.node_entities_info_seq:
                nodes.add((n.node_namespace, n.node_name))

    scans_sent = 0
    written = {}  # scan stamp (ns) -> when it was written (monotonic s)
    first_t = None
    wall0 = time.monotonic()
    topics = [a.scan_topic, *a.extra_scan] + ([a.odom_topic] if a.odom_topic else [])
    extra_sent = {topic: 0 for topic in a.extra_scan}
    # Each scan's stamp as published, with its time in the bag.
    scan_stamps = []
    odom_sent = 0
    images_sent = 0
    next_image = 0.0

    def maybe_image(elapsed):
        nonlocal images_sent, next_image
        if a.images_hz <= 0 or elapsed < next_image:
            return
        next_image += 1.0 / a.images_hz
        now, _ = stamp_now()
        frame_bytes[4:12] = struct.pack(
            "<iI", now // 1_000_000_000, now % 1_000_000_000
        )
        payload = bytes(frame_bytes)
        frame.serialize = lambda **_: payload
        image_writer.write(frame)
        images_sent += 1
        if extra_image_writer is not None:
            extra_bytes[4:12] = frame_bytes[4:12]
            extra_payload = bytes(extra_bytes)
            frame.serialize = lambda **_: extra_payload
            extra_image_writer.write(frame)

    for topic, t_ns, m in bag_messages(a.bag, topics):
        if child.poll() is not None:
            break
        if first_t is None:
            first_t = t_ns
        offset = (t_ns - first_t) * 1e-9
        if offset > a.seconds:
            break
        if (
            a.read_tf_static is not None
            and tf_static_reader is None
            and offset >= a.read_tf_static
        ):
            tf_static_reader = DataReader(
                dp,
                Topic(dp, rt("tf_static"), TFMessage),
                qos=qos(True, 100, transient_local=True),
            )
        while time.monotonic() - wall0 < offset:
            maybe_image(time.monotonic() - wall0)
            drain()
            time.sleep(0.002)
        now, stamp = stamp_now()
        if topic in extra_writers:
            extra_writers[topic].write(recorded_scan(m, stamp))
            extra_sent[topic] += 1
            scan_stamps.append([now, t_ns])
            drain()
            continue
        if topic != a.scan_topic:
            if a.odom_until is not None and offset > a.odom_until:
                continue
            p, q = m.pose.pose.position, m.pose.pose.orientation
            if tf_writer_dyn is not None:
                tf_writer_dyn.write(
                    transform(
                        stamp, "odom", "base_link", (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)
                    )
                )
                odom_sent += 1
                continue
            odom_writer.write(recorded_odometry(m, stamp))
            odom_sent += 1
            continue
        written[now] = time.monotonic()
        scan_stamps.append([now, t_ns])
        scan_writer.write(recorded_scan(m, stamp))
        scans_sent += 1
        drain()

    drain()
    interrupted_at = time.monotonic()
    if child.poll() is None:
        child.send_signal(signal.SIGINT if a.signal == "INT" else signal.SIGTERM)
    try:
        _, stderr = child.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        child.kill()
        _, stderr = child.communicate()
    exited_at = time.monotonic()
    # What was on its way when tether went.
    deadline = time.monotonic() + 1.0
    while time.monotonic() < deadline:
        drain()
        time.sleep(0.02)

    # A scan's command carries the scan's stamp; timer ticks carry others.
    latencies_ms = sorted(
        (c[0] - written[c[3]]) * 1e3 for c in cmds if len(c) > 3 and c[3] in written
    )

    def quantile(q):
        if not latencies_ms:
            return None
        return latencies_ms[min(len(latencies_ms) - 1, int(q * len(latencies_ms)))]

    print(
        json.dumps(
            {
                "latency_ms": {
                    "scans_matched": len(latencies_ms),
                    "median": quantile(0.5),
                    "p99": quantile(0.99),
                    "max": latencies_ms[-1] if latencies_ms else None,
                },
                "matched_after_s": matched_after_s,
                "scans_sent": scans_sent,
                "extra_scans_sent": extra_sent,
                "scan_stamps": scan_stamps,
                "target_pose": target_poses,
                "odom_sent": odom_sent,
                "images_sent": images_sent,
                "cmd_vel": cmds,
                "target_state": states,
                "people": people,
                "nodes": sorted(nodes),
                "tf_static": tf_static_seen,
                "interrupted_at": interrupted_at,
                "exited_at": exited_at,
                "exit_code": child.returncode,
                "stderr": stderr,
            }
        )
    )


if __name__ == "__main__":
    main()
