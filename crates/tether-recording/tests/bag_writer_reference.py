#!/usr/bin/env python3
"""Reads a bag written by tether-recording's BagWriter with the `rosbags` package.

  bag_writer_reference.py BAG
      Prints one JSON object: per connection the topic, type, the MD5 sum stored and
      the one rosbags computes from the stored definition; then one entry per message
      in bag order with its topic, record time and decoded fields.

Custom types (leg_tracker/Person, leg_tracker/PersonArray) are registered from the
definitions the bag stores, as a user of rosbags would do.
"""

import json
import sys

from rosbags.rosbag1 import Reader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg


def main() -> None:
    store = get_typestore(Stores.ROS1_NOETIC)
    out = {'connections': [], 'messages': []}
    with Reader(sys.argv[1]) as reader:
        types = {}
        for c in reader.connections:
            types.update(get_types_from_msg(c.msgdef.data, c.msgtype))
        store.register(types)
        for c in reader.connections:
            _, md5 = store.generate_msgdef(c.msgtype, ros_version=1)
            out['connections'].append({
                'topic': c.topic, 'type': c.msgtype, 'md5_stored': c.digest,
                'md5_rosbags': md5,
            })
        for c, t, raw in reader.messages():
            m = store.deserialize_ros1(raw, c.msgtype)
            entry = {'topic': c.topic, 'time_ns': t}
            h = m.header
            entry['stamp_ns'] = h.stamp.sec * 1_000_000_000 + h.stamp.nanosec
            entry['frame_id'] = h.frame_id
            entry['seq'] = h.seq
            if c.msgtype.endswith('LaserScan'):
                entry['angle_min'] = float(m.angle_min)
                entry['angle_increment'] = float(m.angle_increment)
                entry['ranges'] = [float(r) if r == r and abs(r) != float('inf') else str(r)
                                   for r in m.ranges]
            elif c.msgtype.endswith('PoseArray'):
                entry['xy'] = [[p.position.x, p.position.y] for p in m.poses]
            elif c.msgtype.endswith('PersonArray'):
                entry['people'] = [[int(p.id), p.pose.position.x, p.pose.position.y,
                                    p.pose.orientation.z, p.pose.orientation.w]
                                   for p in m.people]
            elif c.msgtype.endswith('Odometry'):
                entry['child_frame_id'] = m.child_frame_id
                entry['pose'] = [m.pose.pose.position.x, m.pose.pose.position.y,
                                 m.pose.pose.orientation.z, m.pose.pose.orientation.w]
                entry['twist'] = [m.twist.twist.linear.x, m.twist.twist.angular.z]
            out['messages'].append(entry)
    json.dump(out, sys.stdout)


if __name__ == '__main__':
    main()
