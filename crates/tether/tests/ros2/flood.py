#!/usr/bin/env python3
"""A publisher that floods `tether ros2` with bad input, as fast as Python can write:
scans of NaN ranges, scans of 20,000 beams, scans whose angles contradict their
length, zero stamps, a frame nobody knows, odometry with NaN poses. It listens to
`cmd_vel` meanwhile, stops tether with SIGINT and prints one JSON object: what it sent,
the commands, tether's exit code and log. Run it only in a private network namespace
(see peer.py)."""

import argparse
import json
import math
import signal
import subprocess
import time

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from peer import (
    Header,
    LaserScan,
    Odometry,
    Time,
    Twist,
    odometry,
    qos,
    stamp_now,
    valid,
)


def scan(kind, stamp):
    n, inc, frame = 682, 0.00613592, "laser"
    ranges = [1.5] * n
    if kind == 0:
        ranges = [math.nan] * n
    elif kind == 1:
        n = 20_000
        inc = 2 * math.pi / n
        ranges = [2.0 + (i % 7) * 0.1 for i in range(n)]
    elif kind == 2:
        inc = 0.1  # 682 beams of 0.1 rad: more than a turn
    elif kind == 3:
        stamp = Time(sec=0, nanosec=0)
        frame = "a_frame_nobody_publishes"
        ranges = [math.inf if i % 2 else -1.0 for i in range(n)]
    return LaserScan(
        header=Header(stamp=stamp, frame_id=frame),
        angle_min=-2.0862,
        angle_max=-2.0862 + inc * (n - 1),
        angle_increment=inc,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.02,
        range_max=5.6,
        ranges=ranges,
        intensities=[],
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tether", required=True)
    ap.add_argument("--seconds", type=float, default=6.0)
    a = ap.parse_args()
    dp = DomainParticipant(0)
    scans = DataWriter(dp, Topic(dp, "rt/scan", LaserScan), qos=qos(False, 5))
    odom = DataWriter(dp, Topic(dp, "rt/odom", Odometry), qos=qos(False, 5))
    cmds = DataReader(dp, Topic(dp, "rt/cmd_vel", Twist), qos=qos(True, 1000))
    child = subprocess.Popen(
        [a.tether, "ros2", "--ros-args", "-p", "use_sim_time:=false"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    commands = []
    sent = {"scans": 0, "odometry": 0}
    start = time.monotonic()
    k = 0
    while time.monotonic() - start < a.seconds and child.poll() is None:
        _, stamp = stamp_now()
        scans.write(scan(k % 4, stamp))
        sent["scans"] += 1
        if k % 4 == 0:
            nan = float("nan")
            odom.write(odometry(stamp, (nan, 0.0, 0.0), (0.0, 0.0, nan, 1.0), 1e308, nan))
            sent["odometry"] += 1
        k += 1
        if k % 50 == 0:
            commands += [[c.linear.x, c.angular.z] for c in valid(cmds.take(N=1000))]
    elapsed = time.monotonic() - start
    if child.poll() is None:
        child.send_signal(signal.SIGINT)
    try:
        _, stderr = child.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        child.kill()
        _, stderr = child.communicate()
    deadline = time.monotonic() + 1.0
    while time.monotonic() < deadline:
        commands += [[c.linear.x, c.angular.z] for c in valid(cmds.take(N=1000))]
        time.sleep(0.02)
    print(
        json.dumps(
            {
                "sent": sent,
                "rate_hz": sent["scans"] / max(elapsed, 1e-9),
                "commands": len(commands),
                "moving_commands": sum(1 for v, w in commands if v != 0.0 or w != 0.0),
                "exit_code": child.returncode,
                "stderr": stderr,
            }
        )
    )


if __name__ == "__main__":
    main()
