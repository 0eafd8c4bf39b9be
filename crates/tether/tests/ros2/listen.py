#!/usr/bin/env python3
"""A Cyclone DDS listener on the graph of `tether sim --ros2` and `tether ros2`: counts
what arrives on `cmd_vel`, `tether/people` and `scan` for a while, and the nodes in
`ros_discovery_info`, and prints them as one JSON object. Run it only in a private
network namespace (see peer.py)."""

import argparse
import json
import time

from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from peer import LaserScan, ParticipantEntitiesInfo, PoseArray, Twist, qos, valid


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, required=True)
    a = ap.parse_args()
    dp = DomainParticipant(0)
    readers = {
        "cmd_vel": DataReader(dp, Topic(dp, "rt/cmd_vel", Twist), qos=qos(True, 100)),
        "people": DataReader(
            dp, Topic(dp, "rt/tether/people", PoseArray), qos=qos(True, 100)
        ),
        "scan": DataReader(dp, Topic(dp, "rt/scan", LaserScan), qos=qos(False, 5)),
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
    end = time.monotonic() + a.seconds
    while time.monotonic() < end:
        for name, reader in readers.items():
            for s in valid(reader.take(N=1000)):
                counts[name] += 1
                if name == "cmd_vel" and s.linear.x > 0.05:
                    moving += 1
                if name == "people" and s.poses:
                    people_seen += 1
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
            }
        )
    )


if __name__ == "__main__":
    main()
