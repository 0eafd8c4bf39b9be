//! The laser's side of a tick (design 5.5): the people found in a scan become
//! observations in the world frame, those standing in learned static clutter are left
//! out, those the last scan could not see are marked as coming out of a shadow, the
//! tracker takes them, tracks this scan could not see are marked as hidden
//! ([`Shadow`]), and the clutter maps learn what no walking person explains.

use tether_core::{Gaussian2, Laser, Point2, Pose2, Robot, Stamp, World};
use tether_fusion::{Observation, Shadow, TargetState};

use crate::{FusionMode, LaserPerson, Pipeline, Tick, TickInput, follow};

impl Pipeline {
    /// The people found in one scan (laser frame) and the scan's returns (robot frame,
    /// for the obstacle stop), with the robot's pose at the scan's stamp.
    pub fn on_laser_people(
        &mut self,
        stamp: Stamp,
        people: &[LaserPerson],
        obstacles_in_robot: &[Point2<Robot>],
        world_from_robot: Pose2<World, Robot>,
    ) -> Tick {
        if !self.accept(stamp, world_from_robot) {
            return self.idle_tick(stamp, TickInput::Scan);
        }
        self.scan_gap_s = self.last_scan.map_or(0.0, |t| stamp.secs_since(t));
        self.last_scan = Some(stamp);
        let world_from_laser = world_from_robot * self.config.laser.robot_from_laser();
        let world: Vec<Gaussian2<World>> = people
            .iter()
            .map(|p| p.estimate.transformed(world_from_laser))
            .collect();
        let near_m = self.obstacle_reach_m();
        follow::keep_mapped(
            obstacles_in_robot,
            |p| p.range_at_most(near_m),
            |p| p,
            &mut self.near_obstacles,
        );
        // People standing in learned static clutter are clutter: they neither start nor
        // feed tracks (a coasting track walking past a bush must not take it).
        let mut used = Vec::with_capacity(people.len());
        for (p, g) in people.iter().zip(&world) {
            let clutter = self.clutter_world.is_static(g.mean, stamp)
                || self.clutter_laser.is_static(p.estimate.mean, stamp);
            self.stats.clutter_observations += u64::from(clutter);
            used.push(!clutter);
        }
        let tracking =
            self.config.fusion.use_laser && self.config.fusion.mode == FusionMode::Tracker;
        let lone_spawns = self.config.fusion.lone_legs_spawn_tracks;
        let observations: Vec<Observation> = people
            .iter()
            .zip(&world)
            .zip(&used)
            .filter(|(_, used)| **used)
            .map(|((p, g), _)| Observation {
                from_shadow: self.hidden_at_last_scan(g.mean),
                ..match p.weak {
                    true => Observation::weak_laser(*g),
                    false => Observation::laser(*g, p.two_legs, lone_spawns),
                }
            })
            .collect();
        // This scan is the last one from now on.
        self.last_scan_pose = Some(world_from_robot);
        self.obstacle_points.clear();
        self.obstacle_points.extend_from_slice(obstacles_in_robot);
        let track_of = if tracking {
            let track_of = self.tracker.process(stamp, &observations).track_of;
            // Tracks behind the scan's returns went unseen because they could not be seen.
            let robot_from_world = world_from_robot.inverse();
            let shadow = self.shadow_of(obstacles_in_robot);
            self.tracker
                .note_shadow(stamp, |p| shadow.hides(robot_from_world * p));
            track_of
        } else {
            self.tracker.advance(stamp);
            vec![None; observations.len()]
        };
        self.learn_clutter(stamp, people, &world, &used, &track_of);
        // The people this scan reports (and carries to the next camera frame): the
        // strong observations that were used.
        let (laser_people, track_of): (Vec<Gaussian2<World>>, Vec<Option<u64>>) = observations
            .iter()
            .zip(&track_of)
            .filter(|(o, _)| !o.weak)
            .map(|(o, id)| (o.estimate, *id))
            .unzip();
        let motion = |id: Option<u64>| {
            let t = self.tracker.track(id?)?;
            Some((t.velocity(), t.filter.velocity_cov()?))
        };
        self.last_laser_people = Some((
            stamp,
            laser_people
                .iter()
                .zip(&track_of)
                .map(|(g, id)| (*g, motion(*id), *id))
                .collect(),
        ));
        let mut tick = self.finish(stamp, TickInput::Scan, world_from_robot);
        tick.laser_people = laser_people;
        tick
    }

    /// The shadows cast by a scan's returns (robot frame) as seen from the scanner.
    fn shadow_of<'a>(&self, returns_in_robot: &'a [Point2<Robot>]) -> Shadow<'a, Robot> {
        let scanner = self.config.laser.robot_from_laser() * Point2::<Laser>::ORIGIN;
        let margin_m = self.tracker.config().shadow_margin_m;
        Shadow::new(scanner, returns_in_robot, margin_m)
    }

    /// Whether the last scan could not see `p` (a person found there now comes out
    /// from behind something).
    fn hidden_at_last_scan(&self, p: Point2<World>) -> bool {
        self.last_scan_pose.is_some_and(|world_from_robot| {
            self.shadow_of(&self.obstacle_points).hides_near(
                world_from_robot.inverse() * p,
                self.tracker.config().shadow_edge_m,
            )
        })
    }

    /// Teaches the clutter maps this scan's people, except those a walking person (or
    /// the target) explains: the track they updated, or one within half a metre.
    fn learn_clutter(
        &mut self,
        stamp: Stamp,
        people: &[LaserPerson],
        world: &[Gaussian2<World>],
        used: &[bool],
        track_of_used: &[Option<u64>],
    ) {
        if !self.config.clutter.enabled {
            return;
        }
        let target = match self.selector.state() {
            TargetState::Locked { track } | TargetState::Lost { track, .. } => Some(track),
            TargetState::Searching => None,
        };
        let min_walked_m = self.config.target.min_walked_m;
        let protected: Vec<(u64, Point2<World>)> = self
            .tracker
            .tracks()
            .iter()
            .filter(|t| Some(t.id) == target || (t.confirmed && t.walked_m >= min_walked_m))
            .map(|t| (t.id, t.position().mean))
            .collect();
        let mut track_of = track_of_used.iter();
        let (mut in_world, mut in_laser) = (Vec::new(), Vec::new());
        for ((p, g), &was_used) in people.iter().zip(world).zip(used) {
            let updated = if was_used {
                track_of.next().copied().flatten()
            } else {
                None
            };
            let explained = protected
                .iter()
                .any(|(id, q)| updated == Some(*id) || q.distance_m(g.mean) < 0.5);
            if !explained {
                in_world.push(g.mean);
                in_laser.push(p.estimate.mean);
            }
        }
        self.clutter_world.observe(stamp, &in_world);
        self.clutter_laser.observe(stamp, &in_laser);
    }
}
