"""Independent MCAP readers and writers for tether-recording's interoperability tests (issue 7).

Usage:
  mcap_reference.py write-mcap OUT.mcap zstd|lz4|none VALUES.jsonl
      Writes one message of each ROS 2 type tether handles, several times, with
      `mcap` + `mcap-ros2-support` (schemas: rosbags' definitions of ROS 2 Humble,
      with the header's time spelled as builtin_interfaces/Time) and dumps what it
      wrote, flattened, to VALUES.jsonl.
  mcap_reference.py write-rosbags OUTDIR VALUES.jsonl
      The same values with rosbags' own rosbag2 writer (MCAP storage) and serializer.
  mcap_reference.py read-mcap IN.mcap OUT.jsonl
      Reads every message with mcap-ros2-support's decoder; also re-encodes it from
      the file's schema and records whether the bytes are identical.
  mcap_reference.py read-rosbags IN.mcap OUT.jsonl
      Reads every message with rosbags (its MCAP reader and CDR deserializer).

A flattened message maps field paths ("header.stamp.sec", "poses[1].position.x") to
text: integers in decimal, every float as the hex of its IEEE 754 double (float32
values widened exactly), float arrays as the concatenation, byte arrays as hex,
strings as they are, an empty array as "".
"""

import dataclasses
import json
import random
import struct
import sys

import numpy as np

TYPES = [
    "sensor_msgs/msg/LaserScan",
    "sensor_msgs/msg/Image",
    "sensor_msgs/msg/CompressedImage",
    "geometry_msgs/msg/Twist",
    "geometry_msgs/msg/PoseArray",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "nav_msgs/msg/Odometry",
]


def f64hex(x):
    return struct.pack("<d", float(x)).hex()


def flatten(prefix, v, out):
    name = lambda n: f"{prefix}.{n}" if prefix else n  # noqa: E731
    if isinstance(v, (bytes, bytearray)):
        out[prefix] = bytes(v).hex()
    elif isinstance(v, np.ndarray):
        if v.dtype == np.uint8:
            out[prefix] = v.tobytes().hex()
        else:
            out[prefix] = "".join(f64hex(x) for x in v.tolist())
    elif isinstance(v, (list, tuple)):
        if len(v) == 0:
            out[prefix] = ""
        elif isinstance(v[0], float):
            out[prefix] = "".join(f64hex(x) for x in v)
        elif isinstance(v[0], int):
            out[prefix] = bytes(v).hex()
        else:
            for i, item in enumerate(v):
                flatten(f"{prefix}[{i}]", item, out)
    elif isinstance(v, bool):
        out[prefix] = str(int(v))
    elif isinstance(v, int):
        out[prefix] = str(v)
    elif isinstance(v, float):
        out[prefix] = f64hex(v)
    elif isinstance(v, str):
        out[prefix] = v
    elif isinstance(v, dict):
        for k, item in v.items():
            flatten(name(k), item, out)
    elif dataclasses.is_dataclass(v):
        for f in dataclasses.fields(v):
            # Skipped: dunder fields, and message constants (rosbags lists
            # visualization_msgs/Marker's `ARROW`... as fields).
            if not f.name.startswith("__") and not f.name.isupper():
                flatten(name(f.name), getattr(v, f.name), out)
    elif hasattr(v, "__slots__"):
        for s in v.__slots__:
            flatten(name(s), getattr(v, s), out)
    else:
        raise TypeError(f"cannot flatten {prefix}: {type(v)}")
    return out


def f32(rng, lo, hi):
    """A random value exactly representable as float32."""
    return struct.unpack("<f", struct.pack("<f", rng.uniform(lo, hi)))[0]


def header(rng, frame):
    return {
        "stamp": {"sec": rng.randrange(0, 2**31), "nanosec": rng.randrange(0, 10**9)},
        "frame_id": frame,
    }


def pose(rng):
    q = [rng.uniform(-1, 1) for _ in range(4)]
    n = sum(x * x for x in q) ** 0.5
    return {
        "position": {"x": rng.uniform(-50, 50), "y": rng.uniform(-50, 50), "z": rng.uniform(-1, 1)},
        "orientation": dict(zip("xyzw", [x / n for x in q])),
    }


def twist(rng):
    return {
        "linear": {k: rng.uniform(-2, 2) for k in "xyz"},
        "angular": {k: rng.uniform(-3, 3) for k in "xyz"},
    }


def make_values(rng, msgtype, i):
    """Field values (nested dicts) of message i of a type."""
    if msgtype == "sensor_msgs/msg/LaserScan":
        n = 682 if i % 2 == 0 else 1 + rng.randrange(40)
        ranges = [f32(rng, 0.02, 5.6) for _ in range(n)]
        for j in range(0, n, 17):
            ranges[j] = float("inf")
        inc = f32(rng, 0.001, 0.01)
        amin = f32(rng, -2.1, -1.0)
        # angle_max from float32 arithmetic, so that the header's beam count is exact.
        amax = struct.unpack("<f", struct.pack("<f", amin + inc * (n - 1)))[0]
        return {
            "header": header(rng, "laser"),
            "angle_min": amin,
            "angle_max": amax,
            "angle_increment": inc,
            "time_increment": f32(rng, 0, 1e-3),
            "scan_time": f32(rng, 0.05, 0.2),
            "range_min": 0.019999999552965164,
            "range_max": 5.599999904632568,
            "ranges": ranges,
            "intensities": [f32(rng, 0, 1000) for _ in range(i % 3)],
        }
    if msgtype == "sensor_msgs/msg/Image":
        enc, ch = [("mono8", 1), ("rgb8", 3), ("bgr8", 3)][i % 3]
        w, h = 4 + rng.randrange(20), 3 + rng.randrange(10)
        step = w * ch + (i % 2) * 3
        return {
            "header": header(rng, "camera_optical"),
            "height": h,
            "width": w,
            "encoding": enc,
            "is_bigendian": 0,
            "step": step,
            "data": bytes(rng.randrange(256) for _ in range(step * h)),
        }
    if msgtype == "sensor_msgs/msg/CompressedImage":
        magic = [b"\xff\xd8\xff\xe0", b"\x89PNG\r\n\x1a\n"][i % 2]
        return {
            "header": header(rng, "camera_optical"),
            "format": ["jpeg", "png"][i % 2],
            "data": magic + bytes(rng.randrange(256) for _ in range(100 + i)),
        }
    if msgtype == "geometry_msgs/msg/Twist":
        return twist(rng)
    if msgtype == "geometry_msgs/msg/PoseArray":
        return {"header": header(rng, "world"), "poses": [pose(rng) for _ in range(i % 4)]}
    if msgtype == "geometry_msgs/msg/PoseWithCovarianceStamped":
        return {
            "header": header(rng, "world"),
            "pose": {"pose": pose(rng), "covariance": [rng.uniform(-1, 1) for _ in range(36)]},
        }
    if msgtype == "nav_msgs/msg/Odometry":
        return {
            "header": header(rng, "odom"),
            "child_frame_id": "base_link",
            "pose": {"pose": pose(rng), "covariance": [rng.uniform(-1, 1) for _ in range(36)]},
            "twist": {"twist": twist(rng), "covariance": [rng.uniform(-1, 1) for _ in range(36)]},
        }
    raise ValueError(msgtype)


def plan():
    """(topic, type, log_time_ns, values) of every message, in time order."""
    rng = random.Random(20240607)
    out = []
    t = 1_700_000_000_000_000_000
    for i in range(6):
        for k, msgtype in enumerate(TYPES):
            topic = "/" + msgtype.split("/")[-1].lower()
            t += 1_000_000 + rng.randrange(1000)
            out.append((topic, msgtype, t, make_values(rng, msgtype, i)))
    return out


def dump(path, rows):
    with open(path, "w") as f:
        for row in rows:
            f.write(json.dumps(row) + "\n")


def ros2_msgdef(typestore, msgtype):
    """rosbags' definition with the header's `time` spelled the ROS 2 way."""
    text, _ = typestore.generate_msgdef(msgtype)
    sep = "=" * 80 + "\n"
    text = text.replace("MSG: std_msgs/Header\ntime stamp\n", "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\n")
    if "builtin_interfaces/Time stamp" in text:
        text += sep + "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
    return text


def write_mcap(out, compression, values_path):
    from mcap.writer import CompressionType
    from mcap_ros2.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[compression]
    rows = []
    with open(out, "wb") as f:
        w = Writer(f, compression=comp, chunk_size=64 * 1024)
        schemas = {t: w.register_msgdef(t, ros2_msgdef(ts, t)) for t in TYPES}
        for topic, msgtype, t, values in plan():
            w.write_message(topic, schemas[msgtype], values, log_time=t, publish_time=t)
            rows.append({"topic": topic, "type": msgtype, "log_time": t, "fields": flatten("", values, {})})
        w.finish()
    dump(values_path, rows)


def build(typestore, msgtype, values):
    """A rosbags message object from nested dicts, following the typestore."""
    cls = typestore.types[msgtype]
    _, fields = typestore.fielddefs[msgtype]
    kwargs = {}
    for fname, (kind, spec) in fields:
        v = values[fname]
        # kind: 1 base, 2 name (nested message), 3 array, 4 sequence.
        if kind == 2:
            kwargs[fname] = build(typestore, spec, v)
        elif kind in (3, 4):
            (sub_kind, sub_spec), _ = spec
            if sub_kind == 2:
                kwargs[fname] = [build(typestore, sub_spec, x) for x in v]
            else:
                dtype = {"uint8": np.uint8, "float32": np.float32, "float64": np.float64}[sub_spec[0]]
                if dtype == np.uint8:
                    kwargs[fname] = np.frombuffer(v, dtype=np.uint8).copy()
                else:
                    kwargs[fname] = np.array(v, dtype=dtype)
        else:
            kwargs[fname] = v
    return cls(**kwargs)


def write_rosbags(outdir, values_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    rows = []
    with Writer(outdir, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for topic, msgtype, t, values in plan():
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=ts)
            msg = build(ts, msgtype, values)
            w.write(conns[topic], t, ts.serialize_cdr(msg, msgtype))
            rows.append({"topic": topic, "type": msgtype, "log_time": t, "fields": flatten("", values, {})})
    dump(values_path, rows)


def read_mcap(path, out):
    from mcap.reader import make_reader
    from mcap_ros2._dynamic import serialize_dynamic
    from mcap_ros2.decoder import DecoderFactory

    rows = []
    encoders = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header_profile = reader.get_header().profile
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            if schema.id not in encoders:
                encoders[schema.id] = serialize_dynamic(schema.name, schema.data.decode())[schema.name]
            again = encoders[schema.id](decoded)
            rows.append(
                {
                    "profile": header_profile,
                    "topic": channel.topic,
                    "type": schema.name,
                    "schema_encoding": schema.encoding,
                    "message_encoding": channel.message_encoding,
                    "log_time": message.log_time,
                    "publish_time": message.publish_time,
                    "fields": flatten("", decoded, {}),
                    "reencoded_identical": bytes(again) == bytes(message.data),
                }
            )
    dump(out, rows)


def read_rosbags(path, out):
    from pathlib import Path

    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    rows = []
    with Reader(Path(path)) as reader:
        for conn, t, data in reader.messages():
            msg = ts.deserialize_cdr(data, conn.msgtype)
            again = ts.serialize_cdr(msg, conn.msgtype)
            rows.append(
                {
                    "topic": conn.topic,
                    "type": conn.msgtype,
                    "log_time": t,
                    "fields": flatten("", msg, {}),
                    "reencoded_identical": bytes(again) == bytes(data),
                }
            )
    dump(out, rows)


def main(argv):
    cmd = argv[1]
    if cmd == "write-mcap":
        write_mcap(argv[2], argv[3], argv[4])
    elif cmd == "write-rosbags":
        write_rosbags(argv[2], argv[3])
    elif cmd == "read-mcap":
        read_mcap(argv[2], argv[3])
    elif cmd == "read-rosbags":
        read_rosbags(argv[2], argv[3])
    else:
        raise SystemExit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
