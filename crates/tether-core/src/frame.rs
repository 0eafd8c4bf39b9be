//! Coordinate frames as zero-sized marker types.
//!
//! A [`Point2<F>`](crate::Point2) lives in frame `F`; a
//! [`Pose2<To, From>`](crate::Pose2) maps points of `From` into `To`. Names read right
//! to left, as in design section 1: `point_in_robot = robot_from_laser * point_in_laser`.
//! All frames follow REP 103: x forward, y left, z up, angles counter-clockwise.

/// A coordinate frame known at compile time.
pub trait Frame: Copy + Clone + std::fmt::Debug + Default + PartialEq + 'static {
    /// The frame's name as it appears in files and messages (`frame_id`).
    const NAME: &'static str;
}

macro_rules! frames {
    ($($(#[$doc:meta])* $name:ident => $text:literal;)*) => {$(
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
        pub struct $name;
        impl Frame for $name {
            const NAME: &'static str = $text;
        }
    )*};
}

frames! {
    /// The fixed world (map or odometry) frame in which people and the robot move.
    World => "world";
    /// The robot's body frame: origin at the middle of the wheel axis, x forward.
    Robot => "base_link";
    /// The laser's frame: origin at the scanner's centre, x along its front beam
    /// (step 384 on the URG-04LX).
    Laser => "laser";
    /// The camera's ground frame: origin at the lens centre, x along the horizontal
    /// projection of the optical axis, y left, z up. The optical frame (z forward,
    /// x right, y down) is this frame pitched up by the camera's tilt.
    Camera => "camera";
}
