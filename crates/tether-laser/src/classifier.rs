//! The learned leg classifier (design 4.6), the model and its inference: boosted small
//! decision trees on segment features, after Arras, Mozos and Burgard (ICRA 2007), who
//! boosted stumps (trees of depth 1). [`LegClassifier`] is the model as its file holds
//! it, with the exact margin; [`CompiledClassifier`] the same decisions in a layout for
//! fast inference. Training, by discrete AdaBoost, is [`crate::training::train_adaboost`].
//!
//! Each weak classifier `h_t` is a tree of at most [`MAX_DEPTH`] levels that votes leg
//! (+1) or not (-1), with the weight `alpha_t` training gave it. The margin
//!
//! ```text
//! F(x) = sum_t alpha_t h_t(x) / sum_t alpha_t      in [-1, 1]
//! ```
//!
//! says "leg" when `F(x) >= decision_margin`.
//!
//! The default, 300 trees of depth 3, is what cross-validation on the training split
//! of the leg_tracker data supports (`tether train-legs`; four folds, one recording of
//! legs each, detections within 0.15 m of a label): F1 0.811, against 0.814 for 300
//! trees of depth 2, 0.798 for 200 and 0.816 for 400 of depth 3, and 0.663 for 200
//! stumps. Depth 3 led (0.822 against 0.803) while the clustering still joined returns
//! across any beam gap; with leg_tracker's beam window, depths 2 and 3 are within the
//! noise of the folds. The decision margin is chosen by the same cross-validation
//! ([`crate::training::cross_validate`]).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::features::{FEATURE_NAMES, FeatureVector, N_FEATURES};

/// Identifies the model file format.
pub const MODEL_FORMAT: &str = "tether-legs-adaboost-trees/1";

/// The model committed with the crate (`models/legs_default.json`), made by `tether
/// train-legs` with its defaults (see the crate's README for the command).
pub const DEFAULT_MODEL_JSON: &str = include_str!("../models/legs_default.json");

/// The built-in model for coarse scans (beams 0.45 degrees apart or more), trained on
/// the same recordings seen by coarser scanners (design 4.6), as JSON.
pub const DEFAULT_COARSE_MODEL_JSON: &str = include_str!("../models/legs_coarse.json");

/// Why a model file cannot be used.
#[derive(Debug, Error)]
pub enum ModelError {
    /// The text is not a model of this format.
    #[error("leg model is not valid JSON of format {MODEL_FORMAT:?}: {0}")]
    Parse(#[from] serde_json::Error),
    /// The format tag differs.
    #[error(
        "leg model has format {found:?}, this build reads {MODEL_FORMAT:?}; retrain it with \
         `tether train-legs`"
    )]
    Format {
        /// The model's format tag.
        found: String,
    },
    /// The model was trained on other features.
    #[error(
        "leg model was trained on the features [{found}] but this build computes [{expected}]; \
         retrain it with `tether train-legs`"
    )]
    Features {
        /// Features in the model.
        found: String,
        /// Features this build computes.
        expected: String,
    },
    /// A tree is malformed.
    #[error("leg model tree {tree} is invalid: {why}")]
    Tree {
        /// Position of the tree.
        tree: usize,
        /// What is wrong.
        why: String,
    },
}

/// A node of a tree: a split or a leaf.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum Node {
    /// Go to `below` if `x[feature] <= threshold`, else to `above` (node indices, both
    /// greater than this node's).
    Split {
        /// Index into the feature vector.
        feature: usize,
        /// Split value, in the feature's unit.
        threshold: f64,
        /// Node for values at or below the threshold.
        below: usize,
        /// Node for values above it.
        above: usize,
    },
    /// A vote: +1 leg, -1 not a leg.
    Leaf {
        /// The vote.
        vote: i8,
    },
}

/// One weak classifier: a small tree and its weight.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tree {
    /// Vote weight `alpha`.
    pub alpha: f64,
    /// Nodes; node 0 is the root.
    pub nodes: Vec<Node>,
}

impl Tree {
    /// The tree's vote for `x`. The model's validation guarantees that every path
    /// ends in a leaf; a malformed tree votes 0 rather than loop or panic.
    pub(crate) fn vote(&self, x: &FeatureVector) -> f64 {
        let mut k = 0;
        for _ in 0..self.nodes.len() {
            match self.nodes.get(k) {
                Some(Node::Leaf { vote }) => return f64::from(*vote),
                Some(Node::Split {
                    feature,
                    threshold,
                    below,
                    above,
                }) => {
                    let value = x.get(*feature).copied().unwrap_or(f64::NAN);
                    k = if value <= *threshold { *below } else { *above };
                }
                None => return 0.0,
            }
        }
        0.0
    }

    fn validate(&self) -> Result<(), String> {
        if !(self.alpha.is_finite() && self.alpha > 0.0) {
            return Err(format!("alpha {} is not a positive number", self.alpha));
        }
        if self.nodes.is_empty() {
            return Err("it has no nodes".into());
        }
        for (k, node) in self.nodes.iter().enumerate() {
            match *node {
                Node::Leaf { vote } if vote != 1 && vote != -1 => {
                    return Err(format!("node {k} votes {vote}, not +1 or -1"));
                }
                Node::Leaf { .. } => {}
                Node::Split {
                    feature,
                    threshold,
                    below,
                    above,
                } => {
                    if feature >= N_FEATURES {
                        return Err(format!(
                            "node {k} splits on feature {feature} >= {N_FEATURES}"
                        ));
                    }
                    if !threshold.is_finite() {
                        return Err(format!("node {k} has threshold {threshold}"));
                    }
                    for child in [below, above] {
                        if child <= k || child >= self.nodes.len() {
                            return Err(format!(
                                "node {k} points to node {child}: children must come later \
                                 and exist"
                            ));
                        }
                    }
                }
            }
        }
        let depth = tree_depth(self);
        if depth > MAX_DEPTH {
            return Err(format!(
                "it is {depth} splits deep; training makes at most {MAX_DEPTH}"
            ));
        }
        Ok(())
    }
}

/// The deepest tree that training makes and a model may hold.
pub const MAX_DEPTH: usize = 8;

/// How the model was made; informational, kept in the model file.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Provenance {
    /// The command that produced the model.
    pub command: String,
    /// Positive (leg) training samples.
    pub positives: usize,
    /// Negative training samples.
    pub negatives: usize,
    /// Training data, one entry per source.
    pub sources: Vec<String>,
    /// How the decision margin was chosen.
    pub margin_choice: String,
}

/// A trained leg classifier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LegClassifier {
    /// Always [`MODEL_FORMAT`].
    pub format: String,
    /// Feature names, in the order the trees index them.
    pub features: Vec<String>,
    /// A segment is a leg when its margin `F(x)` reaches this value.
    pub decision_margin: f64,
    /// The boosted trees.
    pub trees: Vec<Tree>,
    /// How the model was made.
    #[serde(default)]
    pub provenance: Provenance,
}

impl LegClassifier {
    /// Reads and checks a model from JSON text.
    pub fn from_json(text: &str) -> Result<Self, ModelError> {
        let model: LegClassifier = serde_json::from_str(text)?;
        model.validate()?;
        Ok(model)
    }

    /// The committed default model ([`DEFAULT_MODEL_JSON`]).
    pub fn default_model() -> Result<Self, ModelError> {
        Self::from_json(DEFAULT_MODEL_JSON)
    }

    /// The committed model for coarse scans ([`DEFAULT_COARSE_MODEL_JSON`]).
    pub fn default_coarse_model() -> Result<Self, ModelError> {
        Self::from_json(DEFAULT_COARSE_MODEL_JSON)
    }

    /// The model as JSON, one tree per line, with a final newline.
    pub fn to_json(&self) -> String {
        let trees: Vec<String> = self
            .trees
            .iter()
            .map(|t| format!("    {}", json(t)))
            .collect();
        format!(
            "{{\n  \"format\": {},\n  \"features\": {},\n  \"decision_margin\": {},\n  \
             \"provenance\": {},\n  \"trees\": [\n{}\n  ]\n}}\n",
            json(&self.format),
            json(&self.features),
            json(&self.decision_margin),
            json(&self.provenance),
            trees.join(",\n")
        )
    }

    /// Checks format, feature list and trees.
    pub fn validate(&self) -> Result<(), ModelError> {
        if self.format != MODEL_FORMAT {
            return Err(ModelError::Format {
                found: self.format.clone(),
            });
        }
        if self
            .features
            .iter()
            .map(String::as_str)
            .ne(FEATURE_NAMES.iter().copied())
        {
            return Err(ModelError::Features {
                found: self.features.join(", "),
                expected: FEATURE_NAMES.join(", "),
            });
        }
        if !self.decision_margin.is_finite() {
            return Err(ModelError::Tree {
                tree: 0,
                why: format!("decision_margin {} is not finite", self.decision_margin),
            });
        }
        if self.trees.is_empty() {
            return Err(ModelError::Tree {
                tree: 0,
                why: "the model has no trees".into(),
            });
        }
        // Each weight is finite, and so must be their sum, the margin's denominator
        // (two weights of 1e308 made every margin NaN: no segment was ever a leg).
        let mut total = 0.0;
        for (tree, t) in self.trees.iter().enumerate() {
            t.validate().map_err(|why| ModelError::Tree { tree, why })?;
            total += t.alpha;
            if !total.is_finite() {
                return Err(ModelError::Tree {
                    tree,
                    why: format!(
                        "alpha {} takes the sum of the weights past {:e}",
                        t.alpha,
                        f64::MAX
                    ),
                });
            }
        }
        Ok(())
    }

    /// The margin `F(x) = sum alpha_t h_t(x) / sum alpha_t`, in `[-1, 1]`.
    pub fn margin(&self, x: &FeatureVector) -> f64 {
        let (mut vote, mut total) = (0.0, 0.0);
        for t in &self.trees {
            vote += t.alpha * t.vote(x);
            total += t.alpha;
        }
        if total > 0.0 { vote / total } else { 0.0 }
    }

    /// `Some(F(x))` when `F(x) >= decision_margin`, else `None`: the decision of
    /// [`LegClassifier::is_leg`] with the margin of a leg, at less cost (see
    /// [`CompiledClassifier`], which a detector builds once).
    pub fn margin_if_leg(&self, x: &FeatureVector) -> Option<f64> {
        CompiledClassifier::new(self).margin_if_leg(x)
    }

    /// The margin mapped to `[0, 1]`: `(F(x) + 1) / 2`.
    pub fn score(&self, x: &FeatureVector) -> f64 {
        0.5 * (self.margin(x) + 1.0)
    }

    /// Whether the features describe a leg: `F(x) >= decision_margin`.
    pub fn is_leg(&self, x: &FeatureVector) -> bool {
        self.margin(x) >= self.decision_margin
    }
}

/// A validated classifier laid out for speed. Every tree is stored as a complete
/// binary tree of the model's largest depth `D`, in heap order (the children of node
/// `k` are `2k + 1`, at or below the threshold, and `2k + 2`): a leaf above depth `D`
/// becomes a split whose two children vote alike, which changes no vote. A tree is
/// then `D` comparisons with no branch on the path taken, and its `2^D` leaves hold
/// `alpha_t h_t`. [`CompiledClassifier::margin_if_leg`] sums the trees in order and
/// stops once even a unanimous vote of the trees left could not lift the sum to the
/// decision margin (checked every few trees; a non-leg rarely needs them all); a leg
/// is summed in full, so its margin is exactly [`LegClassifier::margin`] (same terms,
/// same order). Stopping is safe to 1e-9 of the total weight, far more than the
/// rounding of the sums, so whether and where it stops never changes the answer.
#[derive(Debug, Clone, Default)]
pub struct CompiledClassifier {
    depth: usize,
    /// Per tree, `2^D - 1` splits: feature index and threshold.
    features: Vec<u32>,
    thresholds: Vec<f64>,
    /// Per tree, `2^D` leaves: `alpha_t` times the vote.
    leaves: Vec<f64>,
    alphas: Vec<f64>,
    /// The same trees in fixed-size records when the model is [`SHALLOW_DEPTH`] deep
    /// (both built-in models are) and every leaf votes +1 or -1: no bounds check per
    /// node (a byte indexes the padded features), the path's nodes computed from its
    /// comparisons, the vote's sign put on the weight, the alphas still to come
    /// precomputed: on the simulated office's 720-beam scans (34 candidates each, the
    /// coarse model) about 26 us a scan, against 38 us for records walked node by
    /// node with an exit check per tree.
    shallow: Vec<ShallowTree>,
    total: f64,
    decision_margin: f64,
}

/// Depth of the models whose trees get the fixed-size layout of [`ShallowTree`].
const SHALLOW_DEPTH: usize = 3;

/// Length of the feature vector as [`ShallowTree`]s read it: the features, then NaN
/// (what a split on a feature index out of range sees, as `x.get()` would), as many
/// as a byte indexes, so that a feature index needs neither a bounds check nor a mask.
const PADDED_FEATURES: usize = 256;

/// Trees summed between two checks of [`CompiledClassifier::margin_if_at_least`]'s
/// early exit: the check costs about as much as a tree, and stopping a few trees later
/// changes nothing but the work.
const TREES_PER_CHECK: usize = 8;

/// A tree of depth [`SHALLOW_DEPTH`], complete, in heap order.
#[derive(Debug, Clone, Copy, Default)]
struct ShallowTree {
    thresholds: [f64; 7],
    /// Feature indices (into the padded vector).
    features: [u8; 7],
    /// Bit `l` set when leaf `l` votes -1, clear when it votes +1 (a model with any
    /// other vote does not get this layout).
    against_leaves: u8,
    alpha: f64,
    /// The sum of the alphas of the trees after this one, as the sequence
    /// `total - alpha_0 - alpha_1 - ...` gives it.
    alpha_left: f64,
}

impl ShallowTree {
    /// `alpha h(x)`. The three comparisons of the path, each picking the next node
    /// (`above`: the value is not at or below the threshold, as for NaN): node 0, then
    /// `1 + c0`, then `3 + 2 c0 + c1`, and leaf `2 (2 c0 + c1) + c2`. The vote's sign
    /// is put on `alpha` directly, which is `alpha * (+-1.0)` exactly.
    #[inline(always)]
    fn vote(&self, x: &[f64; PADDED_FEATURES]) -> f64 {
        let above = |k: usize| {
            let value = x[usize::from(self.features[k & 7])];
            usize::from(!(value <= self.thresholds[k & 7]))
        };
        let c0 = above(0);
        let path = 2 * c0 + above(1 + c0);
        let leaf = 2 * path + above(3 + path);
        let against = u64::from((self.against_leaves >> (leaf & 7)) & 1);
        f64::from_bits(self.alpha.to_bits() ^ (against << 63))
    }
}

impl CompiledClassifier {
    /// Lays out `model`, which must have passed [`LegClassifier::validate`].
    pub fn new(model: &LegClassifier) -> Self {
        let depth = model.trees.iter().map(tree_depth).max().unwrap_or(0);
        let mut out = CompiledClassifier {
            depth,
            decision_margin: model.decision_margin,
            ..CompiledClassifier::default()
        };
        for t in &model.trees {
            out.alphas.push(t.alpha);
            out.total += t.alpha;
            let splits = out.features.len();
            out.features.resize(splits + (1 << depth) - 1, 0);
            out.thresholds.resize(splits + (1 << depth) - 1, 0.0);
            let leaves = out.leaves.len();
            out.leaves.resize(leaves + (1 << depth), 0.0);
            // (node of the model, position in the complete tree, depth), depth first.
            let mut stack = vec![(0usize, 0usize, 0usize)];
            while let Some((node, at, level)) = stack.pop() {
                match t.nodes.get(node) {
                    Some(&Node::Split {
                        feature,
                        threshold,
                        below,
                        above,
                    }) if level < depth => {
                        out.features[splits + at] = feature as u32;
                        out.thresholds[splits + at] = threshold;
                        stack.push((below, 2 * at + 1, level + 1));
                        stack.push((above, 2 * at + 2, level + 1));
                    }
                    leaf => {
                        let vote = match leaf {
                            Some(&Node::Leaf { vote }) => f64::from(vote),
                            _ => 0.0,
                        };
                        // Every leaf of the complete tree under `at` votes alike.
                        let first = (at + 1) << (depth - level);
                        let count = 1 << (depth - level);
                        let start = leaves + first - (1 << depth);
                        out.leaves[start..start + count].fill(t.alpha * vote);
                    }
                }
            }
        }
        if depth == SHALLOW_DEPTH {
            let (n_splits, n_leaves) = ((1 << depth) - 1, 1 << depth);
            let mut alpha_left = out.total;
            let mut every_vote_is_plus_or_minus_one = true;
            for (t, &alpha) in out.alphas.iter().enumerate() {
                alpha_left -= alpha;
                let mut tree = ShallowTree {
                    alpha,
                    alpha_left,
                    ..ShallowTree::default()
                };
                for k in 0..n_splits {
                    tree.thresholds[k] = out.thresholds[t * n_splits + k];
                    tree.features[k] =
                        out.features[t * n_splits + k].min(PADDED_FEATURES as u32 - 1) as u8;
                }
                for k in 0..n_leaves {
                    let leaf = out.leaves[t * n_leaves + k];
                    tree.against_leaves |= u8::from(leaf < 0.0) << k;
                    every_vote_is_plus_or_minus_one &= leaf != 0.0;
                }
                out.shallow.push(tree);
            }
            if every_vote_is_plus_or_minus_one {
                // The records hold every tree: the general layout is not kept twice.
                out.features = Vec::new();
                out.thresholds = Vec::new();
                out.leaves = Vec::new();
            } else {
                // A path without a leaf (a model that was not validated) votes 0,
                // which only the general layout holds.
                out.shallow = Vec::new();
            }
        }
        out
    }

    /// `Some(F(x))` when `F(x) >= decision_margin`, else `None`.
    pub fn margin_if_leg(&self, x: &FeatureVector) -> Option<f64> {
        self.margin_if_at_least(x, self.decision_margin)
    }

    /// The model's decision margin.
    pub fn decision_margin(&self) -> f64 {
        self.decision_margin
    }

    /// `Some(F(x))` when `F(x) >= min_margin`, else `None` (a caller's own threshold,
    /// e.g. a lower one where a tracked person is expected).
    pub fn margin_if_at_least(&self, x: &FeatureVector, min_margin: f64) -> Option<f64> {
        let total = self.total;
        if !(total > 0.0) {
            return (0.0 >= min_margin).then_some(0.0);
        }
        // F >= m  <=>  vote >= m * total; what is left can add at most `remaining`.
        let needed = min_margin * total - 1e-9 * total;
        let (mut vote, mut remaining) = (0.0, total);
        if !self.shallow.is_empty() {
            let mut padded = [f64::NAN; PADDED_FEATURES];
            padded[..N_FEATURES].copy_from_slice(x);
            // The same terms in the same order; the exit checked after every
            // [`TREES_PER_CHECK`] trees.
            let mut groups = self.shallow.chunks_exact(TREES_PER_CHECK);
            for group in &mut groups {
                for tree in group {
                    vote += tree.vote(&padded);
                }
                if vote + group[TREES_PER_CHECK - 1].alpha_left < needed {
                    return None;
                }
            }
            for tree in groups.remainder() {
                vote += tree.vote(&padded);
            }
            let margin = vote / total;
            return (margin >= min_margin).then_some(margin);
        }
        let n_splits = (1 << self.depth) - 1;
        let n_leaves = 1 << self.depth;
        for (t, &alpha) in self.alphas.iter().enumerate() {
            let features = &self.features[t * n_splits..(t + 1) * n_splits];
            let thresholds = &self.thresholds[t * n_splits..(t + 1) * n_splits];
            let mut k = 0;
            for _ in 0..self.depth {
                let value = x.get(features[k] as usize).copied().unwrap_or(f64::NAN);
                k = 2 * k + 1 + usize::from(!(value <= thresholds[k]));
            }
            vote += self.leaves[t * n_leaves + k - n_splits];
            remaining -= alpha;
            if vote + remaining < needed {
                return None;
            }
        }
        let margin = vote / total;
        (margin >= min_margin).then_some(margin)
    }
}

/// Depth of a tree whose children come after their parent (as validation demands):
/// splits on the longest path from the root, computed from the last node back.
fn tree_depth(tree: &Tree) -> usize {
    let mut depth = vec![0usize; tree.nodes.len()];
    for k in (0..tree.nodes.len()).rev() {
        if let Node::Split { below, above, .. } = tree.nodes[k] {
            let child = |c: usize| depth.get(c).copied().unwrap_or(0);
            depth[k] = 1 + child(below).max(child(above));
        }
    }
    depth.first().copied().unwrap_or(0)
}

/// Compact JSON of a part of the model (serde_json cannot fail on these plain types;
/// should it ever, the error text lands in the file and reading it back fails loudly).
fn json<T: Serialize + ?Sized>(value: &T) -> String {
    serde_json::to_string(value).unwrap_or_else(|e| format!("\"{e}\""))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_bad_model_files() {
        let good = LegClassifier::default_model().unwrap();
        let mut m = good.clone();
        m.features.swap(0, 1);
        assert!(matches!(
            LegClassifier::from_json(&m.to_json()),
            Err(ModelError::Features { .. })
        ));
        let mut m = good.clone();
        m.trees[0].nodes[0] = Node::Split {
            feature: 0,
            threshold: 1.0,
            below: 0,
            above: 1,
        };
        assert!(matches!(
            LegClassifier::from_json(&m.to_json()),
            Err(ModelError::Tree { tree: 0, .. })
        ));
        let mut m = good.clone();
        m.trees[1].nodes = vec![Node::Leaf { vote: 3 }];
        assert!(matches!(
            LegClassifier::from_json(&m.to_json()),
            Err(ModelError::Tree { tree: 1, .. })
        ));
        let mut m = good.clone();
        m.trees[2].alpha = -1.0;
        assert!(matches!(
            LegClassifier::from_json(&m.to_json()),
            Err(ModelError::Tree { tree: 2, .. })
        ));
        let mut m = good;
        m.format = "other".into();
        assert!(matches!(
            LegClassifier::from_json(&m.to_json()),
            Err(ModelError::Format { .. })
        ));
        assert!(matches!(
            LegClassifier::from_json("{"),
            Err(ModelError::Parse(_))
        ));
    }

    #[test]
    fn the_compiled_classifier_decides_exactly_as_the_model() {
        let model = LegClassifier::default_model().unwrap();
        let compiled = CompiledClassifier::new(&model);
        // Feature vectors around the trees' own thresholds, where decisions flip.
        let mut thresholds: Vec<Vec<f64>> = vec![Vec::new(); N_FEATURES];
        for t in &model.trees {
            for n in &t.nodes {
                if let Node::Split {
                    feature, threshold, ..
                } = *n
                {
                    thresholds[feature].push(threshold);
                }
            }
        }
        let mut state = 12_345u64;
        let mut next = move |n: usize| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 33) as usize % n.max(1)
        };
        // The same model with one tree a level deeper than the others, which takes the
        // general layout instead of the fixed-size one of depth-3 models.
        let mut deep = model.clone();
        let split = |feature: usize, threshold: f64, below: usize, above: usize| Node::Split {
            feature,
            threshold,
            below,
            above,
        };
        deep.trees[0].nodes = vec![
            split(0, thresholds[0][0], 1, 2),
            Node::Leaf { vote: -1 },
            split(5, 0.1, 3, 4),
            Node::Leaf { vote: 1 },
            split(5, 0.2, 5, 6),
            Node::Leaf { vote: -1 },
            split(18, 0.5, 7, 8),
            Node::Leaf { vote: 1 },
            Node::Leaf { vote: -1 },
        ];
        deep.validate().unwrap();
        let compiled_deep = CompiledClassifier::new(&deep);
        assert!(compiled_deep.shallow.is_empty() && !compiled.shallow.is_empty());
        let (mut legs, mut tried) = (0, 0);
        for _ in 0..20_000 {
            let mut x = [0.0; N_FEATURES];
            for (f, v) in x.iter_mut().enumerate() {
                let t = &thresholds[f];
                if !t.is_empty() {
                    *v = t[next(t.len())] + [-1e-6, 1e-6][next(2)];
                }
            }
            for (model, compiled) in [(&model, &compiled), (&deep, &compiled_deep)] {
                let full = model.margin(&x);
                let fast = compiled.margin_if_leg(&x);
                assert_eq!(fast.is_some(), model.is_leg(&x), "{x:?}");
                if let Some(m) = fast {
                    assert_eq!(m, full, "a leg's margin is exact");
                    legs += 1;
                }
                tried += 1;
            }
        }
        assert!(legs > 100 && legs < tried, "{legs} legs of {tried}");
        // A model with a shallow tree among deep ones: padded leaves vote alike.
        let mut mixed = model.clone();
        mixed.trees[0].nodes = vec![Node::Leaf { vote: 1 }];
        let compiled = CompiledClassifier::new(&mixed);
        let x = [0.0; N_FEATURES];
        assert_eq!(compiled.margin_if_leg(&x).is_some(), mixed.is_leg(&x));
        // A path that ends nowhere (a model that was not validated) votes 0: the
        // fixed-size records, which hold only +1 and -1, are not used.
        let mut broken = model.clone();
        broken.trees[0].nodes[0] = split(0, thresholds[0][0], 1, 99);
        let compiled = CompiledClassifier::new(&broken);
        assert!(compiled.shallow.is_empty());
        for x in [[0.0; N_FEATURES], [1e9; N_FEATURES]] {
            let exact = broken.margin(&x);
            assert_eq!(compiled.margin_if_at_least(&x, -1.0), Some(exact));
        }
    }

    #[test]
    fn trees_deeper_than_training_makes_are_refused() {
        let mut model = LegClassifier::default_model().unwrap();
        let mut nodes = Vec::new();
        for k in 0..=MAX_DEPTH {
            nodes.push(Node::Split {
                feature: 0,
                threshold: k as f64,
                below: 2 * k + 1,
                above: 2 * k + 2,
            });
            nodes.push(Node::Leaf { vote: 1 });
        }
        nodes.push(Node::Leaf { vote: -1 });
        // Node 2k is a split whose `below` child is a leaf and `above` the next split.
        for (k, n) in nodes.iter_mut().enumerate() {
            if let Node::Split { below, above, .. } = n {
                *below = k + 1;
                *above = k + 2;
            }
        }
        model.trees[0].nodes = nodes;
        assert!(matches!(
            LegClassifier::from_json(&model.to_json()),
            Err(ModelError::Tree { tree: 0, why }) if why.contains("9 splits deep")
        ));
    }

    #[test]
    fn weights_whose_sum_overflows_are_refused() {
        // Each weight is finite, their sum is not: every margin was inf / inf = NaN.
        let mut model = LegClassifier::default_model().unwrap();
        model.trees.truncate(3);
        model.trees[0].alpha = 1e308;
        model.trees[2].alpha = 1e308;
        assert!(matches!(
            LegClassifier::from_json(&model.to_json()),
            Err(ModelError::Tree { tree: 2, why }) if why.contains("sum of the weights")
        ));
        model.trees[2].alpha = 1.0;
        let ok = LegClassifier::from_json(&model.to_json()).unwrap();
        assert!(ok.margin(&[0.0; N_FEATURES]).is_finite());
    }

    #[test]
    fn malformed_trees_vote_nothing_instead_of_looping() {
        let t = Tree {
            alpha: 1.0,
            nodes: vec![Node::Split {
                feature: 0,
                threshold: 0.0,
                below: 0,
                above: 0,
            }],
        };
        assert_eq!(t.vote(&[0.0; N_FEATURES]), 0.0);
    }

    /// What a model that loads must give: JSON that reads back equal, a margin in
    /// [-1, 1], and the compiled layout's decision.
    fn check_loaded(model: &LegClassifier) -> Result<(), proptest::test_runner::TestCaseError> {
        use proptest::prelude::*;
        prop_assert_eq!(&LegClassifier::from_json(&model.to_json()).unwrap(), model);
        let compiled = CompiledClassifier::new(model);
        for x in [[0.0; N_FEATURES], [0.5; N_FEATURES], [f64::NAN; N_FEATURES]] {
            let margin = model.margin(&x);
            prop_assert!(
                margin.is_finite() && margin.abs() <= 1.0 + 1e-9,
                "{}",
                margin
            );
            prop_assert_eq!(compiled.margin_if_leg(&x).is_some(), model.is_leg(&x));
        }
        Ok(())
    }

    /// Small models as JSON values, valid or not: trees of random nodes (splits with
    /// any feature, threshold and children; leaves with any vote) and random weights.
    fn model_like_json() -> impl proptest::strategy::Strategy<Value = String> {
        use proptest::prelude::*;
        let number = prop_oneof![
            -2.0..2.0f64,
            Just(0.0),
            Just(1e308),
            Just(-1e308),
            Just(f64::MIN_POSITIVE),
        ];
        let node = prop_oneof![
            (-2i64..3).prop_map(|v| format!("{{\"vote\": {v}}}")),
            (0usize..30, number.clone(), 0usize..12, 0usize..12).prop_map(|(f, t, b, a)| {
                format!(
                    "{{\"feature\": {f}, \"threshold\": {t:?}, \"below\": {b}, \"above\": {a}}}"
                )
            }),
        ];
        let tree =
            (number.clone(), proptest::collection::vec(node, 0..10)).prop_map(|(alpha, nodes)| {
                format!(
                    "{{\"alpha\": {alpha:?}, \"nodes\": [{}]}}",
                    nodes.join(", ")
                )
            });
        (number, proptest::collection::vec(tree, 0..6)).prop_map(|(margin, trees)| {
            let names: Vec<String> = FEATURE_NAMES.iter().map(|n| format!("{n:?}")).collect();
            format!(
                "{{\"format\": {MODEL_FORMAT:?}, \"features\": [{}], \"decision_margin\": {margin:?}, \"trees\": [{}]}}",
                names.join(", "),
                trees.join(", ")
            )
        })
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]

        /// Arbitrary text is refused or read, never a panic.
        #[test]
        fn arbitrary_text_is_refused_or_read_without_a_panic(text in "\\PC{0,200}") {
            if let Ok(model) = LegClassifier::from_json(&text) {
                check_loaded(&model)?;
            }
        }

        /// Models with random trees: refused with a reason, or they classify.
        #[test]
        fn random_models_are_refused_or_classify(text in model_like_json()) {
            if let Ok(model) = LegClassifier::from_json(&text) {
                check_loaded(&model)?;
            }
        }

        /// The default model with bytes changed, inserted or removed.
        #[test]
        fn a_damaged_default_model_is_refused_or_classifies(
            edits in proptest::collection::vec(
                (proptest::prelude::any::<proptest::sample::Index>(), 0x20u8..0x7f, 0u8..3),
                1..6,
            ),
        ) {
            let mut bytes = DEFAULT_MODEL_JSON.as_bytes().to_vec();
            tether_testkit::damage(&mut bytes, edits);
            let text = String::from_utf8_lossy(&bytes);
            if let Ok(model) = LegClassifier::from_json(&text) {
                check_loaded(&model)?;
            }
        }
    }
}
