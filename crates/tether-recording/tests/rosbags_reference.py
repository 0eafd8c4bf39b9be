#!/usr/bin/env python3
"""Reference reader for tether-recording's cross-check test, using the `rosbags` package.

  rosbags_reference.py dump BAG OUT.jsonl
      One JSON line per message of BAG, per topic in bag order: topic, record time and,
      for LaserScan and PoseArray, the decoded fields (ranges as the hex of their
      little-endian float32 bytes and other floats as the hex of float64 bytes, so that
      the comparison is bit-exact).
  rosbags_reference.py compress SRC DST {bz2,lz4} CHUNK_BYTES
      Copies SRC to DST with chunks compressed by rosbags' own writer, starting a new
      chunk after about CHUNK_BYTES of records.

Needs `pip install rosbags` (numpy comes with it).
"""

import json
import struct
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_typestore

TYPESTORE = get_typestore(Stores.ROS1_NOETIC)


def bits(x) -> str:
    """A float as the hex of its little-endian float64 bytes: exact through JSON."""
    return struct.pack('<d', float(x)).hex()


def stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def dump(src: Path, out: Path) -> None:
    with Reader(src) as reader, out.open('w') as f:
        for conn, time_ns, raw in reader.messages():
            line = {'topic': conn.topic, 'time_ns': time_ns, 'type': conn.msgtype}
            if conn.msgtype == 'sensor_msgs/msg/LaserScan':
                m = TYPESTORE.deserialize_ros1(raw, conn.msgtype)
                ranges = np.asarray(m.ranges, dtype='<f4')
                with np.errstate(invalid='ignore'):
                    valid = np.isfinite(ranges) & (ranges >= np.float32(m.range_min)) & (
                        ranges <= np.float32(m.range_max)
                    )
                    malformed = np.isnan(ranges) | (ranges < 0)
                line.update(
                    seq=m.header.seq,
                    stamp_ns=stamp_ns(m.header),
                    frame_id=m.header.frame_id,
                    angle_min=bits(m.angle_min),
                    angle_max=bits(m.angle_max),
                    angle_increment=bits(m.angle_increment),
                    range_min=bits(m.range_min),
                    range_max=bits(m.range_max),
                    ranges_hex=ranges.tobytes().hex(),
                    returns=int(valid.sum()),
                    malformed=int(malformed.sum()),
                )
            elif conn.msgtype == 'geometry_msgs/msg/PoseArray':
                m = TYPESTORE.deserialize_ros1(raw, conn.msgtype)
                line.update(
                    stamp_ns=stamp_ns(m.header),
                    frame_id=m.header.frame_id,
                    positions=[
                        [bits(p.position.x), bits(p.position.y), bits(p.position.z)]
                        for p in m.poses
                    ],
                )
            f.write(json.dumps(line) + '\n')


def compress_copy(src: Path, dst: Path, fmt: str, chunk_bytes: int) -> None:
    if dst.exists():
        dst.unlink()
    writer = Writer(dst)
    writer.set_compression(
        {'bz2': Writer.CompressionFormat.BZ2, 'lz4': Writer.CompressionFormat.LZ4}[fmt]
    )
    writer.chunk_threshold = chunk_bytes
    with Reader(src) as reader:
        writer.open()
        conns = {}
        for c in reader.connections:
            conns[c.id] = writer.add_connection(
                c.topic,
                c.msgtype,
                msgdef=c.msgdef.data,
                md5sum=c.digest,
                callerid=c.ext.callerid,
                latching=c.ext.latching,
            )
        for conn, time_ns, raw in reader.messages():
            writer.write(conns[conn.id], time_ns, raw)
        writer.close()


def main() -> int:
    if len(sys.argv) == 4 and sys.argv[1] == 'dump':
        dump(Path(sys.argv[2]), Path(sys.argv[3]))
        return 0
    if len(sys.argv) == 6 and sys.argv[1] == 'compress':
        compress_copy(Path(sys.argv[2]), Path(sys.argv[3]), sys.argv[4], int(sys.argv[5]))
        return 0
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == '__main__':
    sys.exit(main())
