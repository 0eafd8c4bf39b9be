//! [`Tracker::process`] in its named steps (design 5.5): which observations are usable,
//! the gated costs of each (track, observation) pairing, camera observations that two
//! tracks explain alike left out, lone legs left to the track that explains them far
//! better, the Hungarian assignment, second legs paired by the tracks, the updates, and
//! new tracks from what no track explains.

use tether_core::{Cov2, Gaussian2, Stamp};

use super::{Anchor, BatchResult, LN_DET_FLOOR, Observation, Source, Track, Tracker, UpdateRule};
use crate::assign::assign;
use crate::kalman::CvFilter;

/// Gated costs, tracks x observations: `None` where a track may not take an
/// observation.
type Costs = Vec<Vec<Option<f64>>>;

/// Costs this close make a camera observation ambiguous between two tracks (a
/// likelihood ratio under e^2).
const AMBIGUOUS_COST_GAP: f64 = 4.0;

impl Tracker {
    /// Processes the observations of one sensor message taken at `stamp`.
    pub fn process(&mut self, stamp: Stamp, observations: &[Observation]) -> BatchResult {
        if !self.advance(stamp) {
            return BatchResult {
                track_of: vec![None; observations.len()],
                accepted: false,
            };
        }
        let usable = self.usable(observations);
        let mut cost = self.gated_costs(stamp, observations, &usable);
        self.leave_out_ambiguous_camera(observations, &mut cost);
        self.leave_legs_to_owners(observations, &mut cost);
        let assignment = self.match_observations(&cost);
        let second = self.second_legs(observations, &cost, &assignment);
        let mut track_of = vec![None; observations.len()];
        for (ti, oi) in assignment.iter().enumerate() {
            let Some(oi) = *oi else { continue };
            let both = second[ti].and_then(|oj| both_legs(&observations[oi], &observations[oj]));
            if self.update(ti, both.as_ref().unwrap_or(&observations[oi]), stamp) {
                track_of[oi] = Some(self.tracks[ti].id);
                if let Some(oj) = second[ti].filter(|_| both.is_some()) {
                    track_of[oj] = Some(self.tracks[ti].id);
                    self.stats.legs_paired_by_tracks += 1;
                }
            }
        }
        self.start_tracks(stamp, observations, &usable, &mut track_of);
        BatchResult {
            track_of,
            accepted: true,
        }
    }

    /// Step 1: which observations may be used at all (finite, and no more uncertain
    /// than `max_observation_sigma_m`); the others are counted as rejected.
    fn usable(&mut self, observations: &[Observation]) -> Vec<bool> {
        let max_var = self.config.max_observation_sigma_m.powi(2);
        observations
            .iter()
            .map(|o| {
                let ok =
                    o.estimate.mean.is_finite() && o.estimate.cov.principal_axes().0 <= max_var;
                if !ok {
                    self.stats.rejected_observations += 1;
                }
                ok
            })
            .collect()
    }

    /// Whether `o` is something that may not take up `t`, a confirmed track that has
    /// coasted for `coast_lone_leg_after_s` or longer (three missed scans at 10 Hz for
    /// 0.3 s, whatever the rounding of the stamps), from farther than
    /// `coast_lone_leg_offset_m`: a lone leg (not weak), or a camera observation of a
    /// track the laser has seen. Except a lone leg coming out of the last scan's shadow
    /// ([`Observation::from_shadow`]) for a track that went behind something since its
    /// last update ([`Track::hidden_since_update`]): its person comes out from where
    /// they could not be seen, wherever their track coasted to (design 5.5, "hidden
    /// tracks"); the gate and the reach still apply.
    fn far_off_coasting(&self, t: &Track, o: &Observation, stamp: Stamp) -> bool {
        let c = &self.config;
        c.coast_lone_leg_offset_m > 0.0
            && ((o.source == Source::Laser && !o.leg_pair && !o.weak)
                || (o.source == Source::Vision && t.last_laser.is_some()))
            && t.confirmed
            && crate::reached_s(stamp.secs_since(t.last_update), c.coast_lone_leg_after_s)
            && !(o.from_shadow && t.hidden_since_update())
            && t.position().mean.distance_m(o.estimate.mean) > c.coast_lone_leg_offset_m
    }

    /// Whether a weak observation may not update `t`: weak legs only keep confirmed
    /// tracks alive, and a track silent longer than `weak_keepalive_s` only from within
    /// `weak_max_offset_m`.
    fn weak_refused(&self, t: &Track, o: &Observation, stamp: Stamp) -> bool {
        o.weak
            && (!t.confirmed
                || (stamp.secs_since(t.last_update) > self.config.weak_keepalive_s
                    && t.position().mean.distance_m(o.estimate.mean)
                        > self.config.weak_max_offset_m))
    }

    /// Step 2: the cost of each pairing that passes the gates: the Mahalanobis gate,
    /// then the physical one (no impossible jump from the last good estimate, however
    /// uncertain the coasting filter has become; counted as `implausible_jumps`). The
    /// cost is the negative log likelihood `d^2 + ln det S`, so that an uncertain track
    /// does not win an observation that a certain track explains better.
    fn gated_costs(
        &mut self,
        stamp: Stamp,
        observations: &[Observation],
        usable: &[bool],
    ) -> Costs {
        let gate = self.config.gate.threshold;
        let bounds = self.config.motion;
        let mut implausible = 0;
        let cost = self
            .tracks
            .iter()
            .map(|t| {
                observations
                    .iter()
                    .zip(usable)
                    .map(|(o, &ok)| {
                        if !ok
                            || self.weak_refused(t, o, stamp)
                            || self.far_off_coasting(t, o, stamp)
                        {
                            return None;
                        }
                        let (s, y) = t.filter.innovation(&o.estimate);
                        let d2 = s.mahalanobis_sq(y[0], y[1]);
                        if d2 >= gate {
                            return None;
                        }
                        if !t.can_reach(&o.estimate, stamp, &bounds) {
                            implausible += 1;
                            return None;
                        }
                        Some(d2 + s.det().ln().max(LN_DET_FLOOR))
                    })
                    .collect()
            })
            .collect();
        self.stats.implausible_jumps += implausible;
        cost
    }

    /// Step 3: a camera observation that two tracks explain about equally well (costs
    /// within [`AMBIGUOUS_COST_GAP`]) is left out: its range is poor, so people standing
    /// on one viewing ray (one hiding the other, a crossing) both gate with it, and
    /// giving it to the wrong one drags that track onto someone else.
    fn leave_out_ambiguous_camera(&mut self, observations: &[Observation], cost: &mut Costs) {
        for (oi, o) in observations.iter().enumerate() {
            let mut costs: Vec<f64> = cost.iter().filter_map(|row| row[oi]).collect();
            costs.sort_by(f64::total_cmp);
            if o.source == Source::Vision
                && costs.len() > 1
                && costs[1] - costs[0] < AMBIGUOUS_COST_GAP
            {
                for row in cost.iter_mut() {
                    row[oi] = None;
                }
                self.stats.ambiguous_observations += 1;
            }
        }
    }

    /// Step 3b: a lone leg that a confirmed track explains far better than another
    /// track does (a cost lower by more than `leg_owner_cost_gap`, a likelihood ratio
    /// over e^3 at the default) is not given to that other track. The assignment
    /// gives as many tracks an observation as it can, so without this a target whose
    /// legs went unseen for a scan takes the leg of the person beside it, whose own
    /// track has another leg to take (design 5.5, "legs paired by the tracks").
    fn leave_legs_to_owners(&self, observations: &[Observation], cost: &mut Costs) {
        let gap = self.config.leg_owner_cost_gap;
        if gap <= 0.0 {
            return;
        }
        for (oi, o) in observations.iter().enumerate() {
            if o.source != Source::Laser || o.leg_pair {
                continue;
            }
            let best = cost
                .iter()
                .zip(&self.tracks)
                .filter(|(_, t)| t.confirmed)
                .filter_map(|(row, _)| row[oi])
                .min_by(f64::total_cmp);
            let Some(best) = best else { continue };
            for row in cost.iter_mut() {
                if row[oi].is_some_and(|c| c > best + gap) {
                    row[oi] = None;
                }
            }
        }
    }

    /// Step 4: the assignment of observations to tracks that minimises the total cost
    /// (the Hungarian method); with `confirmed_first`, in a cascade: the confirmed
    /// tracks first, then the tentative ones among the observations left.
    fn match_observations(&self, cost: &Costs) -> Vec<Option<usize>> {
        if !self.config.confirmed_first {
            return assign(cost);
        }
        let only = |confirmed: bool, taken: &[bool]| -> Costs {
            cost.iter()
                .zip(&self.tracks)
                .map(|(row, t)| {
                    row.iter()
                        .zip(taken)
                        .map(|(&c, &used)| c.filter(|_| t.confirmed == confirmed && !used))
                        .collect()
                })
                .collect()
        };
        let columns = cost.first().map_or(0, Vec::len);
        let first = assign(&only(true, &vec![false; columns]));
        let mut taken = vec![false; columns];
        for oi in first.iter().flatten() {
            taken[*oi] = true;
        }
        let second = assign(&only(false, &taken));
        first
            .into_iter()
            .zip(second)
            .map(|(a, b)| a.or(b))
            .collect()
    }

    /// Step 4b (design 5.5, "legs paired by the tracks"): for each track given a lone
    /// leg, a second lone leg that no track was given, within `pair_lone_legs_within_m`
    /// of the first, inside this track's gate and explained by no other track better
    /// than by this one. The detector pairs legs by distance alone and leaves the two
    /// legs of a striding person apart when they are weak or more than a pair apart;
    /// the track, which knows where its person is, pairs them.
    fn second_legs(
        &self,
        observations: &[Observation],
        cost: &Costs,
        assignment: &[Option<usize>],
    ) -> Vec<Option<usize>> {
        let within = self.config.pair_lone_legs_within_m;
        let lone = |o: &Observation| o.source == Source::Laser && !o.leg_pair;
        let mut given = vec![false; observations.len()];
        for oi in assignment.iter().flatten() {
            given[*oi] = true;
        }
        let mut second = vec![None; assignment.len()];
        if within <= 0.0 {
            return second;
        }
        for (ti, oi) in assignment.iter().enumerate() {
            let Some(oi) = *oi else { continue };
            let first = &observations[oi];
            if !lone(first) {
                continue;
            }
            let best = observations
                .iter()
                .enumerate()
                .filter(|&(oj, o)| {
                    !given[oj]
                        && lone(o)
                        && o.estimate.mean.distance_m(first.estimate.mean) <= within
                })
                .filter_map(|(oj, _)| cost[ti][oj].map(|c| (oj, c)))
                .filter(|&(oj, c)| {
                    cost.iter()
                        .enumerate()
                        .all(|(tj, row)| tj == ti || row[oj].is_none_or(|d| d > c))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((oj, _)) = best {
                given[oj] = true;
                second[ti] = Some(oj);
            }
        }
        second
    }

    /// Whether a camera observation assigned to track `ti` falls among people closer
    /// than a body width (`vision_min_separation_m`): they overlap in the image, so a
    /// box and its range may be either one's (or both merged), and only the laser
    /// updates them.
    fn camera_crowded(&self, ti: usize, o: &Observation) -> bool {
        let sep = self.config.vision_min_separation_m;
        if o.source != Source::Vision || sep <= 0.0 {
            return false;
        }
        let here = self.tracks[ti].position().mean;
        self.tracks
            .iter()
            .enumerate()
            .any(|(tj, u)| tj != ti && u.confirmed && u.position().mean.distance_m(here) < sep)
    }

    /// Step 5: updates track `ti` with its assigned observation `o`; false when the
    /// update is refused (a crowded camera observation, a bearing that does not fit, a
    /// non-finite result). A camera observation of a track the laser supports updates
    /// only its bearing; the rest by the sensor's [`UpdateRule`].
    fn update(&mut self, ti: usize, o: &Observation, stamp: Stamp) -> bool {
        if self.camera_crowded(ti, o) {
            self.stats.ambiguous_observations += 1;
            return false;
        }
        let bounds = self.config.motion;
        let (laser_support_s, laser_rule, vision_rule) = (
            self.config.laser_support_s,
            self.config.laser_update,
            self.config.vision_update,
        );
        let t = &mut self.tracks[ti];
        let before = t.filter;
        let laser_support = t
            .last_laser
            .is_some_and(|l| stamp.secs_since(l) <= laser_support_s);
        match (o.source, o.bearing) {
            (Source::Vision, Some(b)) if laser_support => {
                if !t.filter.update_bearing(
                    b.origin,
                    b.bearing_rad,
                    b.sigma_rad,
                    crate::gate::CHI2_1DOF_99,
                ) {
                    // The position gated but the bearing does not fit: someone else
                    // near the track's viewing ray.
                    self.stats.rejected_observations += 1;
                    return false;
                }
            }
            _ => {
                let rule = match o.source {
                    Source::Laser | Source::Fused => laser_rule,
                    Source::Vision => vision_rule,
                };
                match rule {
                    UpdateRule::Kalman => t.filter.update(&o.estimate),
                    UpdateRule::CovarianceIntersection => {
                        t.filter.update_ci(&o.estimate);
                    }
                }
            }
        }
        if !t.filter.is_finite() {
            t.filter = before;
            self.stats.rejected_observations += 1;
            return false;
        }
        if t.filter.clamp_speed(bounds.max_speed_mps) {
            self.stats.speed_clamps += 1;
        }
        self.record_update(ti, o, stamp);
        true
    }

    /// The bookkeeping of an accepted update of track `ti` by `o`: when, by which
    /// sensors, hits (weak or not), evidence of a whole person, distance walked,
    /// confirmation.
    fn record_update(&mut self, ti: usize, o: &Observation, stamp: Stamp) {
        let confirm_hits = self.config.confirm_hits;
        let t = &mut self.tracks[ti];
        if o.from_shadow && t.hidden_since_update() {
            t.came_out = Some(stamp);
        }
        t.last_update = stamp;
        t.anchor = Anchor::of(&t.filter, stamp);
        if matches!(o.source, Source::Laser | Source::Fused) {
            t.last_laser = Some(stamp);
        }
        if matches!(o.source, Source::Vision | Source::Fused) {
            t.last_vision = Some(stamp);
        }
        self.stats.associated += 1;
        if o.weak {
            self.stats.weak_updates += 1;
            t.weak_hits += 1;
            return;
        }
        t.hits += 1;
        t.pair_hits += u32::from(o.leg_pair);
        if o.leg_pair || o.source != Source::Laser {
            t.last_pair = Some(stamp);
            t.pair_anchor = Some(t.anchor);
        }
        t.walked_m = t
            .walked_m
            .max(t.anchor.position.mean.distance_m(t.birth_position));
        if t.hits >= confirm_hits {
            t.confirmed = true;
        }
    }

    /// Step 6: new tracks from the usable observations no track took, unless a track
    /// could have made them (that track's business, not a new person's: within its
    /// gate, reachable, and not refused as far off) or a confirmed track stands within
    /// `spawn_separation_m`. Weak observations and those that may not spawn start none.
    fn start_tracks(
        &mut self,
        stamp: Stamp,
        observations: &[Observation],
        usable: &[bool],
        track_of: &mut [Option<u64>],
    ) {
        let gate = self.config.gate.threshold;
        let bounds = self.config.motion;
        let sep = self.config.spawn_separation_m;
        for (oi, o) in observations.iter().enumerate() {
            if track_of[oi].is_some() || !usable[oi] || !o.may_spawn || o.weak {
                continue;
            }
            let near_existing = self.tracks.iter().any(|t| {
                t.filter.mahalanobis_sq(&o.estimate) < gate
                    && t.can_reach(&o.estimate, stamp, &bounds)
                    && !self.far_off_coasting(t, o, stamp)
            });
            let beside_confirmed = sep > 0.0
                && self
                    .tracks
                    .iter()
                    .any(|t| t.confirmed && t.position().mean.distance_m(o.estimate.mean) < sep);
            if near_existing || beside_confirmed {
                continue;
            }
            let id = self.next_id;
            self.next_id += 1;
            let track = self.new_track(id, o, stamp);
            self.tracks.push(track);
            self.stats.tracks_started += 1;
            track_of[oi] = Some(id);
        }
    }

    /// A track started by `o` at `stamp`.
    fn new_track(&self, id: u64, o: &Observation, stamp: Stamp) -> Track {
        let (last_laser, last_vision) = match o.source {
            Source::Laser => (Some(stamp), None),
            Source::Vision => (None, Some(stamp)),
            Source::Fused => (Some(stamp), Some(stamp)),
        };
        let filter = CvFilter::new(&o.estimate, self.config.initial_speed_sigma_mps);
        let whole_person = o.leg_pair || o.source != Source::Laser;
        Track {
            id,
            filter,
            confirmed: self.config.confirm_hits <= 1,
            hits: 1,
            born: stamp,
            last_update: stamp,
            last_laser,
            last_vision,
            last_hidden: None,
            came_out: None,
            anchor: Anchor::of(&filter, stamp),
            birth_position: o.estimate.mean,
            walked_m: 0.0,
            pair_hits: u32::from(o.leg_pair),
            weak_hits: 0,
            last_pair: whole_person.then_some(stamp),
            pair_anchor: whole_person.then_some(Anchor::of(&filter, stamp)),
            duplicate_since: None,
            merged: None,
        }
    }
}

/// One observation of a person from two lone legs `a` and `b` (design 5.5, "legs paired
/// by the tracks"): at their midpoint, with covariance `(P_a + P_b) / 4` (each lone
/// leg's covariance already holds the body centre's spread about the leg); weak only
/// when both legs are weak. `None` when that covariance is not usable.
fn both_legs(a: &Observation, b: &Observation) -> Option<Observation> {
    let (ca, cb) = (a.estimate.cov, b.estimate.cov);
    let cov = Cov2::new(
        0.25 * (ca.xx() + cb.xx()),
        0.25 * (ca.xy() + cb.xy()),
        0.25 * (ca.yy() + cb.yy()),
    )
    .ok()?;
    let estimate = Gaussian2::new(a.estimate.mean.lerp(b.estimate.mean, 0.5), cov).ok()?;
    Some(Observation {
        estimate,
        weak: a.weak && b.weak,
        from_shadow: a.from_shadow || b.from_shadow,
        ..*a
    })
}
