#!/usr/bin/env python3
"""A Cyclone DDS listener on the graph of `tether sim --ros2` and `tether ros2`: counts
what arrives on `cmd_vel`, `tether/people`, `scan` and the simulated camera's
`detections` for a while, and the nodes in
`ros_discovery_info`, and prints them as one JSON object. Run it only in a private
network namespace (see peer.py)."""

import argparse
import json
import time

from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from peer import Clock, Detection2DArray, LaserScan, MarkerArray, ParticipantEntitiesInfo, PoseArray, TFMessage, Twist, TwistStamped, qos, valid


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, required=True)
    ap.add_argument(
        "--tf-static-after",
        type=float,
        default=5.0,
        help="join /tf_static this late (transient local: the mounts must still come)",
    )
    ap.add_argument(
        "--cmd-vel-stamped",
        action="store_true",
        help="cmd_vel is geometry_msgs/msg/TwistStamped",
    )
    a = ap.parse_args()
    dp = DomainParticipant(0)
    cmd_type = TwistStamped if a.cmd_vel_stamped else Twist
    readers = {
        "cmd_vel": DataReader(dp, Topic(dp, "rt/cmd_vel", cmd_type), qos=qos(True, 100)),
        "people": DataReader(
            dp, Topic(dp, "rt/tether/people", PoseArray), qos=qos(True, 100)
        ),
        "scan": DataReader(dp, Topic(dp, "rt/scan", LaserScan), qos=qos(False, 5)),
        "clock": DataReader(dp, Topic(dp, "rt/clock", Clock), qos=qos(False, 1)),
        "markers": DataReader(
            dp, Topic(dp, "rt/tether/markers", MarkerArray), qos=qos(True, 100)
        ),
        "detections": DataReader(
            dp, Topic(dp, "rt/detections", Detection2DArray), qos=qos(False, 5)
        ),
        "detections_truth": DataReader(
            dp, Topic(dp, "rt/sim/detections_truth", Detection2DArray), qos=qos(False, 5)
        ),
        "vision_people": DataReader(
            dp, Topic(dp, "rt/tether/vision_people", PoseArray), qos=qos(True, 100)
        ),
    }
    discovery = DataReader(
        dp,
        Topic(dp, "ros_discovery_info", ParticipantEntitiesInfo),
        qos=qos(True, 100, transient_local=True),
    )
    counts = {k: 0 for k in readers}
    moving = 0
    people_seen = 0
    nodes = set()
    # Namespaces of the markers seen, and the labels of the target's track.
    marker_namespaces = set()
    # The newest /clock and the newest stamp on tether/people, ns.
    clock_ns = None
    people_stamp_ns = None
    target_labels = set()
    # The simulated camera's boxes: how many, whether each is a person with a positive
    # size, and the person ids of the ground truth.
    boxes = 0
    bad_boxes = 0
    truth_ids = set()
    vision_people_seen = 0
    # Where tether put the people of the camera frames (its fixed frame), [x, y].
    vision_positions = []
    start = time.monotonic()
    end = start + a.seconds
    tf_static = None
    mounts = []
    while time.monotonic() < end:
        if tf_static is None and time.monotonic() - start >= a.tf_static_after:
            tf_static = DataReader(
                dp,
                Topic(dp, "rt/tf_static", TFMessage),
                qos=qos(True, 100, transient_local=True),
            )
        if tf_static is not None:
            for s in valid(tf_static.take(N=100)):
                for t in s.transforms:
                    v = t.transform.translation
                    mounts.append([t.header.frame_id, t.child_frame_id, v.x, v.y, v.z])
        for name, reader in readers.items():
            for s in valid(reader.take(N=1000)):
                counts[name] += 1
                if name == "cmd_vel" and (s.twist if a.cmd_vel_stamped else s).linear.x > 0.05:
                    moving += 1
                if name == "people" and s.poses:
                    people_seen += 1
                if name == "people":
                    t = s.header.stamp.sec * 1_000_000_000 + s.header.stamp.nanosec
                    people_stamp_ns = max(t, people_stamp_ns or t)
                if name == "clock":
                    t = s.clock.sec * 1_000_000_000 + s.clock.nanosec
                    clock_ns = max(t, clock_ns or t)
                if name in ("detections", "detections_truth"):
                    for d in s.detections:
                        ok = (
                            d.bbox.size_x > 0
                            and d.bbox.size_y > 0
                            and [r.hypothesis.class_id for r in d.results] == ["person"]
                        )
                        bad_boxes += not ok
                        if name == "detections":
                            boxes += 1
                        else:
                            truth_ids.add(d.id)
                if name == "vision_people" and s.poses:
                    vision_people_seen += 1
                    for p in s.poses:
                        vision_positions.append([p.position.x, p.position.y])
                if name == "markers":
                    for m in s.markers:
                        marker_namespaces.add(m.ns)
                        if m.ns == "track_labels" and m.text.endswith("target"):
                            target_labels.add(m.text)
        for s in valid(discovery.take(N=100)):
            for n in s.node_entities_info_seq:
                nodes.add((n.node_namespace, n.node_name))
        time.sleep(0.01)
    print(
        json.dumps(
            {
                "counts": counts,
                "cmd_vel_moving": moving,
                "people_with_someone": people_seen,
                "nodes": sorted(nodes),
                "marker_namespaces": sorted(marker_namespaces),
                "clock_ns": clock_ns,
                "people_stamp_ns": people_stamp_ns,
                "target_labels": sorted(target_labels),
                "tf_static": mounts,
                "boxes": boxes,
                "bad_boxes": bad_boxes,
                "truth_ids": sorted(truth_ids),
                "vision_people_with_someone": vision_people_seen,
                "vision_positions": vision_positions,
            }
        )
    )


if __name__ == "__main__":
    main()
