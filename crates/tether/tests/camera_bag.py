"""Builds a ROS 1 bag for the `tether track --image-topic` test with the `rosbags` package.

usage: camera_bag.py OUT_DIR SOURCE.bag SCAN_TOPIC N_SCANS IMAGE.png...

Writes OUT_DIR/camera.bag: the first N_SCANS LaserScan messages of SOURCE.bag's
SCAN_TOPIC (a real recording), and after each scan one camera frame, the PNG images in
turn, twice: as a mono8 sensor_msgs/Image on /camera/image (grey as OpenCV reads it) and
as a sensor_msgs/CompressedImage on /camera/image/compressed (that grey image encoded as
JPEG by OpenCV, also saved as OUT_DIR/<k>.jpg). After the last scan, one broken frame on
/camera/image (encoding "yuv422", which tether does not read). Prints one JSON object:
{"scan_stamps_ns": [...], "frames": [{"png": path, "jpg": path}, ...]}.
"""

import json
import sys
from pathlib import Path

import cv2
import numpy as np
from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_typestore


def main():
    out_dir, source, scan_topic = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
    n_scans = int(sys.argv[4])
    pngs = [Path(p) for p in sys.argv[5:]]
    store = get_typestore(Stores.ROS1_NOETIC)
    Image = store.types["sensor_msgs/msg/Image"]
    CompressedImage = store.types["sensor_msgs/msg/CompressedImage"]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    greys, jpgs = [], []
    for k, png in enumerate(pngs):
        grey = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
        ok, jpeg = cv2.imencode(".jpg", grey, [cv2.IMWRITE_JPEG_QUALITY, 90])
        assert ok
        jpg = out_dir / f"{k}.jpg"
        jpg.write_bytes(jpeg.tobytes())
        greys.append(grey)
        jpgs.append(jpg)

    def header(seq, stamp_ns):
        time = Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
        return Header(seq=seq, stamp=time, frame_id="camera")

    def raw(seq, stamp_ns, grey, encoding="mono8"):
        return Image(
            header=header(seq, stamp_ns),
            height=grey.shape[0],
            width=grey.shape[1],
            encoding=encoding,
            is_bigendian=0,
            step=grey.shape[1],
            data=grey.reshape(-1),
        )

    stamps, frames = [], []
    with Reader(source) as reader, Writer(out_dir / "camera.bag") as writer:
        conns = [c for c in reader.connections if c.topic == scan_topic]
        scan_conn = writer.add_connection(scan_topic, conns[0].msgtype, typestore=store)
        raw_conn = writer.add_connection("/camera/image", Image.__msgtype__, typestore=store)
        jpg_conn = writer.add_connection(
            "/camera/image/compressed", CompressedImage.__msgtype__, typestore=store
        )
        t = 0
        for i, (conn, t, data) in enumerate(reader.messages(connections=conns)):
            if i >= n_scans:
                break
            writer.write(scan_conn, t, data)
            scan = store.deserialize_ros1(data, conn.msgtype)
            stamps.append(scan.header.stamp.sec * 1_000_000_000 + scan.header.stamp.nanosec)
            k = i % len(pngs)
            at = t + 50_000_000
            msg = raw(i, at, greys[k])
            writer.write(raw_conn, at, store.serialize_ros1(msg, msg.__msgtype__))
            msg = CompressedImage(
                header=header(i, at),
                format="jpeg",
                data=np.frombuffer(jpgs[k].read_bytes(), dtype=np.uint8),
            )
            writer.write(jpg_conn, at, store.serialize_ros1(msg, msg.__msgtype__))
            frames.append({"png": str(pngs[k]), "jpg": str(jpgs[k])})
        msg = raw(n_scans, t + 60_000_000, greys[0], encoding="yuv422")
        writer.write(raw_conn, t + 60_000_000, store.serialize_ros1(msg, msg.__msgtype__))
    print(json.dumps({"scan_stamps_ns": stamps, "frames": frames}))


if __name__ == "__main__":
    main()
