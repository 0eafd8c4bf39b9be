//! The cascade being trained: stages of decision stumps over Haar features, and its
//! evaluation with the detector's rules (stage thresholds lowered by
//! [`tether_vision::cascade::STAGE_THRESHOLD_EPS`] on load, leaves summed in `f64`,
//! `value < threshold` goes left, a window passes a stage when its sum is not below the
//! threshold).

use serde::{Deserialize, Serialize};
use tether_vision::cascade::STAGE_THRESHOLD_EPS;

use crate::features::{CompiledFeature, Feature, FeatureMode};
use crate::sample::SampleSet;

/// A decision stump: `left` when the normalised feature value is below `threshold`,
/// else `right`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stump {
    /// The feature.
    pub feature: Feature,
    /// Split point of the normalised feature value.
    pub threshold: f32,
    /// Leaf for values below the threshold.
    pub left: f32,
    /// Leaf for the other values.
    pub right: f32,
}

/// One boosted stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stage {
    /// The threshold as written in the XML file (the detector lowers it by `1e-5`).
    pub threshold: f32,
    /// The weak classifiers.
    pub stumps: Vec<Stump>,
}

impl Stage {
    /// The threshold the detector compares the stage sum with.
    pub fn effective_threshold(&self) -> f64 {
        f64::from(self.threshold - STAGE_THRESHOLD_EPS)
    }
}

/// A cascade of stump stages for a `width x height` window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CascadeModel {
    /// Window width, px.
    pub width: u32,
    /// Window height, px.
    pub height: u32,
    /// The feature pool the stumps were chosen from (written in `featureParams`).
    pub mode: FeatureMode,
    /// The stages, first to last.
    pub stages: Vec<Stage>,
}

impl CascadeModel {
    /// A cascade without stages (accepts every window that is not flat).
    pub fn empty(width: u32, height: u32, mode: FeatureMode) -> CascadeModel {
        CascadeModel {
            width,
            height,
            mode,
            stages: Vec::new(),
        }
    }

    /// Weak classifiers (stumps) over all stages.
    pub fn weak_count(&self) -> usize {
        self.stages.iter().map(|s| s.stumps.len()).sum()
    }

    /// The stages compiled for integral images with `stride` entries per row.
    pub fn compile(&self, stride: usize) -> CompiledCascade {
        CompiledCascade {
            stages: self
                .stages
                .iter()
                .map(|s| CompiledStage {
                    threshold: s.effective_threshold(),
                    stumps: s
                        .stumps
                        .iter()
                        .map(|st| CompiledStump {
                            feature: st.feature.compile(stride),
                            threshold: st.threshold,
                            left: st.left,
                            right: st.right,
                        })
                        .collect(),
                })
                .collect(),
        }
    }
}

/// A stump with its feature's offsets.
#[derive(Debug, Clone, Copy)]
pub struct CompiledStump {
    /// The feature.
    pub feature: CompiledFeature,
    /// Split point.
    pub threshold: f32,
    /// Leaf below the split.
    pub left: f32,
    /// Leaf at or above the split.
    pub right: f32,
}

/// A stage with its stumps' offsets.
#[derive(Debug, Clone)]
pub struct CompiledStage {
    /// The detector's threshold (file value minus `1e-5`, in `f32`).
    pub threshold: f64,
    /// The stumps, in file order.
    pub stumps: Vec<CompiledStump>,
}

impl CompiledStage {
    /// The stage sum of a window, in `f64` in file order, as the detector sums it.
    #[inline]
    pub fn sum(&self, sum: &[i32], tilted: &[i32], base: usize, norm: f32) -> f64 {
        let mut total = 0.0f64;
        for s in &self.stumps {
            let v = s.feature.value(sum, tilted, base, norm);
            total += f64::from(if v < s.threshold { s.left } else { s.right });
        }
        total
    }
}

/// A cascade compiled for one integral-image stride.
#[derive(Debug, Clone)]
pub struct CompiledCascade {
    /// The stages.
    pub stages: Vec<CompiledStage>,
}

impl CompiledCascade {
    /// Whether every stage accepts the (not flat) window.
    #[inline]
    pub fn accepts(&self, sum: &[i32], tilted: &[i32], base: usize, norm: f32) -> bool {
        self.stages
            .iter()
            .all(|s| s.sum(sum, tilted, base, norm) >= s.threshold)
    }

    /// Whether every stage accepts sample `i` of a set (compiled for its stride).
    pub fn accepts_sample(&self, set: &SampleSet, i: usize) -> bool {
        let (sum, tilted, base, norm) = set.window(i);
        self.accepts(sum, tilted, base, norm)
    }
}
