//! tether's cascade trainer (design 3.1, issue 8): trains the kind of boosted Haar cascade
//! the paper trained for its robot's camera and writes it as OpenCV's current cascade XML,
//! which OpenCV 4.x's `CascadeClassifier` and [`tether_vision`] load and run alike.
//!
//! - [`info`]: annotation files in OpenCV's `info.dat` format.
//! - [`features`]: the Haar feature pool (`BASIC`, `CORE`, `ALL` as
//!   `opencv_traincascade -mode`) and its evaluation with the detector's arithmetic.
//! - [`sample`]: training windows as integral images with the variance normalisation.
//! - [`boost`]: Gentle, Discrete and Real AdaBoost over stumps, on feature values
//!   computed once per stage and kept sorted, and the stage threshold that keeps the hit
//!   rate.
//! - [`mining`]: negatives mined with the cascade so far from the detector's own windows.
//! - [`mod@train`]: the stage loop, positives, resumable state, progress events.
//! - [`xml`]: the OpenCV XML writer. [`eval`]: precision, recall and F1 against labels.
//!
//! The crate reads the images it is given and the state file it is pointed at; it prints
//! nothing and reads no clock (progress comes out as [`train::Event`]s).

pub mod boost;
pub mod eval;
pub mod features;
pub mod info;
pub mod mining;
pub mod model;
pub mod rng;
pub mod sample;
pub mod train;
pub mod xml;

pub use boost::{BoostType, StageParams};
pub use features::FeatureMode;
pub use model::CascadeModel;
pub use train::{
    Event, Observer, StageReport, TrainConfig, TrainError, TrainState, TrainingData, train,
};
