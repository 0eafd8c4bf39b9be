//! The per-scan detector: pre-process, segment, find legs (arc test or learned
//! classifier), pair them into people.

use serde::{Deserialize, Serialize};
use tether_core::{Laser, LaserScan, Point2, RangeNoiseModel};
use thiserror::Error;

use crate::arc::{ArcTestConfig, arc_test};
use crate::classifier::{CompiledClassifier, LegClassifier};
use crate::confirm::{ConfirmConfig, RecentLegs};
use crate::features::{Candidate, FeatureScratch, ScanView, add_context, segment_features};
use crate::fit::centroid;
use crate::people::{
    Leg, PairScratch, PairingConfig, PersonKind, PersonObservation, lone_leg_estimate, pair_legs,
};
use crate::preprocess::{
    BeamTable, PreprocessStats, ScanPoint, closes_the_circle, preprocess_into,
};
use crate::segment::{Breakpoint, ClusterScratch, Segment, cluster_into};

/// A detector configuration that cannot work.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("leg detector configuration is invalid: {0}")]
pub struct ConfigError(pub String);

/// Which test decides that a segment is a leg.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DetectorKind {
    /// The paper's arc test ([`crate::arc`]).
    Arc,
    /// The learned classifier ([`crate::classifier`]).
    Learned,
}

/// Parameters of the leg detector. Every field has the default it documents.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct DetectorConfig {
    /// Segmentation rule (default: Euclidean clustering at 0.13 m, [`Breakpoint::default`]).
    pub breakpoint: Breakpoint,
    /// Fewest returns in a leg candidate (default 3).
    #[config(range = ">= 3")]
    pub min_points: usize,
    /// Widest candidate segment, first to last return, m (default 0.5: wider than two
    /// legs side by side, so no leg).
    #[config(range = "> 0")]
    pub max_width_m: f64,
    /// The arc test. Its diameter range also bounds the learned detector's radius
    /// estimate.
    pub arc: ArcTestConfig,
    /// Pairing and covariance.
    pub pairing: PairingConfig,
    /// Candidates whose classifier margin falls short of the decision by less than this
    /// are reported as weak legs (learned detector only; 0: none): not people, but
    /// enough to keep a person already tracked there (default 0.2 of the margin's
    /// [-1, 1] range).
    #[config(range = ">= 0, <= 2")]
    pub weak_margin: f64,
    /// Confirmation of narrow legs over the last scans (learned detector only): a leg
    /// that passes the classifier by less than `extra_margin` needs an accepted
    /// candidate near it in the last scans, or is only an unconfirmed one, which
    /// updates tracks but starts none (design 4.6; off by default).
    pub confirm: ConfirmConfig,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            breakpoint: Breakpoint::default(),
            min_points: 3,
            max_width_m: 0.5,
            arc: ArcTestConfig::default(),
            pairing: PairingConfig::default(),
            weak_margin: 0.2,
            confirm: ConfirmConfig::default(),
        }
    }
}

impl DetectorConfig {
    /// The defaults with narrow legs confirmed over the last scans
    /// ([`ConfirmConfig::PER_SCAN`]): the detector of `tether legs` and `eval-legs`,
    /// whose legs are the product (design 4.6).
    pub fn per_scan() -> Self {
        DetectorConfig {
            confirm: ConfirmConfig::PER_SCAN,
            ..DetectorConfig::default()
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.breakpoint.validate().map_err(ConfigError)?;
        self.arc.validate().map_err(ConfigError)?;
        self.pairing.validate().map_err(ConfigError)?;
        self.confirm.validate().map_err(ConfigError)?;
        if self.min_points < 3 {
            return Err(ConfigError(format!(
                "min_points must be >= 3 (three points define an arc), got {}",
                self.min_points
            )));
        }
        if !(self.weak_margin.is_finite() && (0.0..=2.0).contains(&self.weak_margin)) {
            return Err(ConfigError(format!(
                "weak_margin must be in [0, 2], got {}",
                self.weak_margin
            )));
        }
        if !(self.max_width_m.is_finite() && self.max_width_m > 0.0) {
            return Err(ConfigError(format!(
                "max_width_m must be > 0, got {}",
                self.max_width_m
            )));
        }
        Ok(())
    }
}

/// Counts for one scan.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DetectionStats {
    /// Pre-processing counts.
    pub preprocess: PreprocessStats,
    /// Segments found.
    pub segments: usize,
    /// Segments that were tested as legs.
    pub candidates: usize,
    /// Leg-sized segments that are no candidates because they reach within
    /// [`FIELD_OF_VIEW_EDGE_BEAMS`] of the first or last beam of a scan that does not
    /// close the circle (cut by the field of view).
    pub cut_by_field_of_view: usize,
    /// Candidates the classifier accepted narrowly with no accepted candidate near
    /// them in the last scans, reported as weak legs ([`crate::confirm`]).
    pub unconfirmed: usize,
}

/// What one scan shows: legs and people, in the scan's frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Detection {
    /// Leg candidates that passed the test.
    pub legs: Vec<Leg>,
    /// Person observations built from them.
    pub people: Vec<PersonObservation>,
    /// Candidates the classifier nearly accepted (see [`DetectorConfig::weak_margin`]).
    pub weak_legs: Vec<Leg>,
    /// Each weak leg as a lone-leg person hypothesis (`OneLeg` indexes `weak_legs`):
    /// evidence for a person already tracked there, never a new person.
    pub weak_people: Vec<PersonObservation>,
    /// Each leg the classifier accepted that the last scans did not confirm
    /// ([`DetectorConfig::confirm`]; among `weak_legs`, which `OneLeg` indexes) as a
    /// lone-leg person: evidence for a person tracked there, even one not yet
    /// confirmed, but no new person.
    pub unconfirmed_people: Vec<PersonObservation>,
    /// Counts.
    pub stats: DetectionStats,
}

/// Detects legs and people in scans, one call per scan.
///
/// It keeps its buffers between calls, so after the first scan a call allocates only
/// when a scan has more of something than any before. Pure computation: no I/O, no
/// clock; the same scans give the same detections.
#[derive(Debug, Clone)]
pub struct LegDetector {
    config: DetectorConfig,
    noise: RangeNoiseModel,
    classifier: Option<LegClassifier>,
    /// The classifier laid out for speed.
    compiled: CompiledClassifier,
    /// The model for scans whose beams are [`COARSE_BEAM_STEP_RAD`] or more apart, if
    /// any ([`LegDetector::with_coarse_model`]), laid out for speed.
    coarse: Option<CompiledClassifier>,
    table: BeamTable,
    points: Vec<ScanPoint>,
    order: Vec<usize>,
    clustered: Vec<ScanPoint>,
    cluster_scratch: ClusterScratch,
    segments: Vec<Segment>,
    candidates: Vec<Candidate>,
    scratch: FeatureScratch,
    pair_scratch: PairScratch,
    /// The candidates accepted in the last scans ([`crate::confirm`]).
    recent: RecentLegs,
}

impl LegDetector {
    /// A detector using the paper's arc test.
    pub fn arc(config: DetectorConfig, noise: RangeNoiseModel) -> Result<Self, ConfigError> {
        Self::new(config, noise, None)
    }

    /// A detector using a learned classifier.
    pub fn learned(
        config: DetectorConfig,
        noise: RangeNoiseModel,
        classifier: LegClassifier,
    ) -> Result<Self, ConfigError> {
        classifier
            .validate()
            .map_err(|e| ConfigError(e.to_string()))?;
        Self::new(config, noise, Some(classifier))
    }

    /// The learned detector with the built-in models: [`LegClassifier::default_model`]
    /// and, for scans whose beams are [`COARSE_BEAM_STEP_RAD`] or more apart,
    /// [`LegClassifier::default_coarse_model`] (design 4.6).
    pub fn builtin(config: DetectorConfig, noise: RangeNoiseModel) -> Result<Self, ConfigError> {
        let model = |m: Result<LegClassifier, crate::classifier::ModelError>| {
            m.map_err(|e| ConfigError(format!("the built-in leg model: {e}")))
        };
        Self::learned(config, noise, model(LegClassifier::default_model())?)?
            .with_coarse_model(model(LegClassifier::default_coarse_model())?)
    }

    /// Classifies the clusters of scans whose beams are [`COARSE_BEAM_STEP_RAD`] or
    /// more apart with `classifier` (a model trained for such scanners) instead.
    pub fn with_coarse_model(mut self, classifier: LegClassifier) -> Result<Self, ConfigError> {
        classifier
            .validate()
            .map_err(|e| ConfigError(e.to_string()))?;
        self.coarse = Some(CompiledClassifier::new(&classifier));
        Ok(self)
    }

    fn new(
        config: DetectorConfig,
        noise: RangeNoiseModel,
        classifier: Option<LegClassifier>,
    ) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(LegDetector {
            config,
            noise,
            compiled: classifier
                .as_ref()
                .map(CompiledClassifier::new)
                .unwrap_or_default(),
            classifier,
            coarse: None,
            table: BeamTable::default(),
            points: Vec::new(),
            order: Vec::new(),
            clustered: Vec::new(),
            cluster_scratch: ClusterScratch::default(),
            segments: Vec::new(),
            candidates: Vec::new(),
            scratch: FeatureScratch::default(),
            pair_scratch: PairScratch::default(),
            recent: RecentLegs::default(),
        })
    }

    /// Which test this detector runs.
    pub fn kind(&self) -> DetectorKind {
        if self.classifier.is_some() {
            DetectorKind::Learned
        } else {
            DetectorKind::Arc
        }
    }

    /// The configuration.
    pub fn config(&self) -> &DetectorConfig {
        &self.config
    }

    /// Detects legs and people in `scan`.
    pub fn detect(&mut self, scan: &LaserScan) -> Detection {
        let mut out = Detection::default();
        self.detect_into(scan, &mut out);
        out
    }

    /// Like [`LegDetector::detect`], reusing `out`'s buffers.
    pub fn detect_into(&mut self, scan: &LaserScan, out: &mut Detection) {
        out.legs.clear();
        out.weak_legs.clear();
        out.weak_people.clear();
        out.unconfirmed_people.clear();
        let learned = self.classifier.is_some();
        out.stats = self.find_candidates(scan, learned);
        // A coarse scan goes to the coarse model when there is one.
        let compiled = match &self.coarse {
            Some(coarse) if scan.angle_increment_rad.abs() >= COARSE_BEAM_STEP_RAD => coarse,
            _ => &self.compiled,
        };
        let weak_floor = compiled.decision_margin() - self.config.weak_margin;
        let confirm = self.config.confirm;
        let confirmed_margin = compiled.decision_margin() + confirm.extra_margin;
        if learned {
            self.recent.start_scan(scan.stamp, confirm.window_s);
            self.recent.keep_beams(scan);
        }
        let (seam, n) = (out.stats.preprocess.seam_beam, scan.len());
        let scan_beam = |beam: usize| (beam + seam) % n;
        for c in &self.candidates {
            let pts = &self.clustered[c.segment.start..c.segment.end];
            let leg = |centre_in_laser, radius_m, score| Leg {
                centre_in_laser,
                radius_m,
                centroid_in_laser: c.centroid_in_laser,
                score,
                first_beam: scan_beam(pts[0].beam),
                last_beam: scan_beam(pts[pts.len() - 1].beam),
                n_points: pts.len(),
            };
            match &self.classifier {
                None => out
                    .legs
                    .extend(arc_test(pts, &self.config.arc).ok().map(|arc| {
                        let score = (1.0 - arc.spread_m / self.config.arc.delta_m).clamp(0.0, 1.0);
                        leg(arc.centre_in_laser, arc.radius_m, score)
                    })),
                Some(_) => {
                    let margin = if self.config.weak_margin > 0.0 {
                        compiled.margin_if_at_least(&c.features, weak_floor)
                    } else {
                        compiled.margin_if_leg(&c.features)
                    };
                    let Some(margin) = margin else {
                        continue;
                    };
                    let (centre, radius_m) =
                        learned_centre(c.centroid_in_laser, c.features[WIDTH], &self.config);
                    let found = leg(centre, radius_m, 0.5 * (margin + 1.0));
                    let accepted = margin >= compiled.decision_margin();
                    if accepted {
                        self.recent.accepted(centre);
                    }
                    let confirmed = margin >= confirmed_margin
                        || (accepted
                            && (self.recent.supports(centre, confirm.radius_m)
                                || self.recent.was_hidden(centre)));
                    if accepted && !confirmed {
                        out.stats.unconfirmed += 1;
                    }
                    if confirmed {
                        out.legs.push(found);
                    } else if let Some(estimate) = lone_leg_estimate(
                        &found,
                        scan.angle_increment_rad,
                        &self.noise,
                        &self.config.pairing,
                    ) {
                        let person = PersonObservation {
                            estimate,
                            kind: PersonKind::OneLeg(out.weak_legs.len()),
                            score: found.score * self.config.pairing.single_leg_score_factor,
                        };
                        match accepted {
                            true => out.unconfirmed_people.push(person),
                            false => out.weak_people.push(person),
                        }
                        out.weak_legs.push(found);
                    }
                }
            }
        }
        if learned {
            self.recent.finish_scan();
        }
        pair_legs(
            &out.legs,
            scan.angle_increment_rad,
            &self.noise,
            &self.config.pairing,
            &mut self.pair_scratch,
            &mut out.people,
        );
    }

    /// The leg candidates of `scan` with all their features, whatever the detector
    /// kind: what the classifier is trained and evaluated on.
    pub fn candidates(&mut self, scan: &LaserScan) -> Vec<Candidate> {
        self.find_candidates(scan, true);
        self.candidates.clone()
    }

    /// Pre-processes and clusters `scan`, and keeps the candidate clusters (with their
    /// features if `with_features`) in `self.candidates`.
    fn find_candidates(&mut self, scan: &LaserScan, with_features: bool) -> DetectionStats {
        let mut stats = self.segment(scan);
        self.candidates.clear();
        let view = ScanView {
            points: &self.points,
            cluster_of: self.cluster_scratch.cluster_of(),
            angle_increment_rad: scan.angle_increment_rad,
        };
        // On a scan that does not close the circle, a cluster reaching within
        // [`FIELD_OF_VIEW_EDGE_BEAMS`] of its first or last beam may run on past the
        // field of view: how wide it is and what lies beyond are unknown, so it is no
        // candidate: neither judged nor trained on, nor context for the others (a
        // robot's own body at the edge of a scanner's view is the common case).
        let inside = if closes_the_circle(scan) {
            0..=usize::MAX
        } else {
            FIELD_OF_VIEW_EDGE_BEAMS + 1..=scan.len().saturating_sub(2 + FIELD_OF_VIEW_EDGE_BEAMS)
        };
        for (k, &seg) in self.segments.iter().enumerate() {
            let pts = &self.clustered[seg.start..seg.end];
            if !is_candidate(pts, &self.config) {
                continue;
            }
            if !(inside.contains(&pts[0].beam) && inside.contains(&pts[pts.len() - 1].beam)) {
                stats.cut_by_field_of_view += 1;
                continue;
            }
            let features = if with_features {
                segment_features(&view, k as u32, pts, &mut self.scratch)
            } else {
                [0.0; crate::features::N_FEATURES]
            };
            self.candidates.push(Candidate {
                segment: seg,
                centroid_in_laser: centroid(pts),
                features,
            });
        }
        if with_features {
            add_context(&mut self.candidates);
        }
        stats.candidates = self.candidates.len();
        stats
    }

    /// Pre-processes and clusters `scan` into the detector's buffers.
    fn segment(&mut self, scan: &LaserScan) -> DetectionStats {
        self.table.update(scan);
        let preprocess = preprocess_into(scan, &self.noise, &self.table, &mut self.points);
        cluster_into(
            &self.points,
            scan.angle_increment_rad,
            &self.noise,
            self.config.breakpoint,
            &mut self.cluster_scratch,
            &mut self.order,
            &mut self.segments,
        );
        self.clustered.clear();
        self.clustered
            .extend(self.order.iter().map(|&i| self.points[i]));
        DetectionStats {
            preprocess,
            segments: self.segments.len(),
            candidates: 0,
            cut_by_field_of_view: 0,
            unconfirmed: 0,
        }
    }
}

/// Whether a cluster (its returns in beam order) is tested as a leg: enough returns,
/// and first and last no farther apart than `max_width_m`.
fn is_candidate(pts: &[ScanPoint], config: &DetectorConfig) -> bool {
    if pts.len() < config.min_points {
        return false;
    }
    // Squared lengths: `hypot` would cost more than the rest of the test.
    let v = pts[0].point_in_laser - pts[pts.len() - 1].point_in_laser;
    v.x * v.x + v.y * v.y <= config.max_width_m * config.max_width_m
}

/// Beams this far apart or more make a coarse scan (0.45 deg): the 0.5-1 degree steps
/// of the 360-degree triangulation scanners most small robots carry (RPLIDAR A1/A2,
/// LDS-01, YDLIDAR X4), against 0.25-0.36 degrees for the Hokuyo and SICK scanners that
/// recorded the training data.
pub const COARSE_BEAM_STEP_RAD: f64 = 0.45 * std::f64::consts::PI / 180.0;

/// A cluster whose first or last beam lies this many beams or fewer from the edge of
/// a scan's field of view is cut by it (a beam or two of no return between them hide
/// nothing).
pub const FIELD_OF_VIEW_EDGE_BEAMS: usize = 2;

/// Index of `width_m` in the feature vector.
const WIDTH: usize = 5;

/// Where the leg of a classified cluster stands, and its radius. The returns cover
/// the side facing the sensor, so their centroid `c` lies in front of the leg's axis:
/// for a circle of radius `R` whose visible half is sampled evenly across the line of
/// sight, by `mean(sqrt(R^2 - y^2)) = pi R / 4`. The centre is `c` moved that far away
/// from the sensor, with `R` = half the cluster's width (first to last return) clamped
/// to the leg diameter range of `config.arc`.
pub fn learned_centre(
    c: Point2<Laser>,
    width_m: f64,
    config: &DetectorConfig,
) -> (Point2<Laser>, f64) {
    let radius_m = (0.5 * width_m).clamp(
        0.5 * config.arc.diameter_min_m,
        0.5 * config.arc.diameter_max_m,
    );
    let range = c.range_m();
    let push = std::f64::consts::FRAC_PI_4 * radius_m;
    let centre = if range > 0.0 {
        Point2::new(c.x * (1.0 + push / range), c.y * (1.0 + push / range))
    } else {
        c
    };
    (centre, radius_m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_round_trips_and_is_checked() {
        let config = DetectorConfig::default();
        let json = serde_json::to_string(&config).unwrap();
        assert!(json.contains("\"rule\":\"euclidean\""), "{json}");
        let back: DetectorConfig = serde_json::from_str(&json).unwrap();
        assert_eq!(back, config);
        let partial: DetectorConfig =
            serde_json::from_str(r#"{"breakpoint": {"rule": "fixed_jump", "jump_m": 0.15}}"#)
                .unwrap();
        assert_eq!(partial.breakpoint, Breakpoint::FixedJump { jump_m: 0.15 });
        assert_eq!(partial.min_points, 3);
        assert!(serde_json::from_str::<DetectorConfig>(r#"{"min_pts": 3}"#).is_err());
        let bad = DetectorConfig {
            min_points: 2,
            ..DetectorConfig::default()
        };
        assert!(LegDetector::arc(bad, RangeNoiseModel::default()).is_err());
        let bad = DetectorConfig {
            max_width_m: f64::NAN,
            ..DetectorConfig::default()
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn kind_follows_the_constructor() {
        let arc = LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default()).unwrap();
        assert_eq!(arc.kind(), DetectorKind::Arc);
        let model = LegClassifier::default_model().unwrap();
        let learned =
            LegDetector::learned(DetectorConfig::default(), RangeNoiseModel::default(), model)
                .unwrap();
        assert_eq!(learned.kind(), DetectorKind::Learned);
    }
}
