//! `geometry_msgs/msg/PoseStamped`: one pose with its time and frame, what Nav2's
//! Following Server reads on the topic its `FollowObject` goal names (`tether ros2`
//! publishes the target on `tether/target_pose`, design 12).

use super::*;

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseStampedMsg {
    /// ROS header: the time of the data and the frame the pose is in.
    pub header: Header,
    /// The pose.
    pub pose: Pose3,
}

impl Ros2Message for PoseStampedMsg {
    const TYPE: &'static str = "geometry_msgs/msg/PoseStamped";
    const DEFINITION: &'static str = concat!(
        "std_msgs/Header header\n",
        "Pose pose\n",
        header_def!(),
        pose_def!()
    );

    fn write_cdr(&self, w: &mut CdrWriter) -> Result<(), EncodeError> {
        self.header.write(w)?;
        write_pose(w, &self.pose);
        Ok(())
    }

    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, DecodeError> {
        Ok(PoseStampedMsg {
            header: Header::read(r)?,
            pose: read_pose(r, "pose")?,
        })
    }

    fn header_stamp(&self) -> Option<Stamp> {
        Some(self.header.stamp)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    #[test]
    fn a_pose_stamped_round_trips_through_cdr() {
        let msg = PoseStampedMsg {
            header: Header::new(Stamp::from_ns(3_000_000_001), "odom"),
            pose: Pose3::planar(1.25, -0.5, 0.75),
        };
        let bytes = to_cdr(&msg).unwrap();
        // Encapsulation (4), stamp (8), "odom" with its length and NUL (9), padding to a
        // multiple of 8 for the doubles (7), seven f64 (56).
        assert_eq!(bytes.len(), 4 + 8 + 9 + 7 + 56);
        assert_eq!(from_cdr::<PoseStampedMsg>(&bytes).unwrap(), msg);
    }
}
