#!/usr/bin/env python3
"""An independent ROS 2 peer for what `tether ros2` offers Nav2 and for its cmd_vel guard,
built on Eclipse Cyclone DDS (Python `cyclonedds`), with the message types of `peer.py`.

It publishes the laser's mount on `rt/tf_static`, and the scans and odometry of a ROS 1
bag on `rt/scan` and `rt/odom` at the bag's pace, starts `tether ros2`, and records, with their arrival times:
`cmd_vel` (Twist or TwistStamped), `tether/target_pose` (PoseStamped), `/tf`,
`tether/target` (PoseWithCovarianceStamped), `tether/target_state`, the nodes of
`ros_discovery_info`, and every DDS writer on the graph (the builtin publication
topic: any type on any topic). With `--signal-at S --signal KILL|STOP` it sends tether
that signal S seconds into the scans and listens on for `--after` seconds (a stopped
tether is then continued); tether still running at the end gets SIGINT. Prints what it
saw as one JSON object on stdout.

Run it only in a private network namespace with only loopback up (DDS discovery
multicasts), e.g. `unshare -n sh -c 'ip link set lo up && python3 nav2_peer.py ...'`.
"""

import argparse
import json
import math
import os
import signal
import subprocess
import time
from dataclasses import dataclass

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.core import Listener
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from peer import (
    Header,
    LaserScan,
    Odometry,
    ParticipantEntitiesInfo,
    Pose,
    String,
    TFMessage,
    Twist,
    TwistStamped,
    bag_messages,
    qos,
    recorded_odometry,
    recorded_scan,
    stamp_now,
    transform,
    valid,
)


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header
    pose: Pose


@dataclass
class PoseWithCovarianceStamped(
    IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"
):
    header: Header
    pose: Pose
    covariance: array[float64, 36]


def ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def yaw(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def pose_row(arrival, header, pose):
    """[arrival, stamp ns, frame, x, y, z, yaw] of a pose in `header.frame_id`."""
    p = pose.position
    return [arrival, ns(header.stamp), header.frame_id, p.x, p.y, p.z, yaw(pose.orientation)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tether", required=True, help="the tether binary")
    ap.add_argument("--bag", required=True, help="a ROS 1 bag with the scans on /scan")
    ap.add_argument("--mount", nargs=4, type=float, required=True, metavar=("X", "Y", "YAW", "Z"))
    ap.add_argument("--seconds", type=float, default=15.0, help="of scans to publish")
    ap.add_argument("--stamped", action="store_true", help="cmd_vel is TwistStamped")
    ap.add_argument("--signal-at", type=float, metavar="S", help="signal tether S s into the scans")
    ap.add_argument("--signal", choices=["KILL", "STOP"], default="KILL")
    ap.add_argument("--after", type=float, default=1.5, help="listen this long after the signal")
    ap.add_argument("tether_args", nargs="*", help="more arguments for tether ros2")
    a = ap.parse_args()

    dp = DomainParticipant(0)
    scan_writer = DataWriter(dp, Topic(dp, "rt/scan", LaserScan), qos=qos(False, 5))
    odom_writer = DataWriter(dp, Topic(dp, "rt/odom", Odometry), qos=qos(False, 5))
    x, y, yaw0, z = a.mount
    tf_static = DataWriter(
        dp, Topic(dp, "rt/tf_static", TFMessage), qos=qos(True, 1, transient_local=True)
    )
    _, stamp = stamp_now()
    tf_static.write(
        transform(stamp, "base_link", "laser", (x, y, z), (0.0, 0.0, math.sin(yaw0 / 2), math.cos(yaw0 / 2)))
    )

    cmds = []

    class CmdListener(Listener):
        """Takes the commands on Cyclone's thread, at their arrival."""

        def on_data_available(self, reader):
            now = time.monotonic()
            for s in valid(reader.take(N=1000)):
                t = s.twist if a.stamped else s
                cmds.append([now, t.linear.x, t.angular.z])

    # Kept in a name: a reader nobody holds is collected, and hears nothing.
    cmd_reader = DataReader(
        dp,
        Topic(dp, "rt/cmd_vel", TwistStamped if a.stamped else Twist),
        qos=qos(True, 1000),
        listener=CmdListener(),
    )
    readers = {
        "target_pose": DataReader(
            dp, Topic(dp, "rt/tether/target_pose", PoseStamped), qos=qos(True, 1000)
        ),
        "target": DataReader(
            dp, Topic(dp, "rt/tether/target", PoseWithCovarianceStamped), qos=qos(True, 1000)
        ),
        "tf": DataReader(dp, Topic(dp, "rt/tf", TFMessage), qos=qos(True, 1000)),
        "target_state": DataReader(
            dp, Topic(dp, "rt/tether/target_state", String), qos=qos(True, 1000)
        ),
        "nodes": DataReader(
            dp,
            Topic(dp, "ros_discovery_info", ParticipantEntitiesInfo),
            qos=qos(True, 100, transient_local=True),
        ),
    }
    writers_reader = BuiltinDataReader(dp, BuiltinTopicDcpsPublication)
    seen = {"target_pose": [], "target": [], "tf": [], "target_state": []}
    nodes, writers = set(), set()

    def drain():
        now = time.monotonic()
        for s in valid(readers["target_pose"].take(N=1000)):
            seen["target_pose"].append(pose_row(now, s.header, s.pose))
        for s in valid(readers["target"].take(N=1000)):
            seen["target"].append(pose_row(now, s.header, s.pose))
        for s in valid(readers["tf"].take(N=1000)):
            for t in s.transforms:
                v, q = t.transform.translation, t.transform.rotation
                seen["tf"].append(
                    [now, ns(t.header.stamp), t.header.frame_id, t.child_frame_id, v.x, v.y, v.z, yaw(q)]
                )
        for s in valid(readers["target_state"].take(N=1000)):
            seen["target_state"].append([now, s.data])
        for s in valid(readers["nodes"].take(N=100)):
            for n in s.node_entities_info_seq:
                nodes.add((n.node_namespace, n.node_name))
        for s in valid(writers_reader.take(N=1000)):
            writers.add((s.topic_name or "", s.type_name or ""))

    child = subprocess.Popen(
        [a.tether, "ros2", *a.tether_args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ),
    )
    started = time.monotonic()
    while time.monotonic() - started < 10.0 and child.poll() is None:
        if scan_writer.get_matched_subscriptions():
            break
        time.sleep(0.05)

    signalled_at, continued_at, scans_sent, first_t = None, None, 0, None
    wall0 = time.monotonic()
    for topic, t_ns, m in bag_messages(a.bag, ["/scan", "/odom"]):
        if child.poll() is not None:
            break
        first_t = t_ns if first_t is None else first_t
        offset = (t_ns - first_t) * 1e-9
        if offset > a.seconds:
            break
        while time.monotonic() - wall0 < offset:
            drain()
            time.sleep(0.002)
        if a.signal_at is not None and signalled_at is None and offset >= a.signal_at:
            os.kill(child.pid, signal.SIGKILL if a.signal == "KILL" else signal.SIGSTOP)
            signalled_at = time.monotonic()
            break
        _, stamp = stamp_now()
        if topic == "/odom":
            odom_writer.write(recorded_odometry(m, stamp))
            continue
        scan_writer.write(recorded_scan(m, stamp))
        scans_sent += 1
        drain()

    if signalled_at is not None:
        while time.monotonic() - signalled_at < a.after:
            drain()
            time.sleep(0.01)
        if a.signal == "STOP":
            os.kill(child.pid, signal.SIGCONT)
            continued_at = time.monotonic()
    drain()
    interrupted_at = time.monotonic()
    if child.poll() is None:
        child.send_signal(signal.SIGINT)
    try:
        # Waits for the guard too: it holds tether's stderr until it exits.
        _, stderr = child.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        child.kill()
        _, stderr = child.communicate()
    exited_at = time.monotonic()
    deadline = time.monotonic() + 1.0
    while time.monotonic() < deadline:
        drain()
        time.sleep(0.02)
    del cmd_reader
    print(
        json.dumps(
            {
                "scans_sent": scans_sent,
                "cmd_vel": cmds,
                **seen,
                "nodes": sorted(nodes),
                "writers": sorted(writers),
                "signalled_at": signalled_at,
                "continued_at": continued_at,
                "interrupted_at": interrupted_at,
                "exited_at": exited_at,
                "exit_code": child.returncode,
                "stderr": stderr,
            }
        )
    )


if __name__ == "__main__":
    main()
