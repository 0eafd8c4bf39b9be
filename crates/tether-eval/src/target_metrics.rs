//! How well a simulated run's target lock held, against the ground truth: whether the
//! locked track is the true person while the laser can see them, whether it is ever a
//! bystander, and how soon the person is taken up again after being hidden (issue 14's
//! measures; design 8 and 11.10).

use serde::Serialize;
use tether_core::{Point2, World};
use tether_fusion::TargetState;
use tether_sim::Truth;

use crate::closed_loop::{RunLog, StepKind};

/// Within this distance of a person, the locked track is on them, m (the CLEAR MOT match
/// threshold of Leigh et al., ICRA 2015).
pub const ON_PERSON_M: f64 = 0.75;

/// The laser sees the target when this many beams hit their legs (fewer cannot make a
/// leg: the detector's smallest segment).
pub const VISIBLE_BEAMS: u32 = 3;

/// A hidden spell shorter than this is not a disappearance (the detector misses in
/// bursts anyway), s.
pub const HIDDEN_MIN_S: f64 = 0.5;

/// The target measures of one run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct TargetLockMetrics {
    /// Scans after the first lock with the target visible to the laser.
    pub visible_scans: u64,
    /// Of those, scans with the locked track on the target.
    pub on_target_scans: u64,
    /// Of those, scans with the locked track on somebody else (within
    /// [`ON_PERSON_M`] of another person and nearer to them than to the target).
    pub wrong_scans: u64,
    /// `on_target_scans / visible_scans`.
    pub on_target_frac: Option<f64>,
    /// Times the target came back into the laser's view after at least
    /// [`HIDDEN_MIN_S`] hidden.
    pub reappearances: u32,
    /// Of those, how many were taken up again (locked on the target) within 1 s.
    pub reacquired_within_1s: u32,
    /// Longest time from a reappearance to the lock being on the target again, s (a
    /// reappearance that ends hidden again or at the end of the run before it is taken
    /// up counts with its visible time).
    pub max_reacquire_s: Option<f64>,
}

/// Distance from `p` to the nearest person who is not the target, m.
pub fn nearest_other(truth: &Truth, p: Point2<World>) -> Option<f64> {
    truth
        .people
        .iter()
        .filter(|q| !q.target)
        .map(|q| (q.position - p).norm())
        .min_by(f64::total_cmp)
}

/// Measures `log`.
pub fn measure_target_lock(log: &RunLog) -> TargetLockMetrics {
    let mut m = TargetLockMetrics::default();
    let mut first_lock = false;
    let mut hidden_since: Option<f64> = None;
    let mut last_visible_t: Option<f64> = None;
    // The reappearance being waited on: when it came back.
    let mut waiting: Option<f64> = None;
    let mut delays: Vec<f64> = Vec::new();
    for step in &log.steps {
        if step.kind != StepKind::Scan {
            continue;
        }
        // Estimates live in the frame of the pose the pipeline was given (dead
        // reckoning or scan matching without odometry): compare them with the truth
        // expressed in that frame, as seen from the robot.
        let truth = step.truth_in_estimate_frame();
        let Some(target) = truth.target() else {
            continue;
        };
        let t = step.truth.stamp.secs_f64();
        let locked = step.tick.as_ref().and_then(|tick| match tick.target.state {
            TargetState::Locked { .. } => tick.target.estimate.map(|e| e.mean),
            _ => None,
        });
        first_lock |= locked.is_some();
        let visible = target.laser_beams.unwrap_or(0) >= VISIBLE_BEAMS;
        let on_target = locked.is_some_and(|p| {
            let d = (p - target.position).norm();
            d <= ON_PERSON_M && nearest_other(&truth, p).is_none_or(|o| d <= o)
        });
        if !visible {
            if hidden_since.is_none() {
                hidden_since = Some(t);
                if let (Some(back), Some(last)) = (waiting.take(), last_visible_t) {
                    // Hidden again before being taken up.
                    delays.push(last - back);
                }
            }
            continue;
        }
        if let Some(since) = hidden_since.take()
            && first_lock
            && t - since >= HIDDEN_MIN_S
        {
            m.reappearances += 1;
            waiting = Some(t);
        }
        last_visible_t = Some(t);
        if !first_lock {
            continue;
        }
        m.visible_scans += 1;
        if on_target {
            m.on_target_scans += 1;
            if let Some(back) = waiting.take() {
                delays.push(t - back);
                m.reacquired_within_1s += u32::from(t - back <= 1.0);
            }
        } else if let Some(p) = locked
            && nearest_other(&truth, p).is_some_and(|o| o <= ON_PERSON_M)
        {
            m.wrong_scans += 1;
        }
    }
    if let (Some(back), Some(last)) = (waiting, last_visible_t) {
        delays.push(last - back);
    }
    m.on_target_frac =
        (m.visible_scans > 0).then(|| m.on_target_scans as f64 / m.visible_scans as f64);
    m.max_reacquire_s = delays.into_iter().max_by(f64::total_cmp);
    m
}
