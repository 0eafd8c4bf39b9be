#!/usr/bin/env python3
"""rosbags' CDR (ROS 2 Jazzy types) of the messages cdr_oracle.rs builds, as hex, one
per line: the independent oracle for tether's codec of `geometry_msgs/msg/TwistStamped`,
`geometry_msgs/msg/PoseStamped`, `tf2_msgs/msg/TFMessage`, `visualization_msgs/msg/MarkerArray` and
`rosgraph_msgs/msg/Clock`, and `vision_msgs/msg/Detection2DArray` (vision_msgs 4.x,
registered here from its .msg files, since rosbags' stores do not carry it)."""

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ts = get_typestore(Stores.ROS2_JAZZY)
VISION_MSGS = {
    "vision_msgs/msg/Point2D": "float64 x\nfloat64 y\n",
    "vision_msgs/msg/Pose2D": "vision_msgs/Point2D position\nfloat64 theta\n",
    "vision_msgs/msg/BoundingBox2D": "vision_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y\n",
    "vision_msgs/msg/ObjectHypothesis": "string class_id\nfloat64 score\n",
    "vision_msgs/msg/ObjectHypothesisWithPose": (
        "vision_msgs/ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose\n"
    ),
    "vision_msgs/msg/Detection2D": (
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\n"
        "vision_msgs/BoundingBox2D bbox\nstring id\n"
    ),
    "vision_msgs/msg/Detection2DArray": "std_msgs/Header header\nvision_msgs/Detection2D[] detections\n",
}
for name, text in VISION_MSGS.items():
    ts.register(get_types_from_msg(text, name))
T = ts.types
Time = T["builtin_interfaces/msg/Time"]
Header = T["std_msgs/msg/Header"]
Vector3 = T["geometry_msgs/msg/Vector3"]
Quaternion = T["geometry_msgs/msg/Quaternion"]
Twist = T["geometry_msgs/msg/Twist"]
TwistStamped = T["geometry_msgs/msg/TwistStamped"]
Transform = T["geometry_msgs/msg/Transform"]
TransformStamped = T["geometry_msgs/msg/TransformStamped"]
TFMessage = T["tf2_msgs/msg/TFMessage"]
Pose = T["geometry_msgs/msg/Pose"]
Point = T["geometry_msgs/msg/Point"]
ColorRGBA = T["std_msgs/msg/ColorRGBA"]
Duration = T["builtin_interfaces/msg/Duration"]
CompressedImage = T["sensor_msgs/msg/CompressedImage"]
UVCoordinate = T["visualization_msgs/msg/UVCoordinate"]
MeshFile = T["visualization_msgs/msg/MeshFile"]
Marker = T["visualization_msgs/msg/Marker"]
MarkerArray = T["visualization_msgs/msg/MarkerArray"]
Clock = T["rosgraph_msgs/msg/Clock"]


def header(sec, nanosec, frame):
    return Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame)


twist = TwistStamped(
    header=header(1_700_000_000, 500_000_000, "base_link"),
    twist=Twist(
        linear=Vector3(x=0.25, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=-0.5)
    ),
)
tf = TFMessage(
    transforms=[
        TransformStamped(
            header=header(12, 34, "base_link"),
            child_frame_id="laser",
            transform=Transform(
                translation=Vector3(x=0.1, y=-0.02, z=0.3),
                rotation=Quaternion(x=0.0, y=0.0, z=0.25, w=0.9682458365518543),
            ),
        ),
        TransformStamped(
            header=header(0, 0, "odom"),
            child_frame_id="base_link_with_a_longer_name",
            transform=Transform(
                translation=Vector3(x=3.0, y=1.0, z=0.0),
                rotation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            ),
        ),
    ]
)
empty = TFMessage(transforms=[])


def marker(ns, id, type, frame, points, text, uv, mesh):
    return Marker(
        header=header(7, 250_000_000, frame),
        ns=ns,
        id=id,
        type=type,
        action=0,
        pose=Pose(
            position=Point(x=1.5, y=-0.5, z=0.9),
            orientation=Quaternion(x=0.0, y=0.0, z=0.25, w=0.9682458365518543),
        ),
        scale=Vector3(x=0.3, y=0.2, z=1.7),
        color=ColorRGBA(r=0.25, g=0.5, b=1.0, a=0.75),
        lifetime=Duration(sec=0, nanosec=500_000_000),
        frame_locked=False,
        points=[Point(x=p[0], y=p[1], z=p[2]) for p in points],
        colors=[ColorRGBA(r=1.0, g=0.0, b=0.0, a=1.0) for _ in points],
        texture_resource="",
        texture=CompressedImage(header=header(0, 0, ""), format="", data=np.zeros(0, np.uint8)),
        uv_coordinates=[UVCoordinate(u=u, v=v) for u, v in uv],
        text=text,
        mesh_resource="",
        mesh_file=MeshFile(filename=mesh, data=np.array([1, 2, 3], np.uint8) if mesh else np.zeros(0, np.uint8)),
        mesh_use_embedded_materials=bool(mesh),
    )


markers = MarkerArray(
    markers=[
        marker("tracks", 3, 3, "odom", [], "", [], ""),
        marker("laser", 0, 7, "odom", [(1.0, 2.0, 0.0), (3.0, -1.0, 0.5)], "#3", [(0.5, 0.25)], "m.stl"),
    ]
)
clock = Clock(clock=Time(sec=42, nanosec=7))
PoseWithCovariance = T["geometry_msgs/msg/PoseWithCovariance"]


def hypothesis(class_id, score):
    return T["vision_msgs/msg/ObjectHypothesisWithPose"](
        hypothesis=T["vision_msgs/msg/ObjectHypothesis"](class_id=class_id, score=score),
        pose=PoseWithCovariance(
            pose=Pose(
                position=Point(x=0.0, y=0.0, z=0.0),
                orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            ),
            covariance=np.zeros(36, np.float64),
        ),
    )


def detection(results, theta, id):
    return T["vision_msgs/msg/Detection2D"](
        header=header(7, 250_000_000, "camera"),
        results=results,
        bbox=T["vision_msgs/msg/BoundingBox2D"](
            center=T["vision_msgs/msg/Pose2D"](
                position=T["vision_msgs/msg/Point2D"](x=140.0, y=88.5), theta=theta
            ),
            size_x=80.0,
            size_y=96.0,
        ),
        id=id,
    )


detections = T["vision_msgs/msg/Detection2DArray"](
    header=header(7, 250_000_000, "camera"),
    detections=[
        detection([hypothesis("person", 0.9), hypothesis("chair", 0.125)], 0.0, "3"),
        detection([], 0.5, ""),
    ],
)
target_pose = T["geometry_msgs/msg/PoseStamped"](
    header=header(1_700_000_001, 250_000_000, "odom"),
    pose=Pose(
        position=Point(x=4.5, y=-1.25, z=0.0),
        orientation=Quaternion(x=0.0, y=0.0, z=-0.25, w=0.9682458365518543),
    ),
)
for msg, name in [
    (twist, "geometry_msgs/msg/TwistStamped"),
    (tf, "tf2_msgs/msg/TFMessage"),
    (empty, "tf2_msgs/msg/TFMessage"),
    (markers, "visualization_msgs/msg/MarkerArray"),
    (clock, "rosgraph_msgs/msg/Clock"),
    (detections, "vision_msgs/msg/Detection2DArray"),
    (target_pose, "geometry_msgs/msg/PoseStamped"),
]:
    print(bytes(ts.serialize_cdr(msg, name)).hex())
