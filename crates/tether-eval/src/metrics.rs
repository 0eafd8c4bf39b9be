//! The measures of a closed-loop run (design 8): estimation (RMSE, NEES), tracking
//! (CLEAR MOT, target swaps) and following (distance error, minimum distance, time in
//! the comfort band, time without a target, collisions, jerk).
//!
//! Distances to the target are measured from the spring's attachment point `J` (`L`
//! ahead of the wheel axis), the distance the follower regulates to `d0`.

use crate::ClearMot;
use serde::Serialize;
use tether_core::{Gaussian2, Point2, World};
use tether_fusion::TargetState;
use tether_pipeline::Tick;

use crate::closed_loop::{RunLog, StepKind};

/// Comfort band of the follow distance for a follow distance of 1 m, m (design 8).
pub const BAND_M: (f64, f64) = (0.8, 1.5);

/// The comfort band around a scenario's follow distance `d0`: design 8's [0.8, 1.5] m
/// for d0 = 1 m, moved with d0 (`[d0 - 0.2, d0 + 0.5]`: 0.2 m nearer, 0.5 m farther),
/// so that `occlusion`'s d0 = 2 m is measured against [1.8, 2.5] m.
pub fn band_m(d0_m: f64) -> (f64, f64) {
    (d0_m - (1.0 - BAND_M.0), d0_m + (BAND_M.1 - 1.0))
}

/// Match threshold of CLEAR MOT and of target-swap detection, m.
pub const MATCH_M: f64 = 0.75;

/// Per-run measures, as written to `metrics.json`.
#[derive(Debug, Clone, Serialize)]
pub struct RunMetrics {
    /// Scenario.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// RMSE of the driving (fused) pipeline's target estimate, m.
    pub rmse_fused_m: Option<f64>,
    /// RMSE of the laser-only passenger's target estimate, m.
    pub rmse_laser_m: Option<f64>,
    /// RMSE of the vision-only passenger's target estimate, m.
    pub rmse_vision_m: Option<f64>,
    /// RMSE of the fused, laser-only and vision-only estimates over the scans where all
    /// three had one (the like-for-like comparison), m.
    pub rmse_common_m: Option<[f64; 3]>,
    /// Scans in that common set.
    pub common_scans: usize,
    /// Mean normalised estimation error squared of the fused target estimate (2 for a
    /// consistent 2-D estimate).
    pub nees_mean: Option<f64>,
    /// CLEAR MOT accuracy of the confirmed tracks against the people the laser sees.
    pub mota: f64,
    /// CLEAR MOT precision, m.
    pub motp_m: f64,
    /// Identity switches.
    pub id_switches: u64,
    /// Times the followed estimate moved from the true target to someone else.
    pub target_swaps: u32,
    /// Mean |d - d0| after the first lock, m.
    pub mean_abs_distance_error_m: Option<f64>,
    /// RMS of d - d0 after the first lock, m.
    pub rms_distance_error_m: Option<f64>,
    /// Smallest d over the run, m.
    pub min_distance_m: f64,
    /// Share of time after the first lock with d in the comfort band [`band_m`]
    /// (design 8's [0.8, 1.5] m for d0 = 1 m).
    pub time_in_band_frac: Option<f64>,
    /// Time after the first lock without a locked target, s.
    pub target_lost_s: f64,
    /// Collisions of the robot with walls or furniture.
    pub collisions: u32,
    /// RMS jerk of the commanded speed (its second difference over the control
    /// period), m/s^3.
    pub rms_jerk: f64,
    /// RMS jerk of the commanded turn rate (second difference), rad/s^3.
    pub rms_angular_jerk: f64,
    /// Time from the start to the first lock, s.
    pub first_lock_s: Option<f64>,
    /// RMSE of the per-frame laser-vision fusion (the paper's complementary fusion) of
    /// the target, m.
    pub rmse_per_frame_fused_m: Option<f64>,
    /// Mean NEES of that per-frame fused estimate.
    pub nees_per_frame_fused: Option<f64>,
}

/// RMSE and mean NEES of the per-frame fused estimate of the target in the camera ticks
/// of `ticks` (the fused person nearest the true target, within the match threshold and
/// nearer to the target than to anyone else).
pub fn per_frame_fused<'a>(
    steps: impl Iterator<Item = (&'a tether_sim::Truth, Option<&'a Tick>)>,
) -> (Option<f64>, Option<f64>) {
    let mut errors = Vec::new();
    let mut nees = Vec::new();
    for (truth, tick) in steps {
        let (Some(target), Some(tick)) = (truth.target(), tick) else {
            continue;
        };
        // The fused estimate of the target: nearest to it, and nearer to it than to
        // anybody else (two people crossing are two estimates, not one error).
        let belongs_to_target = |g: &&Gaussian2<World>| {
            let d = g.mean.distance_m(target.position);
            d <= MATCH_M
                && truth
                    .people
                    .iter()
                    .all(|p| p.target || p.position.distance_m(g.mean) > d)
        };
        let nearest = tick
            .fused_people
            .iter()
            .filter(belongs_to_target)
            .min_by(|a, b| {
                a.mean
                    .distance_m(target.position)
                    .total_cmp(&b.mean.distance_m(target.position))
            });
        if let Some(g) = nearest {
            let e = g.mean - target.position;
            errors.push(e.norm());
            nees.push(g.cov.mahalanobis_sq(e.x, e.y));
        }
    }
    (rmse(&errors), mean(&nees))
}

fn rmse(errors: &[f64]) -> Option<f64> {
    (!errors.is_empty())
        .then(|| (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt())
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The target estimate of a tick, when locked.
fn locked_estimate(tick: &Tick) -> Option<Gaussian2<World>> {
    match tick.target.state {
        TargetState::Locked { .. } => tick.target.estimate,
        _ => None,
    }
}

/// The errors, at one scan, of the locked estimates of the run's passengers (0: laser
/// only, 1: vision only) against the target's true position `truth`; and when the fused
/// pipeline and both passengers are locked, the three errors side by side (`common`).
fn passenger_errors(
    step: &crate::closed_loop::StepRecord,
    truth: Point2<World>,
    locked_estimate: impl Fn(&Tick) -> Option<Gaussian2<World>>,
    common: &mut Vec<[f64; 3]>,
    laser_err: &mut Vec<f64>,
    vision_err: &mut Vec<f64>,
) {
    let fused = step.tick.as_ref().and_then(&locked_estimate);
    let laser = step
        .passengers
        .first()
        .and_then(Option::as_ref)
        .and_then(&locked_estimate);
    let vision = step
        .passengers
        .get(1)
        .and_then(Option::as_ref)
        .and_then(&locked_estimate);
    if let (Some(f), Some(l), Some(v)) = (fused, laser, vision) {
        let e = |g: Gaussian2<World>| (g.mean - truth).norm();
        common.push([e(f), e(l), e(v)]);
    }
    for (k, p) in step.passengers.iter().enumerate() {
        if let Some(est) = p.as_ref().and_then(&locked_estimate) {
            let e = (est.mean - truth).norm();
            match k {
                0 => laser_err.push(e),
                1 => vision_err.push(e),
                _ => {}
            }
        }
    }
}

/// Computes the measures of a run. Passenger 0 is taken as laser-only and passenger 1
/// as vision-only when present.
pub fn measure(log: &RunLog) -> RunMetrics {
    let mut fused_err = Vec::new();
    let mut nees = Vec::new();
    let mut laser_err = Vec::new();
    let mut vision_err = Vec::new();
    let mut mot = ClearMot::new(MATCH_M);
    let mut common: Vec<[f64; 3]> = Vec::new();
    let mut swaps = 0u32;
    let mut following_target: Option<bool> = None;

    let mut first_lock: Option<f64> = None;
    let mut d_err = Vec::new();
    let mut in_band = 0usize;
    let mut timer_ticks = 0usize;
    let mut lost_ticks = 0usize;
    let mut min_d = f64::INFINITY;
    let mut commands: Vec<(f64, f64, f64)> = Vec::new();
    let timer_dt = 1.0 / crate::closed_loop::CONTROL_RATE_HZ;

    for step in &log.steps {
        let truth = &step.truth;
        let Some(target) = truth.target() else {
            continue;
        };
        // Estimates live in the frame of the pose the pipelines were given.
        let to_world = step.world_from_estimates();
        let locked_estimate = |tick: &Tick| locked_estimate(tick).map(|g| g.transformed(to_world));
        let t = truth.stamp.secs_f64();
        let j = truth.world_from_robot * Point2::new(log.attach_ahead_m, 0.0);
        let d = target.position.distance_m(j);
        min_d = min_d.min(d);

        if let Some(tick) = &step.tick {
            if first_lock.is_none() && matches!(tick.target.state, TargetState::Locked { .. }) {
                first_lock = Some(t);
            }
            if step.kind == StepKind::Scan {
                if let Some(est) = locked_estimate(tick) {
                    let e = est.mean - target.position;
                    fused_err.push(e.norm());
                    nees.push(est.cov.mahalanobis_sq(e.x, e.y));
                }
                // CLEAR MOT against the people the laser sees.
                let objects: Vec<(u64, Point2<World>)> = truth
                    .people
                    .iter()
                    .filter(|p| p.laser_beams.is_some_and(|b| b > 0))
                    .map(|p| (u64::from(p.id), p.position))
                    .collect();
                let hypotheses: Vec<(u64, Point2<World>)> = tick
                    .tracks
                    .iter()
                    .filter(|tr| tr.confirmed)
                    .map(|tr| (tr.id, to_world * tr.position.mean))
                    .collect();
                mot.add_frame(&objects, &hypotheses);
                // Who is being followed: the person the CLEAR MOT correspondence ties the
                // locked track to (correspondences persist while they hold, so two
                // people passing close by do not count as a swap).
                if let (TargetState::Locked { track }, Some(_)) =
                    (tick.target.state, locked_estimate(tick))
                {
                    let followed = mot
                        .current_matches()
                        .iter()
                        .find(|(_, h)| **h == track)
                        .map(|(o, _)| *o == u64::from(target.id));
                    if let Some(is_target) = followed {
                        if following_target == Some(true) && !is_target {
                            swaps += 1;
                        }
                        following_target = Some(is_target);
                    }
                }
            }
        }
        if step.kind == StepKind::Scan {
            passenger_errors(
                step,
                target.position,
                locked_estimate,
                &mut common,
                &mut laser_err,
                &mut vision_err,
            );
        }
        if step.kind == StepKind::Timer && first_lock.is_some() {
            timer_ticks += 1;
            d_err.push(d - log.follow_distance_m);
            let band = band_m(log.follow_distance_m);
            if (band.0..=band.1).contains(&d) {
                in_band += 1;
            }
            let locked = step
                .tick
                .as_ref()
                .is_some_and(|tick| matches!(tick.target.state, TargetState::Locked { .. }));
            if !locked {
                lost_ticks += 1;
            }
        }
        if step.kind == StepKind::Timer
            && let Some(tick) = &step.tick
        {
            commands.push((t, tick.command.v_mps, tick.command.w_radps));
        }
    }

    // Jerk from the commanded velocities at the control rate: the derivative of the
    // acceleration, the second difference of the velocity (a third difference of the
    // velocity would be snap, m/s^4).
    let jerk = |component: fn(&(f64, f64, f64)) -> f64| {
        let values: Vec<f64> = commands.iter().map(component).collect();
        let j: Vec<f64> = values
            .windows(3)
            .map(|w| (w[2] - 2.0 * w[1] + w[0]) / timer_dt.powi(2))
            .collect();
        rmse(&j).unwrap_or(0.0)
    };
    let s = mot.summary();
    let (rmse_per_frame_fused_m, nees_per_frame_fused) = per_frame_fused(
        log.steps
            .iter()
            .filter(|s| s.kind == StepKind::Camera)
            .map(|s| (s.truth_in_estimate_frame(), s.tick.as_ref()))
            .collect::<Vec<_>>()
            .iter()
            .map(|(t, k)| (t, *k)),
    );
    RunMetrics {
        scenario: log.scenario.clone(),
        seed: log.seed,
        rmse_fused_m: rmse(&fused_err),
        rmse_laser_m: rmse(&laser_err),
        rmse_vision_m: rmse(&vision_err),
        rmse_common_m: (!common.is_empty()).then(|| {
            [0, 1, 2]
                .map(|k| rmse(&common.iter().map(|c| c[k]).collect::<Vec<_>>()).unwrap_or(f64::NAN))
        }),
        common_scans: common.len(),
        nees_mean: mean(&nees),
        mota: s.mota,
        motp_m: s.motp_m,
        id_switches: s.id_switches,
        target_swaps: swaps,
        mean_abs_distance_error_m: mean(&d_err.iter().map(|e| e.abs()).collect::<Vec<_>>()),
        rms_distance_error_m: rmse(&d_err),
        min_distance_m: min_d,
        time_in_band_frac: (timer_ticks > 0).then(|| in_band as f64 / timer_ticks as f64),
        target_lost_s: lost_ticks as f64 * timer_dt,
        collisions: log.collisions,
        rms_jerk: jerk(|c| c.1),
        rms_angular_jerk: jerk(|c| c.2),
        first_lock_s: first_lock,
        rmse_per_frame_fused_m,
        nees_per_frame_fused,
    }
}
