//! The ROS 1 form of tether's messages: decoders of what it reads from bags, encoders and
//! full definitions (with their MD5 sums) of what it writes into them.
//!
//! ROS 1 serialisation is plain little-endian: numbers at their natural width, a string
//! or an array as a `u32` length followed by its elements, nested messages inline.

use tether_core::Stamp;

mod md5;
pub use md5::{DefinitionError, definition_md5, md5_hex};

use crate::error::DecodeError;
use crate::{
    CompressedImageMsg, Header, ImageMsg, LaserScanMsg, OdometryMsg, PersonArrayMsg, PersonMsg,
    Pose3, PoseArrayMsg, RawLaserScan, TwistMsg,
};

/// A ROS time (`sec: u32, nsec: u32`, little-endian) as a stamp. Always representable:
/// `u32::MAX` seconds fit in an `i64` of nanoseconds.
pub fn time_from_bytes(b: [u8; 8]) -> Stamp {
    let sec = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let nsec = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
    Stamp::from_ns(i64::from(sec) * tether_core::NS_PER_S + i64::from(nsec))
}

/// A ROS 1 message type this crate can decode.
pub trait RosMessage: Sized {
    /// Type name as bags store it, e.g. `sensor_msgs/LaserScan`.
    const TYPE: &'static str;
    /// MD5 sum of the message definition, as `rosmsg md5` prints it.
    const MD5SUM: &'static str;
    /// Decodes a serialised message.
    fn decode(data: &[u8]) -> Result<Self, DecodeError>;
}

/// A cursor over a serialised message that never reads past the end.
struct Wire<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Wire<'a> {
    fn new(data: &'a [u8]) -> Self {
        Wire { data, pos: 0 }
    }

    fn take(&mut self, field: &'static str, n: u64) -> Result<&'a [u8], DecodeError> {
        let available = self.data.len() - self.pos;
        if n > available as u64 {
            return Err(DecodeError::Truncated {
                field,
                at: self.pos,
                needed: n,
                available,
            });
        }
        let out = &self.data[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], DecodeError> {
        let b = self.take(field, N as u64)?;
        let mut out = [0u8; N];
        out.copy_from_slice(b);
        Ok(out)
    }

    fn u32(&mut self, field: &'static str) -> Result<u32, DecodeError> {
        self.array::<4>(field).map(u32::from_le_bytes)
    }

    fn f32(&mut self, field: &'static str) -> Result<f32, DecodeError> {
        self.array::<4>(field).map(f32::from_le_bytes)
    }

    fn f64(&mut self, field: &'static str) -> Result<f64, DecodeError> {
        self.array::<8>(field).map(f64::from_le_bytes)
    }

    fn time(&mut self, field: &'static str) -> Result<Stamp, DecodeError> {
        self.array::<8>(field).map(time_from_bytes)
    }

    fn string(&mut self, field: &'static str) -> Result<String, DecodeError> {
        let len = self.u32(field)?;
        let bytes = self.take(field, u64::from(len))?;
        String::from_utf8(bytes.to_vec()).map_err(|_| DecodeError::NotUtf8 { field })
    }

    /// A `uint8[]`: its `u32` length, then the bytes.
    fn bytes(&mut self, field: &'static str) -> Result<Vec<u8>, DecodeError> {
        let len = self.u32(field)?;
        Ok(self.take(field, u64::from(len))?.to_vec())
    }

    fn f32_vec(&mut self, field: &'static str) -> Result<Vec<f32>, DecodeError> {
        let len = self.u32(field)?;
        let bytes = self.take(field, u64::from(len) * 4)?;
        Ok(bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }

    /// Number of elements of an array whose elements take at least `min_elem_len`
    /// bytes each; refuses counts the remaining bytes cannot hold.
    fn count(&mut self, field: &'static str, min_elem_len: u64) -> Result<usize, DecodeError> {
        let at = self.pos;
        let n = self.u32(field)?;
        let available = self.data.len() - self.pos;
        let needed = u64::from(n) * min_elem_len;
        if needed > available as u64 {
            return Err(DecodeError::Truncated {
                field,
                at,
                needed,
                available,
            });
        }
        Ok(n as usize)
    }

    fn finish(self) -> Result<(), DecodeError> {
        let extra = self.data.len() - self.pos;
        if extra == 0 {
            Ok(())
        } else {
            Err(DecodeError::TrailingBytes { extra })
        }
    }
}

/// `std_msgs/Header` as ROS 1 serialises it (with its sequence number).
fn read_header(w: &mut Wire<'_>) -> Result<Header, DecodeError> {
    Ok(Header {
        seq: w.u32("header.seq")?,
        stamp: w.time("header.stamp")?,
        frame_id: w.string("header.frame_id")?,
    })
}

impl RosMessage for RawLaserScan {
    const TYPE: &'static str = "sensor_msgs/LaserScan";
    const MD5SUM: &'static str = "90c7ef2dc6895d81024acba2ac42f369";

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let mut w = Wire::new(data);
        let msg = RawLaserScan {
            header: read_header(&mut w)?,
            angle_min: w.f32("angle_min")?,
            angle_max: w.f32("angle_max")?,
            angle_increment: w.f32("angle_increment")?,
            time_increment: w.f32("time_increment")?,
            scan_time: w.f32("scan_time")?,
            range_min: w.f32("range_min")?,
            range_max: w.f32("range_max")?,
            ranges: w.f32_vec("ranges")?,
            intensities: w.f32_vec("intensities")?,
        };
        w.finish()?;
        Ok(msg)
    }
}

/// A beam count beyond any array (a corrupt angle field) is a length mismatch; checked
/// before the scan is built so that it never reaches integer arithmetic. The ROS 1 path
/// only: its errors name `usize::MAX` beams for such a header, the CDR path's the count.
fn check_beam_span(raw: &RawLaserScan) -> Result<(), DecodeError> {
    let span =
        (f64::from(raw.angle_max) - f64::from(raw.angle_min)) / f64::from(raw.angle_increment);
    if span.is_finite() && span.abs() > u32::MAX as f64 {
        return Err(DecodeError::Scan(tether_core::ScanError::LengthMismatch {
            expected: usize::MAX,
            got: raw.ranges.len(),
        }));
    }
    Ok(())
}
impl RosMessage for LaserScanMsg {
    const TYPE: &'static str = RawLaserScan::TYPE;
    const MD5SUM: &'static str = RawLaserScan::MD5SUM;

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let raw = RawLaserScan::decode(data)?;
        check_beam_span(&raw)?;
        raw.into_msg()
    }
}

impl RosMessage for PoseArrayMsg {
    const TYPE: &'static str = "geometry_msgs/PoseArray";
    const MD5SUM: &'static str = "916c28c5764443f268b296bb671b9d97";

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let mut w = Wire::new(data);
        let header = read_header(&mut w)?;
        let n = w.count("poses", 7 * 8)?;
        let mut poses = Vec::with_capacity(n);
        for _ in 0..n {
            let position_m = [
                w.f64("poses.position")?,
                w.f64("poses.position")?,
                w.f64("poses.position")?,
            ];
            let orientation = [
                w.f64("poses.orientation")?,
                w.f64("poses.orientation")?,
                w.f64("poses.orientation")?,
                w.f64("poses.orientation")?,
            ];
            poses.push(Pose3 {
                position_m,
                orientation,
            });
        }
        w.finish()?;
        Ok(PoseArrayMsg { header, poses })
    }
}

/// `sensor_msgs/Image` of a ROS 1 bag, decoded into the same [`ImageMsg`] the MCAP
/// reader gives (the ROS 1 header's `seq` is dropped). Convert it with
/// [`ImageMsg::to_gray`].
impl RosMessage for ImageMsg {
    const TYPE: &'static str = "sensor_msgs/Image";
    const MD5SUM: &'static str = "060021388200f6f0f447d0fcd9c64743";

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let mut w = Wire::new(data);
        let header = read_header(&mut w)?;
        let height = w.u32("height")?;
        let width = w.u32("width")?;
        let encoding = w.string("encoding")?;
        let is_bigendian = w.array::<1>("is_bigendian")?[0];
        let step = w.u32("step")?;
        let pixels = w.bytes("data")?;
        w.finish()?;
        Ok(ImageMsg {
            header: Header::new(header.stamp, header.frame_id),
            height,
            width,
            encoding,
            is_bigendian,
            step,
            data: pixels,
        })
    }
}

/// `sensor_msgs/CompressedImage` of a ROS 1 bag (a JPEG or PNG file), decoded into the
/// same [`CompressedImageMsg`] the MCAP reader gives.
impl RosMessage for CompressedImageMsg {
    const TYPE: &'static str = "sensor_msgs/CompressedImage";
    const MD5SUM: &'static str = "8f7a12909da2c9d3332d540a0977563f";

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let mut w = Wire::new(data);
        let header = read_header(&mut w)?;
        let format = w.string("format")?;
        let bytes = w.bytes("data")?;
        w.finish()?;
        Ok(CompressedImageMsg {
            header: Header::new(header.stamp, header.frame_id),
            format,
            data: bytes,
        })
    }
}

/// `nav_msgs/Odometry` of a ROS 1 bag, decoded into the same [`OdometryMsg`] the MCAP
/// reader gives.
impl RosMessage for OdometryMsg {
    const TYPE: &'static str = "nav_msgs/Odometry";
    const MD5SUM: &'static str = "cd5e73d190d741a2f92e81eda573aca7";

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let mut w = Wire::new(data);
        let header = read_header(&mut w)?;
        let child_frame_id = w.string("child_frame_id")?;
        let mut f = |field: &'static str, out: &mut [f64]| -> Result<(), DecodeError> {
            for v in out.iter_mut() {
                *v = w.f64(field)?;
            }
            Ok(())
        };
        let mut position_m = [0.0; 3];
        let mut orientation = [0.0; 4];
        let mut pose_covariance = [0.0; 36];
        let mut linear_mps = [0.0; 3];
        let mut angular_radps = [0.0; 3];
        let mut twist_covariance = [0.0; 36];
        f("pose.pose.position", &mut position_m)?;
        f("pose.pose.orientation", &mut orientation)?;
        f("pose.covariance", &mut pose_covariance)?;
        f("twist.twist.linear", &mut linear_mps)?;
        f("twist.twist.angular", &mut angular_radps)?;
        f("twist.covariance", &mut twist_covariance)?;
        w.finish()?;
        Ok(OdometryMsg {
            header: Header::new(header.stamp, header.frame_id),
            child_frame_id,
            pose: Pose3 {
                position_m,
                orientation,
            },
            pose_covariance,
            twist: TwistMsg {
                linear_mps,
                angular_radps,
            },
            twist_covariance,
        })
    }
}

/// A ROS 1 message type this crate can also write (tether-recording's `BagWriter`).
pub trait RosMessageOut: RosMessage {
    /// The full definition as `rosbag record` stores it in a connection record: the
    /// type's own fields, then each type it uses after a line of 80 `=` and
    /// `MSG: pkg/Type`. [`definition_md5`] of it is [`RosMessage::MD5SUM`].
    const DEFINITION: &'static str;
    /// Appends the ROS 1 serialisation of the message to `out`.
    fn encode(&self, out: &mut Vec<u8>);
}

macro_rules! section {
    ($name:literal, $text:expr) => {
        concat!(
            "================================================================================\n",
            "MSG: ",
            $name,
            "\n",
            $text
        )
    };
}
/// `std_msgs/Header` of ROS 1 (with `seq`; the ROS 2 one has none).
macro_rules! header_section {
    () => {
        section!(
            "std_msgs/Header",
            "uint32 seq\ntime stamp\nstring frame_id\n"
        )
    };
}
/// `geometry_msgs/Pose` and the two types it uses, as ROS 1 spells them.
macro_rules! pose_sections {
    () => {
        concat!(
            section!(
                "geometry_msgs/Pose",
                "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"
            ),
            section!("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z\n"),
            section!(
                "geometry_msgs/Quaternion",
                "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"
            )
        )
    };
}

/// Appends ROS 1 wire values.
struct Out<'a>(&'a mut Vec<u8>);

impl Out<'_> {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    /// A ROS time: seconds and nanoseconds as `u32`; stamps before 1970 or after 2106
    /// are clamped to the range (the writer refuses such record times itself).
    fn time(&mut self, stamp: Stamp) {
        let ns = stamp
            .ns()
            .clamp(0, i64::from(u32::MAX) * tether_core::NS_PER_S);
        self.u32((ns / tether_core::NS_PER_S) as u32);
        self.u32((ns % tether_core::NS_PER_S) as u32);
    }
    /// A string (length-prefixed); longer than 4 GiB cannot be a frame id and is cut.
    fn string(&mut self, s: &str) {
        let bytes = &s.as_bytes()[..s.len().min(u32::MAX as usize)];
        self.u32(bytes.len() as u32);
        self.0.extend_from_slice(bytes);
    }
    fn header(&mut self, seq: u32, stamp: Stamp, frame_id: &str) {
        self.u32(seq);
        self.time(stamp);
        self.string(frame_id);
    }
    fn pose(&mut self, p: &Pose3) {
        for v in p.position_m.iter().chain(p.orientation.iter()) {
            self.f64(*v);
        }
    }
    fn f32_array(&mut self, values: &[f32]) {
        self.u32(values.len() as u32);
        for v in values {
            self.f32(*v);
        }
    }
}

impl RosMessageOut for RawLaserScan {
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n",
        "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n",
        "float32[] ranges\nfloat32[] intensities\n",
        header_section!(),
    );

    fn encode(&self, out: &mut Vec<u8>) {
        let mut o = Out(out);
        o.header(self.header.seq, self.header.stamp, &self.header.frame_id);
        for v in self.geometry() {
            o.f32(v);
        }
        o.f32_array(&self.ranges);
        o.f32_array(&self.intensities);
    }
}

impl RosMessageOut for LaserScanMsg {
    const DEFINITION: &'static str = RawLaserScan::DEFINITION;

    fn encode(&self, out: &mut Vec<u8>) {
        let mut raw = self.to_raw();
        // Unlike a CDR payload's: the angle read from a bag goes back bit for bit.
        raw.angle_max = self.angle_max_rad as f32;
        raw.encode(out);
    }
}

impl RosMessageOut for PoseArrayMsg {
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\ngeometry_msgs/Pose[] poses\n",
        header_section!(),
        pose_sections!(),
    );

    fn encode(&self, out: &mut Vec<u8>) {
        let mut o = Out(out);
        o.header(self.header.seq, self.header.stamp, &self.header.frame_id);
        o.u32(self.poses.len() as u32);
        for p in &self.poses {
            o.pose(p);
        }
    }
}

impl RosMessageOut for OdometryMsg {
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\nstring child_frame_id\n",
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
        header_section!(),
        section!(
            "geometry_msgs/PoseWithCovariance",
            "geometry_msgs/Pose pose\nfloat64[36] covariance\n"
        ),
        pose_sections!(),
        section!(
            "geometry_msgs/TwistWithCovariance",
            "geometry_msgs/Twist twist\nfloat64[36] covariance\n"
        ),
        section!(
            "geometry_msgs/Twist",
            "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n"
        ),
        section!("geometry_msgs/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"),
    );

    fn encode(&self, out: &mut Vec<u8>) {
        let mut o = Out(out);
        o.header(0, self.header.stamp, &self.header.frame_id);
        o.string(&self.child_frame_id);
        o.pose(&self.pose);
        for v in self
            .pose_covariance
            .iter()
            .chain(self.twist.linear_mps.iter())
            .chain(self.twist.angular_radps.iter())
            .chain(self.twist_covariance.iter())
        {
            o.f64(*v);
        }
    }
}

/// `leg_tracker/Person` as ROS 1 serialises it.
fn read_person(w: &mut Wire<'_>) -> Result<PersonMsg, DecodeError> {
    let mut v = [0.0; 7];
    for x in &mut v {
        *x = w.f64("people.pose")?;
    }
    Ok(PersonMsg {
        pose: Pose3 {
            position_m: [v[0], v[1], v[2]],
            orientation: [v[3], v[4], v[5], v[6]],
        },
        id: w.u32("people.id")?,
    })
}

fn write_person(p: &PersonMsg, o: &mut Out<'_>) {
    o.pose(&p.pose);
    o.u32(p.id);
}

impl RosMessage for PersonMsg {
    const TYPE: &'static str = "leg_tracker/Person";
    const MD5SUM: &'static str = "4f334171b5664340c323a1982b554a22";

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let mut w = Wire::new(data);
        let p = read_person(&mut w)?;
        w.finish()?;
        Ok(p)
    }
}

impl RosMessageOut for PersonMsg {
    const DEFINITION: &'static str = concat!(
        "# Pose of a person\ngeometry_msgs/Pose pose\nuint32 id\n",
        pose_sections!(),
    );

    fn encode(&self, out: &mut Vec<u8>) {
        write_person(self, &mut Out(out));
    }
}

impl RosMessage for PersonArrayMsg {
    const TYPE: &'static str = "leg_tracker/PersonArray";
    const MD5SUM: &'static str = "7b54bf6148ab21083b85a27eec643002";

    fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let mut w = Wire::new(data);
        let header = read_header(&mut w)?;
        let n = w.count("people", 7 * 8 + 4)?;
        let mut people = Vec::with_capacity(n);
        for _ in 0..n {
            people.push(read_person(&mut w)?);
        }
        w.finish()?;
        Ok(PersonArrayMsg { header, people })
    }
}

impl RosMessageOut for PersonArrayMsg {
    const DEFINITION: &'static str = concat!(
        "# Array of person positions\nstd_msgs/Header header\nPerson[] people\n",
        header_section!(),
        section!(
            "leg_tracker/Person",
            "# Pose of a person\ngeometry_msgs/Pose pose\nuint32 id\n"
        ),
        pose_sections!(),
    );

    fn encode(&self, out: &mut Vec<u8>) {
        let mut o = Out(out);
        o.header(self.header.seq, self.header.stamp, &self.header.frame_id);
        o.u32(self.people.len() as u32);
        for p in &self.people {
            write_person(p, &mut o);
        }
    }
}

/// Serialises messages the way ROS 1 does; used to build test bags.
#[cfg(test)]
pub(crate) mod encode {
    pub(crate) fn header(out: &mut Vec<u8>, seq: u32, stamp_ns: i64, frame_id: &str) {
        out.extend(seq.to_le_bytes());
        out.extend(((stamp_ns / 1_000_000_000) as u32).to_le_bytes());
        out.extend(((stamp_ns % 1_000_000_000) as u32).to_le_bytes());
        out.extend((frame_id.len() as u32).to_le_bytes());
        out.extend(frame_id.as_bytes());
    }

    /// A LaserScan message with the given geometry and ranges.
    pub(crate) fn laser_scan(
        stamp_ns: i64,
        frame_id: &str,
        angle_min: f32,
        angle_increment: f32,
        ranges: &[f32],
    ) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, 7, stamp_ns, frame_id);
        let angle_max = angle_min + angle_increment * (ranges.len() as f32 - 1.0);
        for v in [angle_min, angle_max, angle_increment, 1e-4, 0.1, 0.02, 5.6] {
            out.extend(v.to_le_bytes());
        }
        out.extend((ranges.len() as u32).to_le_bytes());
        for r in ranges {
            out.extend(r.to_le_bytes());
        }
        out.extend(0u32.to_le_bytes());
        out
    }

    /// An Image message.
    pub(crate) fn image(
        stamp_ns: i64,
        encoding: &str,
        width: u32,
        height: u32,
        step: u32,
        pixels: &[u8],
    ) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, 3, stamp_ns, "camera");
        out.extend(height.to_le_bytes());
        out.extend(width.to_le_bytes());
        out.extend((encoding.len() as u32).to_le_bytes());
        out.extend(encoding.as_bytes());
        out.push(0);
        out.extend(step.to_le_bytes());
        out.extend((pixels.len() as u32).to_le_bytes());
        out.extend(pixels);
        out
    }

    /// A CompressedImage message.
    pub(crate) fn compressed_image(stamp_ns: i64, format: &str, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, 4, stamp_ns, "camera");
        out.extend((format.len() as u32).to_le_bytes());
        out.extend(format.as_bytes());
        out.extend((bytes.len() as u32).to_le_bytes());
        out.extend(bytes);
        out
    }

    /// An Odometry message at `(x, y, yaw)` moving at `(v, w)`.
    pub(crate) fn odometry(stamp_ns: i64, x: f64, y: f64, yaw: f64, v: f64, w: f64) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, 9, stamp_ns, "odom");
        out.extend(9u32.to_le_bytes());
        out.extend(b"base_link");
        let (s, c) = (0.5 * yaw).sin_cos();
        for v in [x, y, 0.0, 0.0, 0.0, s, c] {
            out.extend(v.to_le_bytes());
        }
        out.extend([0u8; 36 * 8]);
        for v in [v, 0.0, 0.0, 0.0, 0.0, w] {
            out.extend(v.to_le_bytes());
        }
        out.extend([0u8; 36 * 8]);
        out
    }

    /// A PoseArray of points on the x-y plane with identity orientation.
    pub(crate) fn pose_array(stamp_ns: i64, frame_id: &str, xy: &[(f64, f64)]) -> Vec<u8> {
        let mut out = Vec::new();
        header(&mut out, 0, stamp_ns, frame_id);
        out.extend((xy.len() as u32).to_le_bytes());
        for &(x, y) in xy {
            for v in [x, y, 0.0, 0.0, 0.0, 0.0, 1.0] {
                out.extend(v.to_le_bytes());
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{Laser, Point2, Pose2};

    #[test]
    fn decodes_a_laser_scan() {
        let data = encode::laser_scan(
            1_500_000_000,
            "laser",
            -0.5,
            0.25,
            &[1.0, f32::INFINITY, 0.0, f32::NAN, 2.0],
        );
        let m = LaserScanMsg::decode(&data).unwrap();
        assert_eq!(m.seq, 7);
        assert_eq!(m.scan.stamp, Stamp::from_ns(1_500_000_000));
        assert_eq!(m.scan.frame_id, "laser");
        assert_eq!(m.scan.len(), 5);
        assert_eq!(m.scan.range_m(0), Some(1.0));
        assert_eq!(m.scan.range_m(2), None, "below range_min is no return");
        assert_eq!(m.scan.malformed_beams(), 1, "NaN is counted");
        assert!((m.angle_max_rad - 0.5).abs() < 1e-6);
        assert!((m.scan_time_s - 0.1).abs() < 1e-6);
    }

    #[test]
    fn decodes_images_raw_and_compressed() {
        // 3x2 bgr8 with a padded row (step 10).
        let mut pixels = vec![0u8; 20];
        pixels[0..3].copy_from_slice(&[0, 0, 255]); // red
        pixels[10..13].copy_from_slice(&[255, 255, 255]);
        let data = encode::image(2_000_000_001, "bgr8", 3, 2, 10, &pixels);
        let m = ImageMsg::decode(&data).unwrap();
        assert_eq!((m.width, m.height, m.step), (3, 2, 10));
        assert_eq!(m.header.stamp, Stamp::from_ns(2_000_000_001));
        assert_eq!(m.header.frame_id, "camera");
        let grey = m.to_gray().unwrap();
        assert_eq!(grey.pixels(), &[76, 0, 0, 255, 0, 0]);
        // Cut anywhere: an error naming the field, never a panic.
        for cut in 0..data.len() {
            assert!(ImageMsg::decode(&data[..cut]).is_err());
        }
        let png = b"\x89PNG\r\n\x1a\nrest".to_vec();
        let data = encode::compressed_image(5, "png", &png);
        let c = CompressedImageMsg::decode(&data).unwrap();
        assert_eq!(c.format, "png");
        assert_eq!(c.data, png);
        assert_eq!(c.detected_format(), Some(crate::CompressedFormat::Png));
        let mut long = data.clone();
        long.push(0);
        assert!(matches!(
            CompressedImageMsg::decode(&long),
            Err(DecodeError::TrailingBytes { extra: 1 })
        ));
    }

    #[test]
    fn decodes_odometry() {
        let data = encode::odometry(3_000_000_000, 1.0, -2.0, 0.5, 0.4, -0.1);
        let m = OdometryMsg::decode(&data).unwrap();
        assert_eq!(m.header.frame_id, "odom");
        assert_eq!(m.child_frame_id, "base_link");
        let pose: Pose2<tether_core::World, tether_core::Robot> = m.pose.pose2();
        assert!((pose.x - 1.0).abs() < 1e-12 && (pose.y + 2.0).abs() < 1e-12);
        assert!((pose.yaw - 0.5).abs() < 1e-12);
        assert_eq!((m.twist.v_mps(), m.twist.w_radps()), (0.4, -0.1));
        for cut in [0, 20, data.len() - 1] {
            assert!(OdometryMsg::decode(&data[..cut]).is_err());
        }
    }

    #[test]
    fn refuses_inconsistent_scans() {
        let mut data = encode::laser_scan(0, "l", -0.5, 0.25, &[1.0; 5]);
        // angle_increment (after header of 4 + 8 + 4 + 1 bytes and two f32) := 0
        let at = 17 + 8;
        data[at..at + 4].copy_from_slice(&0f32.to_le_bytes());
        assert!(matches!(
            LaserScanMsg::decode(&data),
            Err(DecodeError::Scan(
                tether_core::ScanError::BadAngleIncrement(_)
            ))
        ));
        // angle_max says 6 beams, 5 are there.
        let mut data = encode::laser_scan(0, "l", -0.5, 0.25, &[1.0; 5]);
        data[21..25].copy_from_slice(&0.75f32.to_le_bytes());
        assert!(matches!(
            LaserScanMsg::decode(&data),
            Err(DecodeError::Scan(
                tether_core::ScanError::LengthMismatch { .. }
            ))
        ));
    }

    #[test]
    fn refuses_absurd_beam_counts() {
        // angle_max - angle_min of 1e30 increments: no scan has that many beams.
        let mut data = encode::laser_scan(0, "l", -0.5, 0.25, &[1.0; 5]);
        data[21..25].copy_from_slice(&1e30f32.to_le_bytes());
        data[25..29].copy_from_slice(&1e-10f32.to_le_bytes());
        assert!(matches!(
            LaserScanMsg::decode(&data),
            Err(DecodeError::Scan(
                tether_core::ScanError::LengthMismatch { .. }
            ))
        ));
    }

    #[test]
    fn refuses_truncated_and_padded_payloads() {
        let data = encode::laser_scan(0, "laser", -0.5, 0.25, &[1.0; 5]);
        for cut in 0..data.len() {
            assert!(
                RawLaserScan::decode(&data[..cut]).is_err(),
                "a scan cut at {cut} must not decode"
            );
        }
        let mut padded = data.clone();
        padded.push(0);
        assert_eq!(
            RawLaserScan::decode(&padded),
            Err(DecodeError::TrailingBytes { extra: 1 })
        );
        // A huge array length is refused before allocating.
        let mut huge = data[..data.len() - 4 - 5 * 4 - 4].to_vec();
        huge.extend(u32::MAX.to_le_bytes());
        assert!(matches!(
            RawLaserScan::decode(&huge),
            Err(DecodeError::Truncated {
                field: "ranges",
                ..
            })
        ));
    }

    #[test]
    fn decodes_a_pose_array() {
        let data = encode::pose_array(0, "right_laser", &[(1.5, -0.25), (2.0, 0.5)]);
        let m = PoseArrayMsg::decode(&data).unwrap();
        assert_eq!(m.header.frame_id, "right_laser");
        let pts = m.positions_2d::<Laser>();
        assert_eq!(pts, vec![Point2::new(1.5, -0.25), Point2::new(2.0, 0.5)]);
        assert_eq!(m.poses[0].yaw_rad(), 0.0);
        for cut in 0..data.len() {
            assert!(PoseArrayMsg::decode(&data[..cut]).is_err());
        }
        let mut lying = data.clone();
        let n_at = 4 + 8 + 4 + "right_laser".len();
        lying[n_at..n_at + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
        assert!(matches!(
            PoseArrayMsg::decode(&lying),
            Err(DecodeError::Truncated { field: "poses", .. })
        ));
    }

    #[test]
    fn yaw_of_a_quarter_turn() {
        let h = std::f64::consts::FRAC_PI_4;
        let p = Pose3 {
            position_m: [0.0; 3],
            orientation: [0.0, 0.0, h.sin(), h.cos()],
        };
        assert!((p.yaw_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
