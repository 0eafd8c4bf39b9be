#!/usr/bin/env python3
"""Endpoints that DDS will not connect to `tether ros2`, for it to report: a publisher
of the wrong type on `scan`, a volatile `/tf_static` publisher (tether asks transient
local), a `cmd_vel` subscriber that wants `TwistStamped` (tether publishes `Twist`) and a
`tether/people` subscriber that asks for transient local (tether offers volatile). No
data is sent. Run it only in a private network namespace (see peer.py)."""

import argparse
import time

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from peer import PoseArray, String, TFMessage, TwistStamped, qos


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, required=True)
    a = ap.parse_args()
    dp = DomainParticipant(0)
    keep = [
        DataWriter(dp, Topic(dp, "rt/scan", String), qos=qos(False, 5)),
        DataWriter(dp, Topic(dp, "rt/tf_static", TFMessage), qos=qos(True, 1)),
        DataReader(dp, Topic(dp, "rt/cmd_vel", TwistStamped), qos=qos(True, 10)),
        DataReader(
            dp,
            Topic(dp, "rt/tether/people", PoseArray),
            qos=qos(True, 10, transient_local=True),
        ),
    ]
    time.sleep(a.seconds)
    del keep


if __name__ == "__main__":
    main()
