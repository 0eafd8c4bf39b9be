//! The robot's base: differential drive with wheel speed and acceleration limits.

use serde::{Deserialize, Serialize};
use tether_core::{Pose2, Robot, World, wrap_angle_rad};

use crate::scenario::RobotSpec;
use crate::world::StaticWorld;

/// A velocity command as `geometry_msgs/Twist` carries it on `/cmd_vel`: forward speed
/// and counter-clockwise turn rate.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Command {
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Turn rate, rad/s.
    pub w_radps: f64,
}

impl Command {
    /// Zero velocity.
    pub const STOP: Command = Command {
        v_mps: 0.0,
        w_radps: 0.0,
    };
}

/// A differential-drive base.
///
/// Wheel speeds from a command: `v_r = v + w b / 2`, `v_l = v - w b / 2` (design 6, track
/// width `b`). Both are scaled down together when one exceeds the top speed (which
/// keeps the curvature), then both wheels approach their targets by the same fraction,
/// limited so that neither accelerates faster than the limit.
/// The pose is integrated exactly along the resulting arc.
#[derive(Debug, Clone)]
pub struct DiffDrive {
    world_from_robot: Pose2<World, Robot>,
    wheel_left_mps: f64,
    wheel_right_mps: f64,
    command: Command,
    /// Footprint radius, m.
    pub radius_m: f64,
    track_width_m: f64,
    max_wheel_speed_mps: f64,
    max_wheel_accel_mps2: f64,
    command_timeout_s: f64,
    since_command_s: f64,
    blocked: bool,
}

impl DiffDrive {
    /// A robot at the scenario's start pose, at rest.
    pub fn from_spec(spec: &RobotSpec) -> Self {
        DiffDrive {
            world_from_robot: Pose2::new(spec.start.x, spec.start.y, spec.start.yaw_rad),
            wheel_left_mps: 0.0,
            wheel_right_mps: 0.0,
            command: Command::STOP,
            radius_m: spec.radius_m,
            track_width_m: spec.track_width_m,
            max_wheel_speed_mps: spec.max_wheel_speed_mps,
            max_wheel_accel_mps2: spec.max_wheel_accel_mps2,
            command_timeout_s: spec.command_timeout_s,
            since_command_s: 0.0,
            blocked: false,
        }
    }

    /// Sets the command followed from now on. Non-finite commands stop the robot. Like
    /// a real base driver, the robot stops by itself when no command has come for
    /// `command_timeout_s`.
    pub fn set_command(&mut self, command: Command) {
        self.since_command_s = 0.0;
        self.command = if command.v_mps.is_finite() && command.w_radps.is_finite() {
            command
        } else {
            Command::STOP
        };
    }

    /// The command being followed.
    pub fn command(&self) -> Command {
        self.command
    }

    /// Pose in the world.
    pub fn pose(&self) -> Pose2<World, Robot> {
        self.world_from_robot
    }

    /// Actual forward speed and turn rate.
    pub fn velocity(&self) -> Command {
        Command {
            v_mps: 0.5 * (self.wheel_right_mps + self.wheel_left_mps),
            w_radps: (self.wheel_right_mps - self.wheel_left_mps) / self.track_width_m,
        }
    }

    /// Actual wheel speeds (left, right), m/s.
    pub fn wheel_speeds_mps(&self) -> (f64, f64) {
        (self.wheel_left_mps, self.wheel_right_mps)
    }

    /// True when the last step ran into a wall or an obstacle.
    pub fn blocked(&self) -> bool {
        self.blocked
    }

    /// Advances by `dt_s`. Returns true when the robot hit something: it then stays
    /// where it was, with its wheels stopped.
    pub fn step(&mut self, dt_s: f64, world: &StaticWorld) -> bool {
        self.since_command_s += dt_s;
        if self.since_command_s > self.command_timeout_s {
            self.command = Command::STOP;
        }
        let half_b = 0.5 * self.track_width_m;
        let mut right = self.command.v_mps + self.command.w_radps * half_b;
        let mut left = self.command.v_mps - self.command.w_radps * half_b;
        let peak = right.abs().max(left.abs());
        if peak > self.max_wheel_speed_mps {
            let k = self.max_wheel_speed_mps / peak;
            right *= k;
            left *= k;
        }
        // Both wheels move towards their targets by the same fraction, limited so that
        // neither changes faster than the acceleration limit: the curvature of the
        // path blends smoothly instead of jumping while one wheel catches up.
        let (d_right, d_left) = (right - self.wheel_right_mps, left - self.wheel_left_mps);
        let largest = d_right.abs().max(d_left.abs());
        let k = if largest > 0.0 {
            (self.max_wheel_accel_mps2 * dt_s / largest).min(1.0)
        } else {
            0.0
        };
        self.wheel_right_mps += k * d_right;
        self.wheel_left_mps += k * d_left;
        let Command {
            v_mps: v,
            w_radps: w,
        } = self.velocity();
        let p = self.world_from_robot;
        let (x, y) = if w.abs() < 1e-9 {
            (p.x + v * dt_s * p.yaw.cos(), p.y + v * dt_s * p.yaw.sin())
        } else {
            let r = v / w;
            let yaw1 = p.yaw + w * dt_s;
            (
                p.x + r * (yaw1.sin() - p.yaw.sin()),
                p.y - r * (yaw1.cos() - p.yaw.cos()),
            )
        };
        let next = Pose2::new(x, y, wrap_angle_rad(p.yaw + w * dt_s));
        // A move that brings the footprint into contact, or deeper into it, is refused.
        let clearance_next = world.clearance_m(next.translation());
        if clearance_next < self.radius_m && clearance_next < world.clearance_m(p.translation()) {
            self.wheel_left_mps = 0.0;
            self.wheel_right_mps = 0.0;
            self.blocked = true;
            return true;
        }
        self.blocked = false;
        self.world_from_robot = next;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn robot() -> DiffDrive {
        DiffDrive::from_spec(&RobotSpec::default())
    }

    /// Drives with `command` re-sent every step, as a controller would.
    fn drive(r: &mut DiffDrive, world: &StaticWorld, command: Command, steps: usize) -> bool {
        let mut hit = false;
        for _ in 0..steps {
            r.set_command(command);
            hit |= r.step(0.01, world);
        }
        hit
    }

    #[test]
    fn drives_a_circle_of_the_commanded_curvature() {
        let mut r = robot();
        let world = StaticWorld::default();
        let cmd = Command {
            v_mps: 0.5,
            w_radps: 0.5,
        };
        drive(&mut r, &world, cmd, 300);
        // On the radius 1 m circle about (0, 1), about 1.45 m along it.
        let p = r.pose();
        let d = ((p.x - 0.0).powi(2) + (p.y - 1.0).powi(2)).sqrt();
        assert!((d - 1.0).abs() < 0.02, "{d}");
        assert!((p.yaw - 1.45).abs() < 0.05, "turned {}", p.yaw);
    }

    #[test]
    fn saturation_keeps_curvature_and_acceleration_is_limited() {
        let mut r = robot();
        let world = StaticWorld::default();
        let fast = Command {
            v_mps: 5.0,
            w_radps: 5.0,
        };
        let spec = RobotSpec::default();
        drive(&mut r, &world, fast, 1);
        let (l, rr) = r.wheel_speeds_mps();
        // The faster wheel gains exactly its acceleration limit in one 10 ms step.
        let first_step_mps = spec.max_wheel_accel_mps2 * 0.01;
        assert!((rr - first_step_mps).abs() < 1e-12, "{rr}");
        drive(&mut r, &world, fast, 500);
        let (l2, r2) = r.wheel_speeds_mps();
        assert!((r2 - spec.max_wheel_speed_mps).abs() < 1e-9, "{r2}");
        let v = r.velocity();
        assert!((v.w_radps / v.v_mps - 1.0).abs() < 1e-9, "curvature kept");
        assert!(l < rr && l2 < r2);
    }

    #[test]
    fn stops_at_walls() {
        let scenario = crate::Scenario::builtin("corridor").unwrap();
        let world = StaticWorld::from_scenario(&scenario);
        let mut r = DiffDrive::from_spec(&scenario.robot);
        r.set_command(Command {
            v_mps: 0.0,
            w_radps: 0.0,
        });
        // Turn towards the side wall and drive into it.
        r.world_from_robot = Pose2::new(r.pose().x, r.pose().y, std::f64::consts::FRAC_PI_2);
        let forward = Command {
            v_mps: 1.0,
            w_radps: 0.0,
        };
        let hit = drive(&mut r, &world, forward, 1000);
        assert!(hit && r.blocked());
        assert!(!world.disc_collides(r.pose().translation(), r.radius_m));
    }

    #[test]
    fn stops_by_itself_when_commands_stop_coming() {
        let mut r = robot();
        let world = StaticWorld::default();
        r.set_command(Command {
            v_mps: 0.5,
            w_radps: 0.0,
        });
        for _ in 0..40 {
            r.step(0.01, &world);
        }
        assert_eq!(r.command().v_mps, 0.5);
        for _ in 0..100 {
            r.step(0.01, &world);
        }
        assert_eq!(r.command(), Command::STOP);
        assert!(r.velocity().v_mps.abs() < 1e-9);
    }

    #[test]
    fn nan_command_stops() {
        let mut r = robot();
        r.set_command(Command {
            v_mps: f64::NAN,
            w_radps: 0.0,
        });
        assert_eq!(r.command(), Command::STOP);
    }
}
