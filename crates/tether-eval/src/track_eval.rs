//! Tracking and target measures on annotated recordings (`tether eval-track`, issue
//! 14): CLEAR MOT as Leigh et al. (ICRA 2015) compute it, and how well the followed
//! target stays on the labelled person.
//!
//! **Labels.** A label message gives the people of one scan in the scan's frame:
//! `leg_tracker/PersonArray` (an id and a pose per person) or `geometry_msgs/PoseArray`
//! (positions only). A PoseArray is read either as the legs of one person
//! ([`PoseLabels::Legs`]: the person is the mean of the one or two legs, id 0, as in
//! leg_tracker's `positive_*_extracted.bag`) or as people ([`PoseLabels::People`]: one
//! person per pose, ids by their order in the array, so identity switches mean little).
//!
//! **Pairing** a label message with its scan ([`Pairing`]): leg_tracker's annotations
//! are published right after their scan with its stamp; its extracted training bags
//! publish `/leg_cluster_positions` with a zero stamp just before each `/training_scan`.
//! Header-less `leg_tracker/Person` messages (Leigh et al.'s benchmark recordings, one
//! labelled person a message, right after the scan) are paired by position alone: all
//! the Person messages between scan k and scan k+1 are scan k's people
//! ([`tether_recording::samples::LabelSource::Person`]).
//!
//! A scan given several label messages keeps the one nearest to it in stamp (the later
//! on a tie), e.g. `/truth/people` of `tether sim --record`, written for camera frames
//! too.
//!
//! **Measures**, over the labelled scans in log order (labels put in the world frame
//! with the scan's `world_from_robot * robot_from_laser`, or taken as in the world
//! frame already, [`LabelsFrame`]):
//! - CLEAR MOT (Bernardin and Stiefelhagen 2008) of the confirmed tracks against the
//!   labelled people, match within [`crate::metrics::MATCH_M`] (0.75 m), see
//!   [`crate::ClearMot`].
//! - The target (the locked track's estimate, what the robot follows) against the
//!   target label: *on the person* when within 0.75 m of it, *lost* when no track is
//!   locked, *on a wrong person* when locked but farther than 0.75 m. Each labelled
//!   scan counts for the time to the next labelled scan of its stretch (the last one of
//!   a stretch for the mean interval of the stretch).
//! - Stretches: a gap longer than `gap_s` between consecutive labelled scans starts a
//!   new stretch; *target switches* count the changes of the locked track id from one
//!   labelled scan to a later one of the same stretch (a loss in between does not hide
//!   a change).

use std::collections::BTreeSet;

use crate::{ClearMot, MotSummary};
use serde::Serialize;
use tether_core::{Laser, Point2, Pose2, Stamp, World};

use crate::metrics::MATCH_M;
use tether_live::recording_run::ScanStep;
use tether_recording::samples::{LabelMessage, LabelSource};

/// Which scan a label message belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Pairing {
    /// A label whose stamp is the stamp of the scan just before it belongs to that
    /// scan (leg_tracker's `Person` annotations, `tether sim --record-bag`); a label
    /// with a zero stamp belongs to the next scan (leg_tracker's extracted training
    /// bags); any other label to whichever of the scans just before and just after it
    /// is nearer in stamp.
    Auto,
    /// The next scan in log order.
    Before,
    /// The previous scan in log order.
    After,
}

/// How a `geometry_msgs/PoseArray` of labels is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum PoseLabels {
    /// The poses are the legs of one person, who is at their mean (id 0).
    Legs,
    /// Each pose is a person (ids by order in the array).
    People,
}

/// The frame the labels' positions are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum LabelsFrame {
    /// The scan's frame (leg_tracker's annotations; `tether sim --record-bag`): put in
    /// the world with the scan's `world_from_robot * robot_from_laser`.
    Scan,
    /// The world frame: the odometry frame with an odometry topic (e.g. `/truth/people`
    /// of `tether sim --record`), the scan's frame without.
    World,
}

/// Options of the evaluation.
#[derive(Debug, Clone, Copy)]
pub struct EvalOptions {
    /// Label-to-scan pairing.
    pub pairing: Pairing,
    /// How PoseArray labels are read.
    pub pose_labels: PoseLabels,
    /// The frame of the labels.
    pub labels_frame: LabelsFrame,
    /// The labelled person the robot should follow (`None`: the only label id, if
    /// there is only one).
    pub target_label: Option<u32>,
    /// A gap between labelled scans longer than this starts a new stretch, s.
    pub gap_s: f64,
}

/// One scan as the evaluation keeps it.
#[derive(Debug, Clone)]
struct ScanRecord {
    stamp: Stamp,
    frame_id: String,
    world_from_laser: Pose2<World, Laser>,
    /// Confirmed tracks.
    hypotheses: Vec<(u64, Point2<World>)>,
    /// Locked track and its estimate.
    target: Option<(u64, Point2<World>)>,
    /// Labelled people, in the world frame.
    labels: Option<Vec<(u64, Point2<World>)>>,
    /// |label stamp - scan stamp| of the label message kept, ns.
    labels_dt_ns: Option<u64>,
}

/// Collects scans and labels while the recording is read, then measures.
#[derive(Debug)]
pub struct TrackEval {
    options: EvalOptions,
    scans: Vec<ScanRecord>,
    /// Label messages waiting for the next scan, with whether they may still go to the
    /// previous one (auto pairing of a stamp that matches neither).
    pending: Vec<(LabelMessage, bool)>,
    label_messages: usize,
    unpaired: usize,
    doubled: usize,
    frame_mismatches: usize,
}

/// Target measures.
#[derive(Debug, Clone, Serialize)]
pub struct TargetMeasures {
    /// The target's label id.
    pub label: u64,
    /// Labelled scans in which the target is labelled.
    pub labelled_scans: usize,
    /// Of those, the scans with the target within 0.75 m of the person.
    pub on_person_scans: usize,
    /// `on_person_scans / labelled_scans`.
    pub on_person_share: f64,
    /// Scans with no locked target.
    pub lost_scans: usize,
    /// Time without a locked target, s.
    pub lost_s: f64,
    /// Scans with the target locked but not within 0.75 m of the person.
    pub wrong_scans: usize,
    /// Time on a wrong person, s.
    pub wrong_s: f64,
    /// Time the target is labelled, s.
    pub labelled_s: f64,
    /// Changes of the locked track inside a stretch.
    pub switches_in_stretches: usize,
    /// Stretches with at least one scan on a wrong person.
    pub stretches_with_wrong_target: usize,
}

/// One stretch of labelled scans.
#[derive(Debug, Clone, Serialize)]
pub struct Stretch {
    /// Stamp of its first labelled scan, ns.
    pub start_ns: i64,
    /// Stamp of its last labelled scan, ns.
    pub end_ns: i64,
    /// Labelled scans in it.
    pub labelled_scans: usize,
    /// Scans in it with the target labelled.
    pub target_scans: usize,
    /// Of those, scans with the target on the person.
    pub on_person_scans: usize,
    /// Scans on a wrong person.
    pub wrong_scans: usize,
    /// Changes of the locked track.
    pub switches: usize,
}

/// Everything `tether eval-track` reports.
#[derive(Debug, Clone, Serialize)]
pub struct EvalReport {
    /// Scans through the pipeline.
    pub scans: usize,
    /// Scans with a label message.
    pub labelled_scans: usize,
    /// Label messages read.
    pub label_messages: usize,
    /// Label messages with no scan to go to (before the first scan or after the last).
    pub unpaired_label_messages: usize,
    /// Scans that got more than one label message (the one nearest in stamp kept, the
    /// later on a tie).
    pub doubly_labelled_scans: usize,
    /// Label messages whose frame is not their scan's (used as if it were).
    pub frame_mismatches: usize,
    /// Distinct label ids.
    pub label_ids: Vec<u64>,
    /// The pairing rule used.
    pub pairing: Pairing,
    /// Match threshold, m.
    pub match_m: f64,
    /// Gap that starts a new stretch, s.
    pub gap_s: f64,
    /// CLEAR MOT of the confirmed tracks.
    pub clear_mot: MotSummary,
    /// Target measures (absent when no single target label is known).
    pub target: Option<TargetMeasures>,
    /// The stretches.
    pub stretches: Vec<Stretch>,
}

impl TrackEval {
    /// An empty evaluation.
    pub fn new(options: EvalOptions) -> Self {
        TrackEval {
            options,
            scans: Vec::new(),
            pending: Vec::new(),
            label_messages: 0,
            unpaired: 0,
            doubled: 0,
            frame_mismatches: 0,
        }
    }

    /// Takes in a scan and the pipeline's tick for it.
    pub fn on_scan(&mut self, step: &ScanStep<'_>) {
        let tick = step.tick;
        let hypotheses = tick
            .tracks
            .iter()
            .filter(|t| t.confirmed)
            .map(|t| (t.id, t.position.mean))
            .collect();
        let target = tick.target.state.locked_track().and_then(|id| {
            let estimate = tick.target.estimate.map(|g| g.mean).or_else(|| {
                tick.tracks
                    .iter()
                    .find(|t| t.id == id)
                    .map(|t| t.position.mean)
            });
            estimate.map(|p| (id, p))
        });
        self.scans.push(ScanRecord {
            stamp: step.scan.stamp,
            frame_id: step.scan.frame_id.clone(),
            world_from_laser: step.world_from_robot * step.robot_from_laser,
            hypotheses,
            target,
            labels: None,
            labels_dt_ns: None,
        });
        let new = self.scans.len() - 1;
        for (labels, either) in std::mem::take(&mut self.pending) {
            let scan = if either && new > 0 {
                let d = |k: usize| (self.scans[k].stamp.ns() - labels.stamp.ns()).abs();
                if d(new - 1) <= d(new) { new - 1 } else { new }
            } else {
                new
            };
            self.attach(scan, &labels);
        }
    }

    /// Takes in a label message (in log order among the scans).
    pub fn on_labels(&mut self, labels: LabelMessage) {
        self.label_messages += 1;
        let last = self.scans.len().checked_sub(1);
        if labels.source == LabelSource::Person {
            // No header: every Person message after scan k and before scan k+1 is one
            // of scan k's people, whatever `--pairing` says.
            match last {
                Some(k) => self.add_people(k, &labels),
                None => self.unpaired += 1,
            }
            return;
        }
        match self.options.pairing {
            Pairing::After => match last {
                Some(k) => self.attach(k, &labels),
                None => self.unpaired += 1,
            },
            Pairing::Before => self.pending.push((labels, false)),
            Pairing::Auto => {
                if let Some(k) = last.filter(|&k| self.scans[k].stamp == labels.stamp) {
                    self.attach(k, &labels);
                } else if labels.stamp.ns() == 0 {
                    self.pending.push((labels, false));
                } else {
                    self.pending.push((labels, true));
                }
            }
        }
    }

    /// Adds a header-less Person message's person to scan `k`'s labels.
    fn add_people(&mut self, k: usize, labels: &LabelMessage) {
        let scan = &mut self.scans[k];
        let to_world: Pose2<World, Laser> = match self.options.labels_frame {
            LabelsFrame::Scan => scan.world_from_laser,
            LabelsFrame::World => Pose2::IDENTITY,
        };
        let people = labels
            .labels
            .iter()
            .map(|(id, p)| (u64::from(id.unwrap_or(0)), to_world * *p));
        scan.labels.get_or_insert_with(Vec::new).extend(people);
        scan.labels_dt_ns.get_or_insert(0);
    }

    fn attach(&mut self, k: usize, labels: &LabelMessage) {
        let scan = &mut self.scans[k];
        let to_world: Pose2<World, Laser> = match self.options.labels_frame {
            LabelsFrame::Scan => {
                if labels.frame_id != scan.frame_id {
                    self.frame_mismatches += 1;
                }
                scan.world_from_laser
            }
            // Already in the world frame: the identity, named as such.
            LabelsFrame::World => Pose2::IDENTITY,
        };
        let dt_ns = (labels.stamp.ns() - scan.stamp.ns()).unsigned_abs();
        let people: Vec<(u64, Point2<World>)> =
            match (labels.labels.first(), self.options.pose_labels) {
                // PersonArray: ids given.
                (Some((Some(_), _)), _) => labels
                    .labels
                    .iter()
                    .map(|(id, p)| (u64::from(id.unwrap_or(0)), to_world * *p))
                    .collect(),
                (None, _) => Vec::new(),
                (Some((None, _)), PoseLabels::Legs) => {
                    let n = labels.labels.len() as f64;
                    let (sx, sy) = labels
                        .labels
                        .iter()
                        .fold((0.0, 0.0), |(x, y), (_, p)| (x + p.x, y + p.y));
                    vec![(0, to_world * Point2::<Laser>::new(sx / n, sy / n))]
                }
                (Some((None, _)), PoseLabels::People) => labels
                    .labels
                    .iter()
                    .enumerate()
                    .map(|(i, (_, p))| (i as u64, to_world * *p))
                    .collect(),
            };
        match scan.labels_dt_ns {
            // A second label message: the one nearer in stamp stays (the later on a tie).
            Some(old) => {
                self.doubled += 1;
                if dt_ns <= old {
                    scan.labels = Some(people);
                    scan.labels_dt_ns = Some(dt_ns);
                }
            }
            None => {
                scan.labels = Some(people);
                scan.labels_dt_ns = Some(dt_ns);
            }
        }
    }

    /// Measures over everything taken in.
    pub fn finish(mut self) -> EvalReport {
        self.unpaired += self.pending.len();
        let labelled: Vec<&ScanRecord> = self.scans.iter().filter(|s| s.labels.is_some()).collect();
        let ids: BTreeSet<u64> = labelled
            .iter()
            .flat_map(|s| s.labels.iter().flatten().map(|(id, _)| *id))
            .collect();
        let target_label = match self.options.target_label {
            Some(id) => Some(u64::from(id)),
            None if ids.len() == 1 => ids.first().copied(),
            None => None,
        };
        let mut mot = ClearMot::new(MATCH_M);
        // Stretches: indices into `labelled`.
        let mut stretches: Vec<std::ops::Range<usize>> = Vec::new();
        for (i, s) in labelled.iter().enumerate() {
            let new_stretch = i == 0
                || (s.stamp.ns() - labelled[i - 1].stamp.ns()) as f64 * 1e-9 > self.options.gap_s;
            if new_stretch {
                stretches.push(i..i + 1);
            } else if let Some(last) = stretches.last_mut() {
                last.end = i + 1;
            }
        }
        let mut out_stretches = Vec::new();
        let mut t = TargetMeasures {
            label: target_label.unwrap_or(0),
            labelled_scans: 0,
            on_person_scans: 0,
            on_person_share: f64::NAN,
            lost_scans: 0,
            lost_s: 0.0,
            wrong_scans: 0,
            wrong_s: 0.0,
            labelled_s: 0.0,
            switches_in_stretches: 0,
            stretches_with_wrong_target: 0,
        };
        for range in &stretches {
            let scans = &labelled[range.clone()];
            // Time each scan stands for: to the next labelled scan; the last one the
            // mean interval of the stretch (zero for a stretch of one scan).
            let gaps: Vec<f64> = scans
                .windows(2)
                .map(|w| (w[1].stamp.ns() - w[0].stamp.ns()) as f64 * 1e-9)
                .collect();
            let mean_gap = if gaps.is_empty() {
                0.0
            } else {
                gaps.iter().sum::<f64>() / gaps.len() as f64
            };
            let mut st = Stretch {
                start_ns: scans[0].stamp.ns(),
                end_ns: scans[scans.len() - 1].stamp.ns(),
                labelled_scans: scans.len(),
                target_scans: 0,
                on_person_scans: 0,
                wrong_scans: 0,
                switches: 0,
            };
            let mut last_track: Option<u64> = None;
            for (i, s) in scans.iter().enumerate() {
                let labels = s.labels.as_deref().unwrap_or(&[]);
                mot.add_frame(labels, &s.hypotheses);
                if let Some((track, _)) = s.target {
                    if last_track.is_some_and(|l| l != track) {
                        st.switches += 1;
                    }
                    last_track = Some(track);
                }
                let Some(label) = target_label else {
                    continue;
                };
                let Some((_, person)) = labels.iter().find(|(id, _)| *id == label) else {
                    continue;
                };
                let dt = gaps.get(i).copied().unwrap_or(mean_gap);
                st.target_scans += 1;
                t.labelled_s += dt;
                match s.target {
                    Some((_, p)) if p.distance_m(*person) <= MATCH_M => st.on_person_scans += 1,
                    Some(_) => {
                        st.wrong_scans += 1;
                        t.wrong_s += dt;
                    }
                    None => {
                        t.lost_scans += 1;
                        t.lost_s += dt;
                    }
                }
            }
            t.labelled_scans += st.target_scans;
            t.on_person_scans += st.on_person_scans;
            t.wrong_scans += st.wrong_scans;
            t.switches_in_stretches += st.switches;
            t.stretches_with_wrong_target += usize::from(st.wrong_scans > 0);
            out_stretches.push(st);
        }
        if t.labelled_scans > 0 {
            t.on_person_share = t.on_person_scans as f64 / t.labelled_scans as f64;
        }
        EvalReport {
            scans: self.scans.len(),
            labelled_scans: labelled.len(),
            label_messages: self.label_messages,
            unpaired_label_messages: self.unpaired,
            doubly_labelled_scans: self.doubled,
            frame_mismatches: self.frame_mismatches,
            label_ids: ids.into_iter().collect(),
            pairing: self.options.pairing,
            match_m: MATCH_M,
            gap_s: self.options.gap_s,
            clear_mot: mot.summary(),
            target: target_label.map(|_| t),
            stretches: out_stretches,
        }
    }
}

impl EvalReport {
    /// The report as text for a person.
    pub fn text(&self) -> String {
        let m = &self.clear_mot;
        let mut s = format!(
            "{} scans, {} labelled ({} label messages, {} unpaired, {} scans labelled more than once), \
             {} stretches (gap > {} s), label ids {:?}\n",
            self.scans,
            self.labelled_scans,
            self.label_messages,
            self.unpaired_label_messages,
            self.doubly_labelled_scans,
            self.stretches.len(),
            self.gap_s,
            self.label_ids
        );
        s += &format!(
            "CLEAR MOT (match within {} m): {} people labelled, {} matches, {} misses, \
             {} false positives, {} identity switches, MOTA {:.4}, MOTP {:.4} m\n",
            self.match_m,
            m.objects,
            m.matches,
            m.misses,
            m.false_positives,
            m.id_switches,
            m.mota,
            m.motp_m
        );
        match &self.target {
            Some(t) => {
                s += &format!(
                    "target (label {}): on the person in {} of {} labelled scans ({:.1} %), \
                     lost {} scans ({:.1} s), on a wrong person {} scans ({:.1} s) of {:.1} s \
                     labelled; {} target switches inside stretches, {} stretches with a wrong \
                     target\n",
                    t.label,
                    t.on_person_scans,
                    t.labelled_scans,
                    100.0 * t.on_person_share,
                    t.lost_scans,
                    t.lost_s,
                    t.wrong_scans,
                    t.wrong_s,
                    t.labelled_s,
                    t.switches_in_stretches,
                    t.stretches_with_wrong_target
                );
            }
            None => {
                s += "target: no measures (several label ids; give --target-label)\n";
            }
        }
        if self.frame_mismatches > 0 {
            s += &format!(
                "warning: {} label messages are in another frame than their scan (used as \
                 if in the scan's frame)\n",
                self.frame_mismatches
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        reason = "test code: a failed unwrap is a failed test"
    )]

    use super::*;
    use tether_control::Twist;
    use tether_core::{Cov2, Gaussian2, LaserScan, Vector2};
    use tether_fusion::TargetState;
    use tether_pipeline::{TargetView, Tick, TickInput, TrackView};

    const MS: i64 = 1_000_000;

    fn scan(t_ms: i64) -> LaserScan {
        LaserScan::new(
            Stamp::from_ns(t_ms * MS),
            "laser",
            -1.0,
            0.5,
            0.02,
            5.0,
            vec![1.0; 5],
        )
        .unwrap()
    }

    /// A tick with confirmed tracks `(id, x)` at y = 0 and the target locked on one.
    fn tick(t_ms: i64, tracks: &[(u64, f64)], target: Option<u64>) -> Tick {
        let g =
            |x: f64| Gaussian2::new(Point2::new(x, 0.0), Cov2::isotropic(0.1).unwrap()).unwrap();
        Tick {
            stamp: Stamp::from_ns(t_ms * MS),
            input: TickInput::Scan,
            laser_people: Vec::new(),
            vision_people: Vec::new(),
            fused_people: Vec::new(),
            tracks: tracks
                .iter()
                .map(|&(id, x)| TrackView {
                    id,
                    confirmed: true,
                    position: g(x),
                    velocity: Vector2::new(0.0, 0.0),
                })
                .collect(),
            target: TargetView {
                state: target.map_or(TargetState::Searching, |track| TargetState::Locked {
                    track,
                }),
                id: target,
                estimate: target
                    .and_then(|id| tracks.iter().find(|t| t.0 == id))
                    .map(|t| g(t.1)),
                velocity: None,
            },
            command: Twist::STOP,
            wanted: Twist::STOP,
            stop: None,
            refusals: Vec::new(),
            somebody_else: Vec::new(),
            transition: None,
        }
    }

    fn feed(eval: &mut TrackEval, t_ms: i64, tracks: &[(u64, f64)], target: Option<u64>) {
        let s = scan(t_ms);
        let tk = tick(t_ms, tracks, target);
        eval.on_scan(&ScanStep {
            scan: &s,
            tick: &tk,
            world_from_robot: Pose2::IDENTITY,
            robot_from_laser: Pose2::IDENTITY,
            tracks: &[],
        });
    }

    fn legs(t_ms: i64, xs: &[f64]) -> LabelMessage {
        LabelMessage {
            stamp: Stamp::from_ns(t_ms * MS),
            frame_id: "laser".into(),
            labels: xs.iter().map(|&x| (None, Point2::new(x, 0.1))).collect(),
            source: LabelSource::PoseArray,
        }
    }

    fn options(pairing: Pairing) -> EvalOptions {
        EvalOptions {
            pairing,
            pose_labels: PoseLabels::Legs,
            labels_frame: LabelsFrame::Scan,
            target_label: None,
            gap_s: 0.5,
        }
    }

    #[test]
    fn zero_stamped_legs_go_to_the_next_scan_and_count() {
        // leg_tracker's extracted bags: legs (stamp 0) just before each scan. The
        // person is the mean of the legs; the track at x follows them.
        let mut e = TrackEval::new(options(Pairing::Auto));
        let frames: [(i64, [f64; 2], Option<u64>); 6] = [
            (1000, [1.9, 2.1], None),    // before the lock: lost
            (1100, [1.9, 2.1], Some(7)), // on the person
            (1200, [2.9, 3.1], Some(7)), // the track is at 2.0, person at 3.0: wrong
            (1300, [1.9, 2.1], Some(8)), // another track at 2.0: on the person, a switch
            // 2 s gap: a new stretch.
            (3300, [1.9, 2.1], Some(9)), // a new track id in a new stretch: no switch
            (3400, [1.9, 2.1], Some(9)),
        ];
        for (t, xs, target) in frames {
            e.on_labels(legs(0, &xs));
            feed(&mut e, t, &[(7, 2.0), (8, 2.0), (9, 2.0)], target);
        }
        // A label after the last scan has no scan to go to.
        e.on_labels(legs(0, &[1.0]));
        let r = e.finish();
        assert_eq!(
            (r.scans, r.labelled_scans, r.unpaired_label_messages),
            (6, 6, 1)
        );
        assert_eq!(r.label_ids, vec![0]);
        assert_eq!(r.stretches.len(), 2);
        let t = r.target.unwrap();
        assert_eq!(
            (
                t.labelled_scans,
                t.on_person_scans,
                t.lost_scans,
                t.wrong_scans
            ),
            (6, 4, 1, 1)
        );
        assert_eq!(t.switches_in_stretches, 1);
        assert_eq!(t.stretches_with_wrong_target, 1);
        // Each scan stands for the time to the next labelled one; the last of a
        // stretch for the mean interval (0.1 s here).
        assert!((t.lost_s - 0.1).abs() < 1e-9 && (t.wrong_s - 0.1).abs() < 1e-9);
        assert!((t.labelled_s - 0.6).abs() < 1e-9, "{}", t.labelled_s);
        // Three tracks, one person: two false positives a scan, three and a miss in
        // the scan where the person is 1 m from every track.
        let m = r.clear_mot;
        assert_eq!(
            (m.objects, m.matches, m.misses, m.false_positives),
            (6, 5, 1, 13)
        );
    }

    #[test]
    fn pairing_rules() {
        // A label stamped like the scan before it goes to that scan (auto or after);
        // before: to the next one.
        for (pairing, expect_first) in [
            (Pairing::Auto, true),
            (Pairing::After, true),
            (Pairing::Before, false),
        ] {
            let mut e = TrackEval::new(options(pairing));
            feed(&mut e, 1000, &[(1, 2.0)], Some(1));
            e.on_labels(legs(1000, &[2.0]));
            feed(&mut e, 1100, &[(1, 5.0)], Some(1));
            let r = e.finish();
            assert_eq!(r.labelled_scans, 1);
            let on = r.target.unwrap().on_person_scans;
            assert_eq!(on == 1, expect_first, "{pairing:?}");
        }
        // Auto with another stamp: the nearer scan, before or after.
        for (stamp, on_first) in [(1030, true), (1080, false)] {
            let mut e = TrackEval::new(options(Pairing::Auto));
            feed(&mut e, 1000, &[(1, 2.0)], Some(1));
            e.on_labels(legs(stamp, &[2.0]));
            feed(&mut e, 1100, &[(1, 5.0)], Some(1));
            let r = e.finish();
            assert_eq!(r.target.unwrap().on_person_scans == 1, on_first, "{stamp}");
        }
        // Two label messages for one scan: the nearer in stamp stays.
        let mut e = TrackEval::new(options(Pairing::After));
        feed(&mut e, 1000, &[(1, 2.0)], Some(1));
        e.on_labels(legs(1000, &[2.0]));
        e.on_labels(legs(1040, &[5.0]));
        let r = e.finish();
        assert_eq!(r.doubly_labelled_scans, 1);
        assert_eq!(r.target.unwrap().on_person_scans, 1);
    }

    #[test]
    fn person_messages_add_up_for_the_scan_before_them() {
        let person = |id: u32, x: f64| LabelMessage {
            stamp: Stamp::from_ns(0),
            frame_id: String::new(),
            labels: vec![(Some(id), Point2::new(x, 0.0))],
            source: LabelSource::Person,
        };
        // Whatever the pairing: one before any scan (unpaired), two after the first
        // scan, none after the second (unlabelled), one after the third.
        for pairing in [Pairing::Auto, Pairing::Before, Pairing::After] {
            let mut e = TrackEval::new(options(pairing));
            e.on_labels(person(4, 2.0));
            feed(&mut e, 1000, &[(1, 2.0), (2, 4.0)], None);
            e.on_labels(person(4, 2.0));
            e.on_labels(person(5, 4.0));
            feed(&mut e, 1100, &[(1, 2.0), (2, 4.0)], None);
            feed(&mut e, 1200, &[(1, 2.0), (2, 4.0)], None);
            e.on_labels(person(4, 2.0));
            let r = e.finish();
            assert_eq!(
                (
                    r.labelled_scans,
                    r.unpaired_label_messages,
                    r.doubly_labelled_scans
                ),
                (2, 1, 0),
                "{pairing:?}"
            );
            assert_eq!(r.label_ids, vec![4, 5]);
            // Scan 1: both people matched; scan 3: one person, the other track false.
            let m = r.clear_mot;
            assert_eq!(
                (m.objects, m.matches, m.false_positives),
                (3, 3, 1),
                "{pairing:?}"
            );
        }
    }

    #[test]
    fn several_ids_need_a_target_label() {
        let people = |t: i64| LabelMessage {
            stamp: Stamp::from_ns(t * MS),
            frame_id: "laser".into(),
            labels: vec![
                (Some(4), Point2::new(2.0, 0.0)),
                (Some(5), Point2::new(4.0, 0.0)),
            ],
            source: LabelSource::PersonArray,
        };
        let run = |target_label| {
            let mut e = TrackEval::new(EvalOptions {
                target_label,
                ..options(Pairing::Auto)
            });
            feed(&mut e, 1000, &[(1, 2.0), (2, 4.0)], Some(2));
            e.on_labels(people(1000));
            e.finish()
        };
        let r = run(None);
        assert!(r.target.is_none() && r.text().contains("--target-label"));
        assert_eq!((r.clear_mot.matches, r.clear_mot.false_positives), (2, 0));
        assert_eq!(run(Some(5)).target.unwrap().on_person_scans, 1);
        assert_eq!(run(Some(4)).target.unwrap().wrong_scans, 1);
    }
}
