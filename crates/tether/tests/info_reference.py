#!/usr/bin/env python3
"""What Python's readers say a recording holds, for `tests/info.rs` to compare with
`tether info --json`.

  info_reference.py bag FILE.bag
      {topic: {"type": ..., "count": ...}} from `rosbags.rosbag1.Reader`: the type as
      the bag's connection names it (ROS 1 spelling, `sensor_msgs/LaserScan`), the count
      summed over the topic's connections from the bag's index.
  info_reference.py mcap FILE.mcap
      {topic: {"type": ..., "count": ...}} from `mcap.reader.make_reader`: the channel's
      schema name and the summary statistics' message count of the channel (summed over
      the topic's channels).
  info_reference.py check
      Exits 0 when both packages import.

Needs `pip install rosbags mcap`.
"""

import json
import sys


def from_bag(path):
    from rosbags.rosbag1 import Reader

    out = {}
    with Reader(path) as reader:
        for conn in reader.connections:
            # rosbags names types the ROS 2 way (`pkg/msg/Type`); the bag says `pkg/Type`.
            msgtype = conn.msgtype.replace('/msg/', '/', 1)
            entry = out.setdefault(conn.topic, {'type': msgtype, 'count': 0})
            entry['count'] += conn.msgcount
    return out


def from_mcap(path):
    from mcap.reader import make_reader

    out = {}
    with open(path, 'rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        if summary is None or summary.statistics is None:
            raise SystemExit(f'{path} has no summary statistics')
        counts = summary.statistics.channel_message_counts
        for channel_id, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            entry = out.setdefault(
                channel.topic, {'type': schema.name if schema else '', 'count': 0}
            )
            entry['count'] += counts.get(channel_id, 0)
    return out


def main():
    if sys.argv[1:] == ['check']:
        import mcap.reader  # noqa: F401
        import rosbags.rosbag1  # noqa: F401

        return
    if len(sys.argv) != 3 or sys.argv[1] not in ('bag', 'mcap'):
        raise SystemExit(__doc__)
    kind, path = sys.argv[1], sys.argv[2]
    result = from_bag(path) if kind == 'bag' else from_mcap(path)
    json.dump(result, sys.stdout, indent=1, sort_keys=True)
    sys.stdout.write('\n')


if __name__ == '__main__':
    main()
