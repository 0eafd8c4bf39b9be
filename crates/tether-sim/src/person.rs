//! A walking person: a body that follows a waypoint path with a speed profile
//! (accelerating, cruising, braking for pauses and the path's end), and two legs that
//! step with a gait (design 7).
//!
//! Gait model. Steps alternate between the feet at a cadence of 1.7-2.0 steps/s (faster
//! when walking faster). During a step the stance foot stays fixed on the floor while
//! the swing foot travels to its landing point, half a step length ahead of where the
//! body will be when it lands: over a step of duration `T = 1/cadence` the body advances
//! one step length `v T`, the swing foot two. When the person stops, a last step brings
//! the feet side by side. The laser sees each leg at its own height `h`: a leg is a
//! straight line from the hip (above the body centre, offset sideways) to the foot, so
//! at height `h` it is at `foot + (hip - foot) h / hip_height`. At 1.2 m/s a step is
//! 0.65 m at the floor but only ~0.4 m at 0.35 m height, which gives the 0.2-0.35 m leg
//! separations of real URG-04LX recordings.

use tether_core::{Point2, Vector2, World, wrap_angle_rad};

use crate::geometry::Circle;
use crate::rng::SimRng;
use crate::scenario::PersonSpec;

/// Body proportions of one person.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Height (head top above the floor), m.
    pub height_m: f64,
    /// Radius of each leg at the calf ([`LEG_REFERENCE_HEIGHT_M`]), m.
    pub leg_radius_m: f64,
    /// Sideways distance between the leg centres (and the hips), m.
    pub leg_spread_m: f64,
}

impl Body {
    /// Hip joint height, m (about 0.53 of stature).
    pub fn hip_height_m(&self) -> f64 {
        0.53 * self.height_m
    }

    /// Shoulder width, m (about 0.25 of stature).
    pub fn shoulder_width_m(&self) -> f64 {
        0.25 * self.height_m
    }

    /// Height of the middle of the torso, the bottom of the upper-body box, m.
    pub fn mid_torso_height_m(&self) -> f64 {
        0.62 * self.height_m
    }

    /// Radius of the torso seen from above, for occlusion of the camera's view, m.
    pub fn torso_radius_m(&self) -> f64 {
        0.5 * self.shoulder_width_m()
    }
}

/// Height at which a person's `leg_radius_m` is given, m: the calf, where the
/// URG-04LX of the paper's robot scanned (`LaserMount::default().height_m`).
pub const LEG_REFERENCE_HEIGHT_M: f64 = 0.30;

/// Girth of a leg against height above the floor, `(height m, girth mm)`, rounded means
/// of men and women of the 2012 Anthropometric Survey of U.S. Army Personnel (ANSUR
/// II; Gordon et al., NATICK/TR-15/007): ankle circumference (the narrowest, about
/// 0.11 m up), calf circumference (at the calf's widest, taken at 0.30 m), the narrower
/// leg just below the knee, the knee, lower thigh circumference (just above the knee)
/// and thigh circumference (at the gluteal furrow, about 0.78 m). Linear between the
/// points, constant beyond the ends.
pub const LEG_GIRTH_PROFILE_MM: [(f64, f64); 6] = [
    (0.11, 220.0),
    (LEG_REFERENCE_HEIGHT_M, 380.0),
    (0.42, 340.0),
    (0.50, 380.0),
    (0.55, 400.0),
    (0.78, 620.0),
];

/// How much wider a leg is at `height_m` than at [`LEG_REFERENCE_HEIGHT_M`]: the
/// ratio of girths of [`LEG_GIRTH_PROFILE_MM`] (a leg's cross-section taken as a circle,
/// its radius in proportion to its girth). Exactly 1 at the reference height, so that
/// the default mount keeps every leg as it was; about 0.71 at 0.17 m (an LDS-01 on a
/// TurtleBot3: a 0.13 m calf is a 0.09 m ankle), 1.05 at 0.55 m (the lower thigh), 1.3
/// at 0.65 m. A scan plane through the hips (above 0.78 m) sees the thighs at their
/// widest.
pub fn leg_girth_scale(height_m: f64) -> f64 {
    let p = &LEG_GIRTH_PROFILE_MM;
    let reference = p[1].1;
    let girth = if height_m <= p[0].0 {
        p[0].1
    } else if height_m >= p[p.len() - 1].0 {
        p[p.len() - 1].1
    } else {
        p.windows(2)
            .find(|w| height_m <= w[1].0)
            .map_or(reference, |w| {
                let t = (height_m - w[0].0) / (w[1].0 - w[0].0);
                w[0].1 + t * (w[1].1 - w[0].1)
            })
    };
    girth / reference
}

/// Walking acceleration and deceleration, m/s^2.
const ACCEL_MPS2: f64 = 0.9;

/// People keep at least this far apart, centre to centre, when one gives way to the
/// other, m (close behind a back or beside a shoulder, not touching: two torsos are
/// about 0.4 m across together).
pub const PASS_M: f64 = 0.45;

/// How far ahead a person looks for someone to give way to, s.
pub const GIVE_WAY_HORIZON_S: f64 = 2.0;
/// Largest turn rate of the body's heading, rad/s.
const MAX_TURN_RATE_RADPS: f64 = 4.0;
/// Below this speed and with the feet together, the person stands still.
const STAND_SPEED_MPS: f64 = 0.05;

/// Cadence (steps per second) at speed `v`: 1.7 slow to 2.0 at 1.4 m/s and above.
pub fn cadence_hz(v_mps: f64) -> f64 {
    1.7 + 0.3 * (v_mps / 1.4).clamp(0.0, 1.0)
}

/// A person in the simulated world.
#[derive(Debug, Clone)]
pub struct Person {
    /// Index in the scenario (the person's id).
    pub id: u32,
    /// Name from the scenario.
    pub name: String,
    /// The person the robot should follow.
    pub is_target: bool,
    /// Body proportions.
    pub body: Body,
    path: Vec<Point2<World>>,
    /// Arc length at each waypoint of one lap (the last entry is the lap length).
    cum_m: Vec<f64>,
    repeat: bool,
    cruise_mps: f64,
    start_s: f64,
    /// See `PersonSpec::give_way_m`.
    give_way_m: f64,
    /// Giving way now: slowing to a stand until the way is clear.
    giving_way: bool,
    /// (arc length within a lap, duration) of each pause, sorted.
    pauses: Vec<(f64, f64)>,
    // Motion state.
    s_m: f64,
    v_mps: f64,
    heading_rad: f64,
    pause_left_s: f64,
    /// Arc length of the last pause served (so it is not served twice).
    last_pause_s_m: f64,
    elapsed_s: f64,
    position: Point2<World>,
    velocity: Vector2<World>,
    // Gait state: feet on the floor, index 0 left, 1 right.
    feet: [Point2<World>; 2],
    stance: usize,
    phase: f64,
    swing_from: Point2<World>,
    stepping: bool,
}

impl Person {
    /// Builds a person from the scenario, drawing unspecified body sizes from `rng`.
    pub fn from_spec(id: u32, spec: &PersonSpec, rng: &mut SimRng) -> Self {
        let body = Body {
            height_m: spec
                .height_m
                .unwrap_or_else(|| rng.normal(1.75, 0.07).clamp(1.55, 1.95)),
            leg_radius_m: spec
                .leg_radius_m
                .unwrap_or_else(|| rng.uniform(0.058, 0.072)),
            leg_spread_m: spec.leg_spread_m.unwrap_or_else(|| rng.uniform(0.18, 0.26)),
        };
        let mut path: Vec<Point2<World>> =
            spec.path.iter().map(|p| Point2::new(p[0], p[1])).collect();
        let repeat = spec.repeat && path.len() > 2;
        if repeat && let Some(&first) = path.first() {
            path.push(first);
        }
        let mut cum_m = vec![0.0];
        for w in path.windows(2) {
            let last = cum_m.last().copied().unwrap_or(0.0);
            cum_m.push(last + w[0].distance_m(w[1]));
        }
        let mut pauses: Vec<(f64, f64)> = spec
            .pauses
            .iter()
            .filter_map(|p| cum_m.get(p.waypoint).map(|&s| (s, p.duration_s)))
            .collect();
        pauses.sort_by(|a, b| a.0.total_cmp(&b.0));
        let start = path.first().copied().unwrap_or(Point2::ORIGIN);
        let heading_rad = match path.get(1) {
            Some(&next) => (next - start).angle_rad(),
            None => 0.0,
        };
        let mut person = Person {
            id,
            name: spec.name.clone(),
            is_target: spec.target,
            body,
            path,
            cum_m,
            repeat,
            cruise_mps: spec.speed_mps,
            start_s: spec.start_s,
            give_way_m: spec.give_way_m,
            giving_way: false,
            pauses,
            s_m: 0.0,
            v_mps: 0.0,
            heading_rad,
            pause_left_s: 0.0,
            last_pause_s_m: -1.0,
            elapsed_s: 0.0,
            position: start,
            velocity: Vector2::ZERO,
            feet: [start; 2],
            stance: 0,
            phase: 0.0,
            swing_from: start,
            stepping: false,
        };
        person.feet = [person.neutral_foot(0), person.neutral_foot(1)];
        person.swing_from = person.feet[1];
        person
    }

    fn lap_m(&self) -> f64 {
        self.cum_m.last().copied().unwrap_or(0.0)
    }

    /// Point of the path at arc length `s` (wrapping for repeating paths).
    fn path_at(&self, s: f64) -> Point2<World> {
        let lap = self.lap_m();
        if self.path.len() < 2 || lap <= 0.0 {
            return self.path.first().copied().unwrap_or(Point2::ORIGIN);
        }
        let s = if self.repeat {
            s.rem_euclid(lap)
        } else {
            s.clamp(0.0, lap)
        };
        let k = self
            .cum_m
            .partition_point(|&c| c <= s)
            .clamp(1, self.path.len() - 1);
        let (s0, s1) = (self.cum_m[k - 1], self.cum_m[k]);
        let t = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
        self.path[k - 1].lerp(self.path[k], t)
    }

    /// The next place to stop at or after arc length `s`: `(arc length, pause duration
    /// or None for the path's end)`.
    fn next_stop(&self, s: f64) -> Option<(f64, Option<f64>)> {
        let lap = self.lap_m();
        if self.repeat && lap > 0.0 {
            let base = (s / lap).floor() * lap;
            for lap_start in [base, base + lap] {
                for &(ps, d) in &self.pauses {
                    let at = lap_start + ps;
                    if at >= s - 1e-9 && at > self.last_pause_s_m + 1e-6 {
                        return Some((at, Some(d)));
                    }
                }
            }
            None
        } else {
            for &(ps, d) in &self.pauses {
                if ps >= s - 1e-9 && ps > self.last_pause_s_m + 1e-6 {
                    return Some((ps, Some(d)));
                }
            }
            Some((lap, None))
        }
    }

    fn left_unit(&self) -> Vector2<World> {
        Vector2::unit(self.heading_rad).perp()
    }

    /// Where foot `j` rests when standing: under its hip.
    fn neutral_foot(&self, j: usize) -> Point2<World> {
        self.hip(j)
    }

    /// The hip of leg `j` projected on the floor.
    fn hip(&self, j: usize) -> Point2<World> {
        let side = if j == 0 { 0.5 } else { -0.5 };
        self.position + self.left_unit() * (side * self.body.leg_spread_m)
    }

    /// Whether this person gives way to `other` (a person listed before it): `other` is
    /// within `give_way_m` in front of it, and were this person to walk on at its
    /// cruising speed, the two would pass closer than [`PASS_M`] within
    /// [`GIVE_WAY_HORIZON_S`] (the closest approach of straight-line motion:
    /// `d + w t*`, `t* = clamp(-d.w / |w|^2, 0, T)`, `d` the offset of `other`, `w` its
    /// velocity less this person's intended one).
    pub fn must_give_way_to(&self, other: &Person) -> bool {
        let d = other.position - self.position;
        let range = d.norm();
        let heading = Vector2::<World>::new(self.heading_rad.cos(), self.heading_rad.sin());
        if self.give_way_m <= 0.0
            || range >= self.give_way_m
            || heading.dot(d) <= 0.0
            || self.elapsed_s < self.start_s
        {
            return false;
        }
        let w = other.velocity - heading * self.cruise_mps;
        let w2 = w.dot(w);
        let t = if w2 > 1e-12 {
            (-d.dot(w) / w2).clamp(0.0, GIVE_WAY_HORIZON_S)
        } else {
            0.0
        };
        (d + w * t).norm() < PASS_M
    }

    /// Sets whether the person gives way from now on (slows to a stand while it does).
    pub fn set_giving_way(&mut self, giving_way: bool) {
        self.giving_way = giving_way;
    }

    /// Advances the person by `dt_s`.
    pub fn step(&mut self, dt_s: f64) {
        let before = self.position;
        self.elapsed_s += dt_s;
        self.advance_along_path(dt_s);
        self.position = self.path_at(self.s_m);
        self.velocity = if dt_s > 0.0 {
            (self.position - before) * (1.0 / dt_s)
        } else {
            Vector2::ZERO
        };
        self.turn(dt_s);
        self.advance_gait(dt_s);
    }

    fn advance_along_path(&mut self, dt_s: f64) {
        if self.elapsed_s < self.start_s || self.path.len() < 2 {
            self.v_mps = 0.0;
            return;
        }
        if self.pause_left_s > 0.0 {
            self.pause_left_s -= dt_s;
            self.v_mps = 0.0;
            return;
        }
        let stop = self.next_stop(self.s_m);
        let to_stop = stop.map_or(f64::INFINITY, |(at, _)| at - self.s_m);
        if to_stop <= 1e-6 {
            // Standing at a stop.
            self.v_mps = 0.0;
            if let Some((at, Some(duration))) = stop {
                self.pause_left_s = duration;
                self.last_pause_s_m = at;
            }
            return;
        }
        let brake = (2.0 * ACCEL_MPS2 * to_stop).sqrt();
        let wanted = if self.giving_way {
            0.0
        } else {
            self.cruise_mps.min(brake)
        };
        let dv = (wanted - self.v_mps).clamp(-ACCEL_MPS2 * dt_s * 2.0, ACCEL_MPS2 * dt_s);
        self.v_mps = (self.v_mps + dv).max(0.0);
        // Creep the last centimetres so that the stop is reached in finite time.
        let v = if to_stop < 0.02 {
            self.v_mps.max(0.1)
        } else {
            self.v_mps
        };
        let ds = v * dt_s;
        if ds >= to_stop {
            self.s_m += to_stop;
            self.v_mps = 0.0;
            if let Some((at, Some(duration))) = stop {
                self.pause_left_s = duration;
                self.last_pause_s_m = at;
            }
        } else {
            self.s_m += ds;
        }
    }

    fn turn(&mut self, dt_s: f64) {
        if self.path.len() < 2 {
            return;
        }
        // Heading follows the path tangent, looking a little ahead and behind so that
        // corners are turned smoothly rather than on the spot.
        let ahead = self.path_at(self.s_m + 0.3);
        let behind = self.path_at(self.s_m - 0.3);
        let tangent = ahead - behind;
        if tangent.norm() < 1e-6 {
            return;
        }
        let err = wrap_angle_rad(tangent.angle_rad() - self.heading_rad);
        let max = MAX_TURN_RATE_RADPS * dt_s;
        self.heading_rad = wrap_angle_rad(self.heading_rad + err.clamp(-max, max));
    }

    fn advance_gait(&mut self, dt_s: f64) {
        let settled = (0..2).all(|j| self.feet[j].distance_m(self.neutral_foot(j)) < 0.04);
        let walking = self.v_mps > STAND_SPEED_MPS;
        if !self.stepping {
            if walking || !settled {
                self.stepping = true;
                self.phase = 0.0;
                // Start with the foot that is furthest behind.
                let fwd = Vector2::unit(self.heading_rad);
                let behind0 = (self.feet[0] - self.position).dot(fwd);
                let behind1 = (self.feet[1] - self.position).dot(fwd);
                self.stance = if behind0 < behind1 { 1 } else { 0 };
                self.swing_from = self.feet[1 - self.stance];
            } else {
                return;
            }
        }
        let cadence = cadence_hz(self.v_mps);
        self.phase += cadence * dt_s;
        let swing = 1 - self.stance;
        let target = self.landing_point(swing, cadence);
        if self.phase >= 1.0 {
            self.feet[swing] = target;
            self.phase -= 1.0;
            self.stance = swing;
            self.swing_from = self.feet[1 - self.stance];
            let settled = (0..2).all(|j| self.feet[j].distance_m(self.neutral_foot(j)) < 0.04);
            if !walking && settled {
                self.stepping = false;
                self.phase = 0.0;
            }
        } else {
            // Smooth start and stop of the swing: 3 t^2 - 2 t^3.
            let t = self.phase;
            let smooth = t * t * (3.0 - 2.0 * t);
            self.feet[swing] = self.swing_from.lerp(target, smooth);
        }
    }

    /// Where the swing foot lands: half a step ahead of where the body will be then.
    fn landing_point(&self, j: usize, cadence: f64) -> Point2<World> {
        let fwd = Vector2::unit(self.heading_rad);
        let remaining_s = (1.0 - self.phase).max(0.0) / cadence;
        let step_m = self.v_mps / cadence;
        self.neutral_foot(j) + fwd * (self.v_mps * remaining_s + 0.5 * step_m)
    }

    /// Centre of the body on the floor.
    pub fn position(&self) -> Point2<World> {
        self.position
    }

    /// Velocity of the body, m/s.
    pub fn velocity(&self) -> Vector2<World> {
        self.velocity
    }

    /// Walking speed along the path, m/s.
    pub fn speed_mps(&self) -> f64 {
        self.v_mps
    }

    /// Direction the body faces, rad.
    pub fn heading_rad(&self) -> f64 {
        self.heading_rad
    }

    /// Feet on the floor (left, right).
    pub fn feet(&self) -> [Point2<World>; 2] {
        self.feet
    }

    /// The two legs as circles at height `height_m` above the floor (left, right), of
    /// radius `leg_radius_m * leg_girth_scale(height_m)`.
    pub fn legs_at(&self, height_m: f64) -> [Circle; 2] {
        let k = (height_m / self.body.hip_height_m()).clamp(0.0, 1.0);
        let radius_m = self.body.leg_radius_m * leg_girth_scale(height_m);
        [0, 1].map(|j| Circle {
            center: self.feet[j].lerp(self.hip(j), k),
            radius_m,
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::scenario::PauseSpec;

    /// A target of average build walking `path` at `speed` m/s, no pauses.
    pub(crate) fn spec(path: Vec<[f64; 2]>, speed: f64) -> PersonSpec {
        PersonSpec {
            name: "p".into(),
            target: true,
            path,
            speed_mps: speed,
            start_s: 0.0,
            pauses: vec![],
            repeat: false,
            height_m: Some(1.75),
            leg_radius_m: Some(0.06),
            leg_spread_m: Some(0.2),
            give_way_m: 2.0,
        }
    }

    fn walk(p: &mut Person, seconds: f64) {
        let dt = 0.01;
        for _ in 0..(seconds / dt).round() as usize {
            p.step(dt);
        }
    }

    #[test]
    fn a_person_gives_way_to_one_listed_before_rather_than_walk_through_them() {
        let mut rng = SimRng::stream(0, "p");
        let run = |give_way_m: f64, rng: &mut SimRng| {
            let first = spec(vec![[-3.0, 0.0], [3.0, 0.0]], 1.0);
            let second = PersonSpec {
                give_way_m,
                ..spec(vec![[0.0, 3.0], [0.0, -3.0]], 1.0)
            };
            let (mut a, mut b) = (
                Person::from_spec(0, &first, rng),
                Person::from_spec(1, &second, rng),
            );
            let mut closest = f64::INFINITY;
            for _ in 0..1500 {
                b.set_giving_way(b.must_give_way_to(&a));
                a.step(0.01);
                b.step(0.01);
                closest = closest.min(a.position().distance_m(b.position()));
            }
            (closest, b.position())
        };
        let (closest, end) = run(2.0, &mut rng);
        assert!(closest > 0.5, "came within {closest} m");
        assert!(
            end.distance_m(Point2::new(0.0, -3.0)) < 0.05,
            "ended at {end:?}"
        );
        // Without giving way the two meet at the crossing.
        assert!(run(0.0, &mut rng).0 < 0.3);
    }

    #[test]
    fn reaches_cruise_speed_and_stops_at_the_end() {
        let mut rng = SimRng::stream(1, "t");
        let mut p = Person::from_spec(0, &spec(vec![[0.0, 0.0], [10.0, 0.0]], 1.2), &mut rng);
        walk(&mut p, 4.0);
        assert!((p.speed_mps() - 1.2).abs() < 1e-9);
        walk(&mut p, 10.0);
        assert_eq!(p.speed_mps(), 0.0);
        assert!((p.position().x - 10.0).abs() < 1e-6);
        // Feet come together beside each other under the hips.
        walk(&mut p, 2.0);
        let [l, r] = p.feet();
        assert!(
            (l.x - 10.0).abs() < 0.05 && (r.x - 10.0).abs() < 0.05,
            "{l:?} {r:?}"
        );
        assert!((l.distance_m(r) - 0.2).abs() < 0.05);
    }

    #[test]
    fn stance_foot_stays_fixed_while_the_other_swings() {
        let mut rng = SimRng::stream(1, "t");
        let mut p = Person::from_spec(0, &spec(vec![[0.0, 0.0], [30.0, 0.0]], 1.2), &mut rng);
        walk(&mut p, 5.0);
        let mut fixed_ticks = 0;
        let mut ticks = 0;
        for _ in 0..200 {
            let before = p.feet();
            let stance = p.stance;
            p.step(0.01);
            if p.stance == stance {
                ticks += 1;
                if before[stance] == p.feet()[stance] {
                    fixed_ticks += 1;
                }
            }
        }
        assert_eq!(fixed_ticks, ticks);
        assert!(ticks > 150);
    }

    #[test]
    fn cadence_and_step_length_are_human() {
        let mut rng = SimRng::stream(1, "t");
        let mut p = Person::from_spec(0, &spec(vec![[0.0, 0.0], [40.0, 0.0]], 1.2), &mut rng);
        walk(&mut p, 5.0);
        let mut landings = 0;
        let mut stance = p.stance;
        for _ in 0..1000 {
            p.step(0.01);
            if p.stance != stance {
                landings += 1;
                stance = p.stance;
            }
        }
        // 10 s at ~1.96 steps/s.
        assert!((18..=21).contains(&landings), "{landings}");
        // Feet at double support are about one step length apart.
        let step = 1.2 / cadence_hz(1.2);
        assert!((step - 0.61).abs() < 0.05, "{step}");
    }

    #[test]
    fn pauses_hold_the_person_still() {
        let mut rng = SimRng::stream(1, "t");
        let mut s = spec(vec![[0.0, 0.0], [2.0, 0.0], [6.0, 0.0]], 1.0);
        s.pauses = vec![PauseSpec {
            waypoint: 1,
            duration_s: 3.0,
        }];
        let mut p = Person::from_spec(0, &s, &mut rng);
        walk(&mut p, 3.5);
        assert!((p.position().x - 2.0).abs() < 1e-6, "{:?}", p.position());
        walk(&mut p, 2.0);
        assert!((p.position().x - 2.0).abs() < 1e-6);
        walk(&mut p, 3.0);
        assert!(p.position().x > 3.0);
    }

    #[test]
    fn repeating_path_loops() {
        let mut rng = SimRng::stream(1, "t");
        let mut s = spec(vec![[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]], 1.0);
        s.repeat = true;
        let mut p = Person::from_spec(0, &s, &mut rng);
        walk(&mut p, 60.0);
        assert!(p.speed_mps() > 0.5, "still walking after many laps");
    }
}
