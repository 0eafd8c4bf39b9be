//! tether's own CDR messages on DDS.
//!
//! Every ROS 2 message tether knows has one definition: the type in
//! `tether_msgs` with its hand-written CDR codec, checked byte for byte
//! against Python `rosbags`. The MCAP reader and writer use it, and so does the live
//! node, through [`Wire`].
//!
//! ros2-client hands a message to serde's CDR serializer after writing the 4-byte
//! encapsulation header itself. [`Wire`] serialises the codec's body (the payload after
//! that header) as a tuple of bytes, which CDR writes as the bytes themselves: no length
//! prefix, and no padding, since a byte needs no alignment. The body keeps its own
//! alignment because both count offsets from the end of the encapsulation header. On
//! the way in, the CDR deserializer's tuple gives the body back byte by byte up to the
//! end of the payload, and the codec reads it as if the header were in front.
//!
//! Byte order: the codec writes and reads little-endian CDR (`CDR_LE`), which every
//! ROS 2 middleware sends on the machines ROS 2 runs on. A big-endian payload decodes
//! to byte-swapped lengths and counts that the codec's checks refuse (beyond the
//! payload) in all but contrived cases.

use std::fmt;

use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use tether_msgs::{Ros2Message, from_cdr, to_cdr};

/// The encapsulation header of little-endian plain CDR (`CDR_LE`, options 0).
const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// A tether message on a ROS 2 topic: ros2-client publishes and takes `Wire<M>`.
#[derive(Debug, Clone, PartialEq)]
pub struct Wire<M>(pub M);

impl<M: Ros2Message> Serialize for Wire<M> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let payload = to_cdr(&self.0).map_err(serde::ser::Error::custom)?;
        let body = payload.get(CDR_LE_HEADER.len()..).unwrap_or_default();
        let mut tuple = serializer.serialize_tuple(body.len())?;
        for byte in body {
            tuple.serialize_element(byte)?;
        }
        tuple.end()
    }
}

impl<'de, M: Ros2Message> Deserialize<'de> for Wire<M> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let payload = deserializer.deserialize_tuple(usize::MAX, BodyVisitor)?;
        from_cdr(&payload)
            .map(Wire)
            .map_err(|e| serde::de::Error::custom(format!("{}: {e}", M::TYPE)))
    }
}

/// Collects the body's bytes behind a `CDR_LE` header, until the payload ends.
struct BodyVisitor;

impl<'de> Visitor<'de> for BodyVisitor {
    type Value = Vec<u8>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a CDR message body")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<u8>, A::Error> {
        let mut payload = Vec::with_capacity(CDR_LE_HEADER.len() + seq.size_hint().unwrap_or(0));
        payload.extend_from_slice(&CDR_LE_HEADER);
        // The deserializer reports the end of the payload as an error: that is where the
        // body ends.
        while let Ok(Some(byte)) = seq.next_element::<u8>() {
            payload.push(byte);
        }
        Ok(payload)
    }
}

/// The ROS 2 type of `M` as ros2-client names it (`sensor_msgs/msg/LaserScan` is package
/// `sensor_msgs`, type `LaserScan`; on DDS `sensor_msgs::msg::dds_::LaserScan_`).
pub fn type_name<M: Ros2Message>() -> ros2_client::MessageTypeName {
    let mut parts = M::TYPE.split('/');
    let package = parts.next().unwrap_or_default();
    let name = parts.next_back().unwrap_or_default();
    ros2_client::MessageTypeName::new(package, name)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use tether_core::{LaserScan, Stamp};
    use tether_msgs::{
        CompressedImageMsg, Detection2DArrayMsg, ImageMsg, LaserScanMsg, OdometryMsg, TwistMsg,
        TwistStampedMsg,
    };

    use super::*;

    #[test]
    fn type_names_are_the_dds_names_ros_2_uses() {
        assert_eq!(
            type_name::<LaserScanMsg>().dds_msg_type(),
            "sensor_msgs::msg::dds_::LaserScan_"
        );
        assert_eq!(
            type_name::<TwistMsg>().dds_msg_type(),
            "geometry_msgs::msg::dds_::Twist_"
        );
    }

    fn scan() -> LaserScanMsg {
        let scan = LaserScan::new(
            Stamp::from_ns(1_700_000_000_123_456_789),
            "laser",
            -2.0,
            0.01,
            0.02,
            5.6,
            vec![1.0, f32::INFINITY, 2.5, 0.5, 3.25],
        )
        .unwrap();
        LaserScanMsg::new(scan, 1e-4, 0.1)
    }

    /// What the DDS payload of `msg` is: the encapsulation header ros2-client writes,
    /// then serde's CDR of `Wire(msg)`.
    fn dds_payload<M: Ros2Message + Clone>(msg: &M) -> Vec<u8> {
        let mut bytes = CDR_LE_HEADER.to_vec();
        bytes.extend(
            cdr_encoding::to_vec::<_, byteorder::LittleEndian>(&Wire(msg.clone())).unwrap(),
        );
        bytes
    }

    fn from_dds_payload<M: Ros2Message>(payload: &[u8]) -> Result<M, cdr_encoding::Error> {
        let (Wire(msg), _) = cdr_encoding::from_bytes::<Wire<M>, byteorder::LittleEndian>(
            payload.get(4..).unwrap_or_default(),
        )?;
        Ok(msg)
    }

    #[test]
    fn the_dds_payload_is_the_codec_s_payload_byte_for_byte() {
        let msg = scan();
        assert_eq!(dds_payload(&msg), to_cdr(&msg).unwrap());
        let twist = TwistMsg::unicycle(0.25, -0.5);
        assert_eq!(dds_payload(&twist), to_cdr(&twist).unwrap());
    }

    #[test]
    fn a_payload_read_through_serde_is_the_message() {
        let payload = to_cdr(&scan()).unwrap();
        let back: LaserScanMsg = from_dds_payload(&payload).unwrap();
        // The codec's own reading (the fields are f32 on the wire).
        assert_eq!(back, from_cdr::<LaserScanMsg>(&payload).unwrap());
    }

    #[test]
    fn a_truncated_payload_is_an_error_not_a_message() {
        let payload = to_cdr(&scan()).unwrap();
        for cut in [4, 10, payload.len() / 2, payload.len() - 3] {
            assert!(
                from_dds_payload::<LaserScanMsg>(&payload[..cut]).is_err(),
                "cut {cut}"
            );
        }
    }

    proptest::proptest! {
        #[test]
        fn any_bytes_decode_to_an_error_or_a_message_never_a_panic(
            body in proptest::collection::vec(proptest::num::u8::ANY, 0..200)
        ) {
            let mut payload = CDR_LE_HEADER.to_vec();
            payload.extend(body);
            let _ = from_dds_payload::<LaserScanMsg>(&payload);
            let _ = from_dds_payload::<TwistMsg>(&payload);
            let _ = from_dds_payload::<TwistStampedMsg>(&payload);
            let _ = from_dds_payload::<OdometryMsg>(&payload);
            let _ = from_dds_payload::<ImageMsg>(&payload);
            let _ = from_dds_payload::<CompressedImageMsg>(&payload);
            let _ = from_dds_payload::<Detection2DArrayMsg>(&payload);
        }

        #[test]
        fn a_scan_with_any_bytes_flipped_decodes_or_is_refused(
            at in 4usize..60, xor in 1u8..=255
        ) {
            let mut payload = to_cdr(&scan()).unwrap();
            let i = at.min(payload.len() - 1);
            payload[i] ^= xor;
            if let Ok(msg) = from_dds_payload::<LaserScanMsg>(&payload) {
                // Whatever decodes is a valid scan (finite geometry, one range per beam).
                proptest::prop_assert!(msg.scan.angle_increment_rad.is_finite());
                proptest::prop_assert_eq!(msg.scan.len(), msg.scan.ranges_m().len());
            }
        }
    }
}
