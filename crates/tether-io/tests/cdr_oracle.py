#!/usr/bin/env python3
"""rosbags' CDR (ROS 2 Jazzy types) of the messages cdr_oracle.rs builds, as hex, one
per line: the independent oracle for tether's codec of `geometry_msgs/msg/TwistStamped`
and `tf2_msgs/msg/TFMessage`."""

from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS2_JAZZY)
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
for msg, name in [
    (twist, "geometry_msgs/msg/TwistStamped"),
    (tf, "tf2_msgs/msg/TFMessage"),
    (empty, "tf2_msgs/msg/TFMessage"),
]:
    print(bytes(ts.serialize_cdr(msg, name)).hex())
