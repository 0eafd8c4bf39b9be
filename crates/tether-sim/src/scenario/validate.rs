//! [`Scenario::validate`]: the checks of a parsed scenario (design 7: a bad file is
//! refused with its field), one function per part of the file, run in file order so
//! that the first problem reported is the first in the file as far as possible.

use tether_core::{LaserModel, Point2, World};

use super::{DriverKind, FieldSeg, MAX_WORLD_EXTENT_M, PersonSpec, Problem, Scenario, XY, point};
use crate::geometry::{Segment, segment_circle_distance_m, segments_intersect};

/// Space a walking person needs on each side of their path: half the widest leg spread
/// plus a leg radius, m.
const PERSON_CLEARANCE_M: f64 = 0.2;

/// The problems found so far, in the order found.
#[derive(Default)]
struct Problems(Vec<Problem>);

impl Problems {
    /// Records a problem with `field`.
    fn bad(&mut self, field: Vec<FieldSeg>, message: String) {
        self.0.push(Problem { field, message });
    }
}

impl Scenario {
    /// Every problem found, in file order as far as possible. Empty when the scenario
    /// can be simulated.
    pub fn validate(&self) -> Vec<Problem> {
        let mut problems = Problems::default();
        self.check_duration(&mut problems);
        self.check_walls(&mut problems);
        self.check_round_obstacles(&mut problems);
        self.check_tables(&mut problems);
        self.check_chairs(&mut problems);
        let walls = self.wall_segments();
        let bounds = self.bounds();
        self.check_robot(&mut problems, bounds);
        self.check_sensor_models(&mut problems);
        self.check_laser_sim(&mut problems);
        self.check_camera_sim(&mut problems);
        self.check_target(&mut problems);
        let pillars: Vec<(Point2<World>, f64)> = self
            .world
            .pillars
            .iter()
            .map(|c| (point(c.center), c.radius_m))
            .collect();
        for (pi, p) in self.people.iter().enumerate() {
            check_person(&mut problems, pi, p, &walls, &pillars, bounds);
        }
        problems.0
    }

    /// `duration_s`: more than 0 s and at most a day.
    fn check_duration(&self, problems: &mut Problems) {
        if !(self.duration_s.is_finite()
            && self.duration_s > 0.0
            && self.duration_s <= 24.0 * 3600.0)
        {
            problems.bad(
                path!["duration_s"],
                format!(
                    "must be more than 0 s and at most 86400 s (a day), got {}",
                    self.duration_s
                ),
            );
        }
    }

    /// `world.rooms` and `world.walls`: finite corners and ends near the origin, rooms
    /// with `max` beyond `min`, walls with two different ends.
    fn check_walls(&self, problems: &mut Problems) {
        let w = &self.world;
        for (i, room) in w.rooms.iter().enumerate() {
            if !all_finite(&[room.min[0], room.min[1], room.max[0], room.max[1]]) {
                problems.bad(
                    path!["world", "rooms", i],
                    "corners must be finite numbers".into(),
                );
            } else if !near(&[room.min[0], room.min[1], room.max[0], room.max[1]]) {
                problems.bad(path!["world", "rooms", i], format!("corners {}", far()));
            } else if room.min[0] >= room.max[0] || room.min[1] >= room.max[1] {
                problems.bad(
                    path!["world", "rooms", i, "max"],
                    "max must be greater than min in x and y".into(),
                );
            }
        }
        for (i, wall) in w.walls.iter().enumerate() {
            if !all_finite(&[wall.from[0], wall.from[1], wall.to[0], wall.to[1]]) {
                problems.bad(
                    path!["world", "walls", i],
                    "ends must be finite numbers".into(),
                );
            } else if !near(&[wall.from[0], wall.from[1], wall.to[0], wall.to[1]]) {
                problems.bad(path!["world", "walls", i], format!("ends {}", far()));
            } else if wall.from == wall.to {
                problems.bad(
                    path!["world", "walls", i, "to"],
                    "a wall needs two different ends".into(),
                );
            }
        }
    }

    /// `world.pillars`, `posts`, `bins` and `bushes`: a finite centre near the origin
    /// and a radius of at most 5 m.
    fn check_round_obstacles(&self, problems: &mut Problems) {
        let w = &self.world;
        for (kind, list) in [
            ("pillars", &w.pillars),
            ("posts", &w.posts),
            ("bins", &w.bins),
            ("bushes", &w.bushes),
        ] {
            for (i, c) in list.iter().enumerate() {
                if !all_finite(&c.center) {
                    problems.bad(path!["world", kind, i, "center"], "must be finite".into());
                } else if !near(&c.center) {
                    problems.bad(path!["world", kind, i, "center"], far());
                }
                if !(c.radius_m.is_finite() && c.radius_m > 0.0 && c.radius_m <= 5.0) {
                    problems.bad(
                        path!["world", kind, i, "radius_m"],
                        format!(
                            "radius must be a positive number of metres (at most 5), got {}",
                            c.radius_m
                        ),
                    );
                }
            }
        }
    }

    /// `world.tables`: a finite pose, sides of at most 10 m, legs thinner than a
    /// quarter of the shorter side.
    fn check_tables(&self, problems: &mut Problems) {
        for (i, t) in self.world.tables.iter().enumerate() {
            if !all_finite(&[t.center[0], t.center[1], t.yaw_rad]) {
                problems.bad(
                    path!["world", "tables", i],
                    "center and yaw_rad must be finite".into(),
                );
            }
            if !(t
                .size_m
                .iter()
                .all(|s| s.is_finite() && *s > 0.0 && *s <= 10.0))
            {
                problems.bad(
                    path!["world", "tables", i, "size_m"],
                    format!(
                        "both sides must be positive (at most 10 m), got {:?}",
                        t.size_m
                    ),
                );
            }
            if !(t.leg_radius_m.is_finite()
                && t.leg_radius_m > 0.0
                && t.leg_radius_m < 0.25 * t.size_m[0].min(t.size_m[1]))
            {
                problems.bad(
                    path!["world", "tables", i, "leg_radius_m"],
                    format!(
                        "must be positive and under a quarter of the table's shorter side, got {}",
                        t.leg_radius_m
                    ),
                );
            }
        }
    }

    /// `world.chairs`: a finite pose, a seat of at most 3 m, legs thinner than a
    /// quarter of the seat.
    fn check_chairs(&self, problems: &mut Problems) {
        for (i, c) in self.world.chairs.iter().enumerate() {
            if !all_finite(&[c.center[0], c.center[1], c.yaw_rad]) {
                problems.bad(
                    path!["world", "chairs", i],
                    "center and yaw_rad must be finite".into(),
                );
            }
            if !(c.size_m.is_finite() && c.size_m > 0.0 && c.size_m <= 3.0) {
                problems.bad(
                    path!["world", "chairs", i, "size_m"],
                    format!("must be positive (at most 3 m), got {}", c.size_m),
                );
            }
            if !(c.leg_radius_m.is_finite()
                && c.leg_radius_m > 0.0
                && c.leg_radius_m < 0.25 * c.size_m)
            {
                problems.bad(
                    path!["world", "chairs", i, "leg_radius_m"],
                    format!(
                        "must be positive and under a quarter of the seat size, got {}",
                        c.leg_radius_m
                    ),
                );
            }
        }
    }

    /// `robot`: a finite start inside the walls, positive sizes and speeds within
    /// their ranges, and a script (for the scripted driver) in time order.
    fn check_robot(&self, problems: &mut Problems, bounds: Option<(XY, XY)>) {
        let r = &self.robot;
        let start = [r.start.x, r.start.y];
        if !all_finite(&[r.start.x, r.start.y, r.start.yaw_rad]) {
            problems.bad(path!["robot", "start"], "must be finite".into());
        } else if !near(&[r.start.x, r.start.y]) {
            problems.bad(path!["robot", "start"], far());
        } else if !inside(bounds, start) {
            problems.bad(
                path!["robot", "start"],
                "the robot starts outside the walls".into(),
            );
        }
        for (field, value, max) in [
            ("radius_m", r.radius_m, 2.0),
            ("track_width_m", r.track_width_m, 3.0),
            ("max_wheel_speed_mps", r.max_wheel_speed_mps, 10.0),
            ("max_wheel_accel_mps2", r.max_wheel_accel_mps2, 50.0),
            ("command_timeout_s", r.command_timeout_s, 60.0),
            ("follow_distance_m", r.follow_distance_m, 20.0),
        ] {
            if !(value.is_finite() && value > 0.0 && value <= max) {
                problems.bad(
                    path!["robot", field],
                    format!("must be positive and at most {max}, got {value}"),
                );
            }
        }
        if r.driver == DriverKind::Scripted && r.script.is_empty() {
            problems.bad(
                path!["robot", "driver"],
                "the scripted driver needs a `script` of commands".into(),
            );
        }
        let mut last_at = f64::NEG_INFINITY;
        for (i, c) in r.script.iter().enumerate() {
            if !all_finite(&[c.at_s, c.v_mps, c.w_radps]) || c.at_s < last_at {
                problems.bad(
                    path!["robot", "script", i],
                    "commands need finite values and non-decreasing at_s".into(),
                );
            }
            last_at = c.at_s;
        }
    }

    /// `laser` and `camera`: the sensor models' own checks.
    fn check_sensor_models(&self, problems: &mut Problems) {
        if let Err(e) = self.laser.validate() {
            problems.bad(dotted("laser", laser_error_field(&e)), e.to_string());
        }
        for (i, extra) in self.extra_lasers.iter().enumerate() {
            if let Err(e) = extra.laser.validate() {
                let mut field = path!["extra_lasers", i, "laser"];
                field.extend(dotted("x", laser_error_field(&e)).into_iter().skip(1));
                problems.bad(field, e.to_string());
            }
        }
        let frames: Vec<&str> = self
            .extra_lasers
            .iter()
            .map(|l| l.frame_id.as_str())
            .collect();
        let first = <tether_core::Laser as tether_core::Frame>::NAME;
        check_frame_ids(problems, "extra_lasers", &frames, first, "laser's scans");
        if let Err(e) = self.camera.validate() {
            problems.bad(
                dotted("camera", e.field.split('/').next().unwrap_or(e.field)),
                e.to_string(),
            );
        }
        for (i, extra) in self.extra_cameras.iter().enumerate() {
            if let Err(e) = extra.camera.validate() {
                let mut field = path!["extra_cameras", i, "camera"];
                let key = e.field.split('/').next().unwrap_or(e.field);
                field.extend(dotted("x", key).into_iter().skip(1));
                problems.bad(field, e.to_string());
            }
        }
        let frames: Vec<&str> = self
            .extra_cameras
            .iter()
            .map(|c| c.frame_id.as_str())
            .collect();
        let first = tether_core::FIRST_CAMERA_FRAME;
        check_frame_ids(problems, "extra_cameras", &frames, first, "camera's frames");
    }

    /// `laser_sim`: probabilities in [0, 1], a valid noise model, spells and phantoms of
    /// at least a scan, phantom radii in order, and the weak-leg and long-range distances in order.
    fn check_laser_sim(&self, problems: &mut Problems) {
        let ls = &self.laser_sim;
        for (field, value) in [
            ("dropout_prob", ls.dropout_prob),
            ("long_range_dropout_prob", ls.long_range_dropout_prob),
            ("weak_leg_prob_near", ls.weak_leg_prob_near),
            ("weak_leg_prob_far", ls.weak_leg_prob_far),
            ("spell_start_prob", ls.spell_start_prob),
            ("spell_weak_leg_prob", ls.spell_weak_leg_prob),
            ("weak_beam_loss_prob", ls.weak_beam_loss_prob),
            ("foliage_beam_loss_prob", ls.foliage_beam_loss_prob),
            ("object_beam_loss_prob", ls.object_beam_loss_prob),
            ("ghost_pair_prob", ls.ghost_pair_prob),
        ] {
            if !(0.0..=1.0).contains(&value) {
                problems.bad(
                    path!["laser_sim", field],
                    format!("a probability must lie in [0, 1], got {value}"),
                );
            }
        }
        let noise_check = LaserModel {
            noise: ls.noise.clone(),
            ..LaserModel::default()
        };
        if let Err(e) = noise_check.validate() {
            problems.bad(dotted("laser_sim", laser_error_field(&e)), e.to_string());
        }
        if !(ls.spell_mean_scans.is_finite() && ls.spell_mean_scans >= 1.0) {
            problems.bad(
                path!["laser_sim", "spell_mean_scans"],
                format!("must be at least 1 scan, got {}", ls.spell_mean_scans),
            );
        }
        if !(ls.ghost_mean_scans.is_finite() && (1.0..=1e4).contains(&ls.ghost_mean_scans)) {
            problems.bad(
                path!["laser_sim", "ghost_mean_scans"],
                format!("must lie in [1, 10000] scans, got {}", ls.ghost_mean_scans),
            );
        }
        let [q_lo, q_hi] = ls.clutter_shown_prob;
        if !(0.0 <= q_lo && q_lo <= q_hi && q_hi <= 1.0) {
            problems.bad(
                path!["laser_sim", "clutter_shown_prob"],
                format!("must be [min, max] with 0 <= min <= max <= 1, got [{q_lo}, {q_hi}]"),
            );
        }
        let [r_lo, r_hi] = ls.ghost_radius_m;
        if !(r_lo.is_finite() && r_hi.is_finite() && 0.005 <= r_lo && r_lo <= r_hi && r_hi <= 0.5) {
            problems.bad(
                path!["laser_sim", "ghost_radius_m"],
                format!(
                    "must be [min, max] with 0.005 <= min <= max <= 0.5 m, got [{r_lo}, {r_hi}]"
                ),
            );
        }
        for (field, value) in [
            ("weak_range_sigma_m", ls.weak_range_sigma_m),
            ("ghosts_per_scan", ls.ghosts_per_scan),
            ("clutter_per_m2", ls.clutter_per_m2),
        ] {
            if !(value.is_finite() && (0.0..=10.0).contains(&value)) {
                problems.bad(
                    path!["laser_sim", field],
                    format!("must lie in [0, 10], got {value}"),
                );
            }
        }
        if !(ls.weak_range_near_m.is_finite()
            && ls.weak_range_far_m.is_finite()
            && 0.0 <= ls.weak_range_near_m
            && ls.weak_range_near_m < ls.weak_range_far_m)
        {
            problems.bad(
                path!["laser_sim", "weak_range_far_m"],
                format!(
                    "need 0 <= weak_range_near_m < weak_range_far_m, got {} and {}",
                    ls.weak_range_near_m, ls.weak_range_far_m
                ),
            );
        }
        if !(ls.long_range_start_m.is_finite() && ls.long_range_start_m > 0.0) {
            problems.bad(
                path!["laser_sim", "long_range_start_m"],
                "must be a positive distance".into(),
            );
        }
    }

    /// `camera_sim`: a frame rate of at most 240 Hz, a probability, non-negative noise
    /// and sizes, and the reliable range below the longest.
    fn check_camera_sim(&self, problems: &mut Problems) {
        let cs = &self.camera_sim;
        if !(cs.rate_hz.is_finite() && cs.rate_hz > 0.0 && cs.rate_hz <= 240.0) {
            problems.bad(
                path!["camera_sim", "rate_hz"],
                format!("must lie in (0, 240], got {}", cs.rate_hz),
            );
        }
        if !(0.0..=1.0).contains(&cs.detect_prob) {
            problems.bad(
                path!["camera_sim", "detect_prob"],
                format!("a probability must lie in [0, 1], got {}", cs.detect_prob),
            );
        }
        for (field, value) in [
            ("pixel_sigma_px", cs.pixel_sigma_px),
            ("size_sigma_frac", cs.size_sigma_frac),
            ("min_box_height_px", cs.min_box_height_px),
            ("false_positives_per_frame", cs.false_positives_per_frame),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                problems.bad(
                    path!["camera_sim", field],
                    format!("must be >= 0, got {value}"),
                );
            }
        }
        if !(cs.reliable_range_m.is_finite()
            && cs.reliable_range_m > 0.0
            && cs.max_range_m > cs.reliable_range_m)
        {
            problems.bad(
                path!["camera_sim", "max_range_m"],
                "need 0 < reliable_range_m < max_range_m".into(),
            );
        }
    }

    /// The target: at most one person marked `target`, and one for the oracle driver,
    /// which follows them.
    fn check_target(&self, problems: &mut Problems) {
        let targets = self.people.iter().filter(|p| p.target).count();
        if targets > 1 {
            let second = self
                .people
                .iter()
                .enumerate()
                .filter(|(_, p)| p.target)
                .nth(1)
                .map_or(0, |(i, _)| i);
            problems.bad(
                path!["people", second, "target"],
                "only one person can be the target".into(),
            );
        }
        if self.robot.driver == DriverKind::Oracle && targets == 0 {
            problems.bad(
                path!["robot", "driver"],
                "the oracle driver follows the target: mark one person `target = true`".into(),
            );
        }
    }
}

/// `people[pi]`: a path of at least one waypoint, the walk and the body within their
/// ranges, pauses at waypoints of the path, then the path itself.
fn check_person(
    problems: &mut Problems,
    pi: usize,
    p: &PersonSpec,
    walls: &[(Segment, Vec<FieldSeg>)],
    pillars: &[(Point2<World>, f64)],
    bounds: Option<(XY, XY)>,
) {
    if p.path.is_empty() {
        problems.bad(
            path!["people", pi, "path"],
            "a path needs at least one waypoint".into(),
        );
        return;
    }
    if !(p.speed_mps.is_finite() && (0.0..=3.0).contains(&p.speed_mps)) {
        problems.bad(
            path!["people", pi, "speed_mps"],
            format!("must lie in [0, 3] m/s, got {}", p.speed_mps),
        );
    }
    if !(p.start_s.is_finite() && p.start_s >= 0.0) {
        problems.bad(
            path!["people", pi, "start_s"],
            format!("must be >= 0, got {}", p.start_s),
        );
    }
    if !(p.give_way_m.is_finite() && (0.0..=5.0).contains(&p.give_way_m)) {
        problems.bad(
            path!["people", pi, "give_way_m"],
            format!("must lie in [0, 5] m, got {}", p.give_way_m),
        );
    }
    for (field, value, lo, hi) in [
        ("height_m", p.height_m, 0.9, 2.3),
        ("leg_radius_m", p.leg_radius_m, 0.02, 0.15),
        ("leg_spread_m", p.leg_spread_m, 0.08, 0.5),
    ] {
        if let Some(v) = value
            && !(v.is_finite() && v >= lo && v <= hi)
        {
            problems.bad(
                path!["people", pi, field],
                format!("must lie in [{lo}, {hi}] m, got {v}"),
            );
        }
    }
    for (k, pause) in p.pauses.iter().enumerate() {
        if pause.waypoint >= p.path.len() {
            problems.bad(
                path!["people", pi, "pauses", k, "waypoint"],
                format!(
                    "the path has {} waypoints (0..{})",
                    p.path.len(),
                    p.path.len().saturating_sub(1)
                ),
            );
        }
        if !(pause.duration_s.is_finite() && pause.duration_s >= 0.0) {
            problems.bad(
                path!["people", pi, "pauses", k, "duration_s"],
                "must be >= 0".into(),
            );
        }
    }
    check_waypoints(problems, pi, p, bounds);
    check_path_legs(problems, pi, p, walls, pillars);
}

/// `people[pi].path`: every waypoint finite, near the origin and inside the walls.
fn check_waypoints(problems: &mut Problems, pi: usize, p: &PersonSpec, bounds: Option<(XY, XY)>) {
    for (k, wp) in p.path.iter().enumerate() {
        if !all_finite(wp) {
            problems.bad(
                path!["people", pi, "path", k],
                "waypoints must be finite".into(),
            );
        } else if !near(wp) {
            problems.bad(
                path!["people", pi, "path", k],
                format!("waypoints {}", far()),
            );
        } else if !inside(bounds, *wp) {
            problems.bad(
                path!["people", pi, "path", k],
                format!("waypoint ({}, {}) lies outside the walls", wp[0], wp[1]),
            );
        }
    }
}

/// `people[pi].path`, leg by leg (back to the start when it repeats): no leg through a
/// wall, none closer to a pillar than a walking person's clearance.
fn check_path_legs(
    problems: &mut Problems,
    pi: usize,
    p: &PersonSpec,
    walls: &[(Segment, Vec<FieldSeg>)],
    pillars: &[(Point2<World>, f64)],
) {
    let n = p.path.len();
    let legs = if p.repeat && n > 2 { n } else { n - 1 };
    for k in 0..legs {
        let a = point(p.path[k]);
        let b = point(p.path[(k + 1) % n]);
        if !(a.is_finite() && b.is_finite()) {
            continue;
        }
        let seg = Segment::new(a, b);
        if let Some((wall, _)) = walls
            .iter()
            .find(|(wall, _)| segments_intersect(&seg, wall))
        {
            problems.bad(
                path!["people", pi, "path", (k + 1) % n],
                format!(
                    "the path from waypoint {k} to {} goes through the wall from ({}, {}) to ({}, {})",
                    (k + 1) % n,
                    wall.a.x,
                    wall.a.y,
                    wall.b.x,
                    wall.b.y
                ),
            );
        }
        for (c, radius) in pillars {
            // The body centre passes at least a hip's width plus a leg from it.
            if segment_circle_distance_m(&seg, *c) < radius + PERSON_CLEARANCE_M {
                problems.bad(
                    path!["people", pi, "path", (k + 1) % n],
                    format!(
                        "the path from waypoint {k} runs into the pillar at ({}, {})",
                        c.x, c.y
                    ),
                );
            }
        }
    }
}

/// What a coordinate too far from the origin is told.
fn far() -> String {
    format!(
        "must be within {MAX_WORLD_EXTENT_M} m of the origin (a person-following run \
         covers a few hundred metres)"
    )
}

/// Whether `p` lies strictly inside the box around the walls (anywhere without walls).
fn inside(bounds: Option<(XY, XY)>, p: XY) -> bool {
    match bounds {
        Some((lo, hi)) => p[0] > lo[0] && p[0] < hi[0] && p[1] > lo[1] && p[1] < hi[1],
        None => true,
    }
}

/// Every coordinate within [`MAX_WORLD_EXTENT_M`] of the origin.
fn near(v: &[f64]) -> bool {
    v.iter().all(|c| c.abs() <= MAX_WORLD_EXTENT_M)
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn laser_error_field(e: &tether_core::LaserModelError) -> &'static str {
    match e {
        tether_core::LaserModelError::BadGeometry { .. } => "geometry",
        tether_core::LaserModelError::BadValue { field, .. } => field,
    }
}

/// `root` followed by the dot-separated parts of `field`.
fn dotted(root: &str, field: &str) -> Vec<FieldSeg> {
    std::iter::once(root)
        .chain(field.split('.'))
        .map(FieldSeg::from)
        .collect()
}

/// The `frame_id`s of a list of extra sensors (`list`, e.g. `extra_lasers`): each names
/// its sensor's data (`what`) alone, neither empty, nor the first sensor's `first`, nor
/// another entry's.
fn check_frame_ids(problems: &mut Problems, list: &str, frames: &[&str], first: &str, what: &str) {
    for (i, frame) in frames.iter().enumerate() {
        if frame.is_empty() || *frame == first || frames[..i].contains(frame) {
            problems.bad(
                path![list, i, "frame_id"],
                format!(
                    "{frame:?} must name this {what} alone: not empty, not the first's \
                     `{first}` and not another's"
                ),
            );
        }
    }
}
