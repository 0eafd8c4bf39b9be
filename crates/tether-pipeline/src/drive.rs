//! The robot's side of a tick (design 6): whether it may follow, the virtual spring
//! or the held command, the obstacle stop, reversing only along its own trail, and
//! the limits of the base.

use tether_control::{PersonInRobot, SEARCH_RATE_RADPS, SafetyConfig, StopReason, Twist};
use tether_core::{Point2, Pose2, Robot, Stamp, Vector2, World, wrap_angle_rad};
use tether_fusion::TargetState;

use crate::{FusionMode, Pipeline, TargetView, follow};

/// The search for a lost target under way (design 6, safety 1): the heading at the
/// last tick, how far the robot has turned since the loss, and which way it searches
/// (+1 left, -1 right: the side where the target was last seen).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Search {
    last_yaw: f64,
    turned_rad: f64,
    direction: f64,
}

impl Pipeline {
    /// Why the robot may not follow (design 6, safety 1 and 2): no target yet, the
    /// target lost, or, while locked, the watchdogs (the newest scan or the target's
    /// last update too old), or the target unseen for longer than a missed scan or two
    /// with another person near where it should be. `None` when it may follow.
    pub(super) fn hold_reason(&self, stamp: Stamp, target: &TargetView) -> Option<StopReason> {
        let last_target_update = self.last_target_update(target);
        match target.state {
            TargetState::Searching => Some(StopReason::NoTarget),
            TargetState::Lost { .. } => Some(StopReason::TargetLost),
            TargetState::Locked { .. } => {
                let safety = &self.config.safety;
                safety
                    .watchdog(stamp, self.stalest_scan(), last_target_update)
                    .or_else(|| {
                        let unseen_s = stamp.secs_since(last_target_update?);
                        (unseen_s > safety.unseen_full_pace_s && self.another_could_be_it(target))
                            .then_some(StopReason::UnseenAmongOthers)
                    })
            }
        }
    }

    /// The last scan of the laser heard from least recently (`None` while one has not
    /// been heard at all): every scanner must be alive for the robot to drive, since
    /// each sees what the others cannot.
    fn stalest_scan(&self) -> Option<Stamp> {
        self.lasers.iter().map(|l| l.last_scan).min().flatten()
    }

    /// When the target's estimate last took in a measurement.
    fn last_target_update(&self, target: &TargetView) -> Option<Stamp> {
        match self.config.fusion.mode {
            FusionMode::Tracker => target
                .id
                .and_then(|id| self.tracker.track(id))
                .map(|t| t.last_update),
            FusionMode::PerFrame => self.per_frame_target.map(|(t, _)| t),
        }
    }

    /// The pace at which the robot follows the target (design 6, safety 2): 1 while it
    /// is seen and for `unseen_full_pace_s` after, then falling linearly to 0 at
    /// `target_timeout_s`, when the watchdog holds the robot. Meanwhile the robot
    /// follows the target where it should be (its track's prediction): a person does
    /// not stop walking because a scan missed their legs.
    ///
    /// `pace = clamp((T - t) / (T - t_full), 0, 1)`, `t` the time unseen.
    pub(super) fn unseen_pace(&self, stamp: Stamp, target: &TargetView) -> f64 {
        let safety = &self.config.safety;
        let Some(last) = self.last_target_update(target) else {
            return 1.0;
        };
        let unseen_s = stamp.secs_since(last);
        let fading_s = safety.target_timeout_s - safety.unseen_full_pace_s;
        if unseen_s <= safety.unseen_full_pace_s || fading_s <= 0.0 {
            return 1.0;
        }
        ((safety.target_timeout_s - unseen_s) / fading_s).clamp(0.0, 1.0)
    }

    /// Another confirmed track within `unseen_clear_m` of where the unseen target
    /// should be: following the guess could mean following them.
    fn another_could_be_it(&self, target: &TargetView) -> bool {
        let (Some(id), Some(estimate)) = (target.id, target.estimate) else {
            return false;
        };
        let clear_m = self.config.safety.unseen_clear_m;
        self.tracker.tracks().iter().any(|t| {
            t.id != id && t.confirmed && t.position().mean.distance_m(estimate.mean) < clear_m
        })
    }

    /// Records where the robot is and, while locked, where the target is: the trails
    /// the spring may steer along and the robot may back up onto (design 6, "Where the
    /// spring pulls").
    pub(super) fn record_trails(
        &mut self,
        stamp: Stamp,
        world_from_robot: Pose2<World, Robot>,
        target: &TargetView,
    ) {
        self.trails
            .record_robot(stamp, world_from_robot.translation());
        if let (Some(id), Some(estimate), TargetState::Locked { .. }) =
            (target.id, target.estimate, target.state)
        {
            self.trails.record_target(id, estimate.mean);
        }
    }

    /// The command that follows the target at `target_at` (world): the aim, straight at
    /// the target or along its trail when the laser sees something in the way, then one
    /// step of the virtual spring toward a person in the aim's direction at the
    /// (possibly along-the-trail) distance, damped relative to the target's speed
    /// (design 6).
    pub(super) fn follow(
        &mut self,
        world_from_robot: Pose2<World, Robot>,
        target_at: Point2<World>,
        target_velocity: Option<Vector2<World>>,
        dt_s: f64,
    ) -> Twist {
        let safety = &self.config.safety;
        let robot_from_world = world_from_robot.inverse();
        let attach = world_from_robot * Point2::new(self.config.follower.attach_ahead_m, 0.0);
        // Only returns nearer than the target (plus a margin) can stand between.
        let reach_m = (robot_from_world * target_at).range_m() + 1.0;
        let mut obstacles = std::mem::take(&mut self.obstacles_in_world);
        follow::keep_mapped(
            &self.lasers[0].returns,
            |p| p.range_at_most(reach_m),
            world_from_robot.point_map(),
            &mut obstacles,
        );
        for side in &self.lasers[1..] {
            obstacles.extend(
                side.returns
                    .iter()
                    .filter(|p| p.range_at_most(reach_m))
                    .map(|p| world_from_robot * *p),
            );
        }
        let aim = self.trails.aim(
            world_from_robot,
            attach,
            target_at,
            &obstacles,
            safety.robot_radius_m + safety.corridor_margin_m,
            self.config.follower_always_trail,
        );
        self.obstacles_in_world = obstacles;
        // The spring sees a person in the aim's direction at the (possibly
        // along-the-trail) distance.
        let direction = aim.point - attach;
        let norm = direction.norm().max(1e-6);
        let virtual_person = robot_from_world * (attach + direction * (aim.distance_m / norm));
        let vx = target_velocity.map_or(0.0, |v| robot_from_world.rotate(v).x);
        let (v, w) = self.spring.step(
            &PersonInRobot {
                x_m: virtual_person.x,
                y_m: virtual_person.y,
                vx_mps: vx,
            },
            dt_s,
        );
        Twist {
            v_mps: v,
            w_radps: w,
        }
    }

    /// The command while the robot is held: the spring is reset, and the robot stands,
    /// except that after a loss it turns on the spot: for `search_turn_s` toward where
    /// the target should be, then, with the opt-in search, on toward the side where it
    /// was last seen until it has turned `search_rotate_rad` since the loss or
    /// `search_rotate_s` have passed (design 6, safety 1; design 11.3).
    pub(super) fn held_command(
        &mut self,
        stamp: Stamp,
        world_from_robot: Pose2<World, Robot>,
        state: TargetState,
    ) -> Twist {
        self.spring.reset();
        let TargetState::Lost { since, .. } = state else {
            self.search = None;
            return Twist::STOP;
        };
        let safety = &self.config.safety;
        let lost_s = stamp.secs_since(since);
        // Turning in place sweeps no new ground.
        let bearing = self
            .selector
            .lost_prediction(stamp)
            .map(|p| (world_from_robot.inverse() * p.mean).bearing_rad());
        let yaw = world_from_robot.yaw;
        let search = self.search.get_or_insert(Search {
            last_yaw: yaw,
            turned_rad: 0.0,
            direction: bearing.map_or(1.0, f64::signum),
        });
        search.turned_rad += wrap_angle_rad(yaw - search.last_yaw).abs();
        search.last_yaw = yaw;
        let turn = |w_radps: f64| Twist {
            v_mps: 0.0,
            w_radps,
        };
        if lost_s <= safety.search_turn_s {
            // The look: it may have stepped out of the sensors' field of view beside
            // the robot.
            return match bearing {
                Some(b) if b.abs() > 0.2 => turn((1.5 * b).clamp(-1.0, 1.0)),
                _ => Twist::STOP,
            };
        }
        if safety.search_rotate_rad > 0.0
            && lost_s <= safety.search_rotate_s
            && search.turned_rad < safety.search_rotate_rad
        {
            return turn(search.direction * SEARCH_RATE_RADPS);
        }
        Twist::STOP
    }

    /// The obstacle stop (design 6, safety 3): true when a return of any laser's last
    /// scan lies in the straight corridor ahead of the footprint or on the arc it sweeps,
    /// within the stop distance plus the braking distance, for the `desired` motion or
    /// the one the robot is still rolling with (a smooth stop takes a moment).
    pub(super) fn obstacle_in_the_way(&self, desired: Twist) -> bool {
        let safety = &self.config.safety;
        let current = self.motion.twist;
        let decel = self.config.limits.max_decel_mps2;
        let blocked = |v: f64, w: f64| {
            // The free space needed grows with the braking distance at this speed.
            let reach = SafetyConfig {
                stop_distance_m: safety.stop_distance_m + v * v / (2.0 * decel),
                ..safety.clone()
            };
            v > 0.0
                && self.lasers.iter().any(|side| {
                    let near = &side.near;
                    reach.obstacle_ahead_m(near.iter().copied()).is_some()
                        || reach.obstacle_on_arc_m(near, v, w).is_some()
                })
        };
        blocked(desired.v_mps, desired.w_radps) || blocked(current.v_mps, current.w_radps)
    }

    /// How far from the robot a return can be in the way within the stop distance
    /// (design 6, safety 3): the footprint's reach at the highest speed, m.
    pub(super) fn obstacle_reach_m(&self) -> f64 {
        let safety = &self.config.safety;
        let top = self.config.limits.max_speed_mps;
        safety.robot_radius_m
            + safety.corridor_margin_m
            + safety.stop_distance_m
            + top * top / (2.0 * self.config.limits.max_decel_mps2)
    }

    /// The reverse rule (design 6, safety 4): the laser does not see behind, so the
    /// robot backs up only onto its own path, driven over more than half a second ago.
    pub(super) fn may_reverse(&self, stamp: Stamp, world_from_robot: Pose2<World, Robot>) -> bool {
        self.trails
            .may_reverse(stamp, world_from_robot, self.config.safety.robot_radius_m)
    }

    /// The limits of the base (design 6, "Limits"; safety 5), without the jerk limit in
    /// an `emergency`; the spring is told what was commanded so that it cannot wind up,
    /// and the result is the tick's command.
    pub(super) fn apply_limits(&mut self, desired: Twist, dt_s: f64, emergency: bool) -> Twist {
        self.motion = self
            .config
            .limits
            .apply_smooth(self.motion, desired, dt_s, emergency);
        let command = self.motion.twist;
        self.spring.sync(command.v_mps, command.w_radps);
        self.command = command;
        command
    }
}
