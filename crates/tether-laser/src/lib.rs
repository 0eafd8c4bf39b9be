//! Laser person detection for tether (design section 4): from a 2-D scan to person
//! observations with honest covariances.
//!
//! The pipeline, one call per scan ([`LegDetector::detect`]):
//!
//! 1. [`preprocess`](mod@preprocess): drop beams with no return, subtract the calibrated range bias
//!    `bias(r)` ([`tether_core::RangeNoiseModel`]).
//! 2. [`segment`]: cluster the returns: by default leg_tracker's Euclidean clustering
//!    (0.13 m), or split where consecutive returns jump more than Borges and Aldon's
//!    adaptive breakpoint or a fixed distance.
//! 3. Leg candidates, by either
//!    - [`arc`]: the paper's test (bisectors of chords meeting within delta = 40 mm,
//!      centre behind the arc, leg-sized diameter), or
//!    - [`classifier`]: AdaBoost on small trees over the cluster [`features`] of Arras,
//!      Mozos and Burgard (2007), trained on labelled recordings ([`training`]); a
//!      default model is built in ([`LegClassifier::default_model`]).
//! 4. [`people`]: pair legs within 0.6 m into people at the midpoint, keep lone legs as
//!    weaker hypotheses, and give each a covariance: the polar range and bearing noise
//!    propagated to Cartesian plus the spread of the leg midpoint during gait.
//!
//! [`statistics`] measures what matters for tracking (detection against range, runs of
//! misses, merged legs, false positives and their persistence), on real recordings and
//! simulated runs alike.
//!
//! [`calibration`] fits `bias(r)` and `sigma(r)` from measurements at known distances
//! (the paper's Fig. 9).
//!
//! Pure algorithms: no I/O and no clock. Any scan the core type can hold, however
//! broken its ranges, gives a result and never a panic.

pub mod adapt;
pub mod arc;
pub mod augment;
pub mod calibration;
pub mod classifier;
pub mod confirm;
pub mod detector;
pub mod features;
mod fit;
pub mod people;
pub mod preprocess;
pub mod segment;
pub mod self_label;
pub mod statistics;
pub mod training;

pub use arc::{ArcLeg, ArcReject, ArcTestConfig, arc_test};
pub use calibration::{
    CalibrationConfig, CalibrationError, CalibrationFit, CalibrationSample, RangeStats,
    fit_range_noise, simulate_samples,
};
pub use classifier::{CompiledClassifier, LegClassifier, ModelError, Node, Provenance, Tree};
pub use confirm::ConfirmConfig;
pub use detector::{
    COARSE_BEAM_STEP_RAD, ConfigError, Detection, DetectionStats, DetectorConfig, DetectorKind,
    FIELD_OF_VIEW_EDGE_BEAMS, LegDetector,
};
pub use features::{Candidate, FEATURE_NAMES, FeatureVector, N_FEATURES};
pub use fit::Circle;
pub use people::{Leg, PairingConfig, PersonKind, PersonObservation, pair_legs};
pub use preprocess::{ScanPoint, preprocess};
pub use segment::{Breakpoint, Segment};
pub use training::{AdaBoostConfig, TrainError, train_adaboost};
