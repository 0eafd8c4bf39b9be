//! The robot's pose on a base that reports no odometry: dead reckoning of the commanded
//! velocities.
//!
//! Each command is taken to be driven exactly from the moment it is sent until the next
//! one (a unicycle along an arc). That ignores the base's own acceleration limits, its
//! latency and wheel slip, so the pose drifts; the pipeline only needs it to be
//! consistent over the few seconds a track lives (people are tracked in this frame, and
//! the trail the robot follows is kept in it), not to be a map.

use std::collections::VecDeque;

use tether_control::Twist;
use tether_core::{Pose2, Robot, Stamp, World, wrap_angle_rad};

/// One command held from `start` on, starting at `pose`.
#[derive(Debug, Clone, Copy)]
struct Segment {
    start: Stamp,
    pose: Pose2<World, Robot>,
    twist: Twist,
}

/// How long the history of commands reaches back, ns (poses are asked for at the stamps
/// of scans and camera frames, which arrive after they were taken).
const HISTORY_NS: i64 = 5_000_000_000;

/// Dead reckoning of the commanded velocities, with a short history so that the pose at
/// a sensor's (past) stamp can be looked up.
#[derive(Debug, Clone)]
pub struct DeadReckoning {
    segments: VecDeque<Segment>,
}

/// The pose after driving `twist` for `dt_s` from `pose` (exact along the arc).
pub fn integrate(pose: Pose2<World, Robot>, twist: Twist, dt_s: f64) -> Pose2<World, Robot> {
    let (v, w) = (twist.v_mps, twist.w_radps);
    if !(v.is_finite() && w.is_finite() && dt_s.is_finite()) {
        return pose;
    }
    let yaw = pose.yaw;
    let (dx, dy) = if (w * dt_s).abs() < 1e-9 {
        (v * dt_s * yaw.cos(), v * dt_s * yaw.sin())
    } else {
        let r = v / w;
        let end = yaw + w * dt_s;
        (r * (end.sin() - yaw.sin()), -r * (end.cos() - yaw.cos()))
    };
    Pose2::new(pose.x + dx, pose.y + dy, wrap_angle_rad(yaw + w * dt_s))
}

impl DeadReckoning {
    /// Standing at the origin from `start`.
    pub fn new(start: Stamp) -> Self {
        let mut segments = VecDeque::new();
        segments.push_back(Segment {
            start,
            pose: Pose2::IDENTITY,
            twist: Twist::STOP,
        });
        DeadReckoning { segments }
    }

    /// The pose at `t`: before the history's start, its first pose.
    pub fn pose_at(&self, t: Stamp) -> Pose2<World, Robot> {
        let Some(segment) = self
            .segments
            .iter()
            .rev()
            .find(|s| s.start <= t)
            .or(self.segments.front())
        else {
            return Pose2::IDENTITY;
        };
        let dt_s = t.secs_since(segment.start).max(0.0);
        integrate(segment.pose, segment.twist, dt_s)
    }

    /// The command currently driven.
    pub fn twist(&self) -> Twist {
        self.segments.back().map_or(Twist::STOP, |s| s.twist)
    }

    /// From `t` on the robot drives `twist` (a `t` before the last command counts as
    /// the last command's time).
    pub fn set_command(&mut self, t: Stamp, twist: Twist) {
        let Some(last) = self.segments.back().copied() else {
            return;
        };
        if last.twist == twist {
            return;
        }
        let t = t.max(last.start);
        self.segments.push_back(Segment {
            start: t,
            pose: self.pose_at(t),
            twist,
        });
        while self.segments.len() > 2
            && self
                .segments
                .get(1)
                .is_some_and(|s| t.ns_since(s.start) > HISTORY_NS)
        {
            self.segments.pop_front();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(secs: f64) -> Stamp {
        Stamp::from_ns((secs * 1e9).round() as i64)
    }

    #[test]
    fn straight_then_quarter_turn() {
        let mut dr = DeadReckoning::new(s(10.0));
        dr.set_command(
            s(10.0),
            Twist {
                v_mps: 1.0,
                w_radps: 0.0,
            },
        );
        let p = dr.pose_at(s(12.0));
        assert!((p.x - 2.0).abs() < 1e-9 && p.y.abs() < 1e-9, "{p:?}");
        // A quarter circle of radius 1 to the left.
        let w = std::f64::consts::FRAC_PI_2;
        dr.set_command(
            s(12.0),
            Twist {
                v_mps: w,
                w_radps: w,
            },
        );
        let p = dr.pose_at(s(13.0));
        assert!(
            (p.x - 3.0).abs() < 1e-9 && (p.y - 1.0).abs() < 1e-9,
            "{p:?}"
        );
        assert!((p.yaw - w).abs() < 1e-9);
        // Looking back into the history.
        let p = dr.pose_at(s(11.0));
        assert!((p.x - 1.0).abs() < 1e-9, "{p:?}");
        let p = dr.pose_at(s(9.0));
        assert_eq!(p.x, 0.0);
    }

    #[test]
    fn history_is_bounded() {
        let mut dr = DeadReckoning::new(s(0.0));
        for k in 0..2000 {
            let v = if k % 2 == 0 { 0.5 } else { 0.6 };
            dr.set_command(
                s(0.05 * f64::from(k)),
                Twist {
                    v_mps: v,
                    w_radps: 0.0,
                },
            );
        }
        assert!(dr.segments.len() <= 102, "{}", dr.segments.len());
        let p = dr.pose_at(s(100.0));
        assert!((p.x - 55.0).abs() < 0.1, "{p:?}");
    }
}
