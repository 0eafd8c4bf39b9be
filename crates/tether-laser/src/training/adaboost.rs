//! Discrete AdaBoost over depth-limited trees (design 4.6): the training of the leg
//! classifier from feature vectors and labels.

use thiserror::Error;

use crate::classifier::{LegClassifier, MAX_DEPTH, MODEL_FORMAT, Node, Provenance, Tree};
use crate::features::{FEATURE_NAMES, FeatureVector, N_FEATURES};

use super::TrainingViews;

/// AdaBoost training parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaBoostConfig {
    /// Number of boosting rounds (trees); default 300.
    pub rounds: usize,
    /// Depth of each tree; 1 gives Arras et al.'s stumps. Default 3.
    pub max_depth: usize,
    /// The decision margin written into the model; default 0.
    pub decision_margin: f64,
    /// The views of the training scans that [`super::folds_from_scans`] adds (recorded in the
    /// model's provenance; boosting itself does not read it).
    pub views: TrainingViews,
}

impl Default for AdaBoostConfig {
    fn default() -> Self {
        AdaBoostConfig {
            rounds: 300,
            max_depth: 3,
            decision_margin: 0.0,
            views: TrainingViews::default(),
        }
    }
}

/// Why training could not run.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum TrainError {
    /// One class has no samples.
    #[error("training needs positive and negative samples, got {positives} and {negatives}")]
    OneClass {
        /// Positive samples.
        positives: usize,
        /// Negative samples.
        negatives: usize,
    },
    /// A feature value is NaN or infinite.
    #[error("sample {sample} has a non-finite value of feature {feature}")]
    NotFinite {
        /// Index of the sample.
        sample: usize,
        /// Name of the feature.
        feature: &'static str,
    },
    /// Samples and labels differ in number.
    #[error("{samples} samples but {labels} labels")]
    Mismatch {
        /// Samples.
        samples: usize,
        /// Labels.
        labels: usize,
    },
    /// The parameters make no sense.
    #[error("AdaBoost needs rounds >= 1 and 1 <= max_depth <= 8, got {rounds} and {max_depth}")]
    Config {
        /// Rounds asked for.
        rounds: usize,
        /// Depth asked for.
        max_depth: usize,
    },
}

/// Trains a classifier by discrete AdaBoost on trees. `labels[i]` says whether
/// `samples[i]` is a leg. Deterministic: no randomness, fixed tie-breaking.
pub fn train_adaboost(
    samples: &[FeatureVector],
    labels: &[bool],
    config: &AdaBoostConfig,
    provenance: Provenance,
) -> Result<LegClassifier, TrainError> {
    if samples.len() != labels.len() {
        return Err(TrainError::Mismatch {
            samples: samples.len(),
            labels: labels.len(),
        });
    }
    if config.rounds == 0 || !(1..=MAX_DEPTH).contains(&config.max_depth) {
        return Err(TrainError::Config {
            rounds: config.rounds,
            max_depth: config.max_depth,
        });
    }
    let positives = labels.iter().filter(|&&l| l).count();
    let negatives = labels.len() - positives;
    if positives == 0 || negatives == 0 {
        return Err(TrainError::OneClass {
            positives,
            negatives,
        });
    }
    for (sample, x) in samples.iter().enumerate() {
        if let Some(f) = x.iter().position(|v| !v.is_finite()) {
            return Err(TrainError::NotFinite {
                sample,
                feature: FEATURE_NAMES[f],
            });
        }
    }
    let grower = TreeGrower::new(samples, labels, config.max_depth);
    let mut w = vec![1.0 / samples.len() as f64; samples.len()];
    let mut trees = Vec::with_capacity(config.rounds);
    let mut votes = vec![0i8; samples.len()];
    for _ in 0..config.rounds {
        let nodes = grower.grow(&w);
        let tree = Tree { alpha: 1.0, nodes };
        let mut error = 0.0;
        for (i, v) in votes.iter_mut().enumerate() {
            *v = if tree.vote(&samples[i]) > 0.0 { 1 } else { -1 };
            if (*v > 0) != labels[i] {
                error += w[i];
            }
        }
        if error >= 0.5 {
            break;
        }
        let error = error.max(1e-12);
        let alpha = 0.5 * ((1.0 - error) / error).ln();
        let mut total = 0.0;
        for (i, wi) in w.iter_mut().enumerate() {
            let agree = (votes[i] > 0) == labels[i];
            *wi *= if agree { (-alpha).exp() } else { alpha.exp() };
            total += *wi;
        }
        for wi in &mut w {
            *wi /= total;
        }
        trees.push(Tree { alpha, ..tree });
    }
    Ok(LegClassifier {
        format: MODEL_FORMAT.to_string(),
        features: FEATURE_NAMES.iter().map(|s| s.to_string()).collect(),
        decision_margin: config.decision_margin,
        trees,
        provenance: Provenance {
            positives,
            negatives,
            ..provenance
        },
    })
}

/// Grows weighted trees level by level over samples sorted once per feature, so that
/// a level costs one pass over every feature's order.
struct TreeGrower<'a> {
    samples: &'a [FeatureVector],
    labels: &'a [bool],
    /// Per feature: sample indices sorted by the feature's value, and those values.
    order: Vec<Vec<u32>>,
    sorted_values: Vec<Vec<f64>>,
    max_depth: usize,
}

/// Best split found so far for one open node.
#[derive(Clone, Copy)]
struct SplitCandidate {
    score: f64,
    feature: usize,
    threshold: f64,
}

/// Running sums of one open node during a sweep over one feature.
#[derive(Clone, Copy, Default)]
struct Sweep {
    pos: f64,
    neg: f64,
    last: Option<f64>,
}

impl<'a> TreeGrower<'a> {
    fn new(samples: &'a [FeatureVector], labels: &'a [bool], max_depth: usize) -> Self {
        let order: Vec<Vec<u32>> = (0..N_FEATURES)
            .map(|f| {
                let mut idx: Vec<u32> = (0..samples.len() as u32).collect();
                idx.sort_by(|&a, &b| {
                    samples[a as usize][f]
                        .total_cmp(&samples[b as usize][f])
                        .then(a.cmp(&b))
                });
                idx
            })
            .collect();
        let sorted_values = order
            .iter()
            .enumerate()
            .map(|(f, idx)| idx.iter().map(|&i| samples[i as usize][f]).collect())
            .collect();
        TreeGrower {
            samples,
            labels,
            order,
            sorted_values,
            max_depth,
        }
    }

    fn grow(&self, w: &[f64]) -> Vec<Node> {
        const NONE: usize = usize::MAX;
        // Node under construction of each sample; all start at the root.
        let mut at = vec![0usize; self.samples.len()];
        let mut nodes: Vec<Node> = vec![Node::Leaf { vote: -1 }];
        let mut open: Vec<usize> = vec![0];
        for depth in 0..=self.max_depth {
            // Class weights per open node.
            let mut slot = vec![NONE; nodes.len()];
            for (s, &k) in open.iter().enumerate() {
                slot[k] = s;
            }
            let mut totals = vec![(0.0f64, 0.0f64); open.len()];
            for (i, &k) in at.iter().enumerate() {
                if k != NONE && slot[k] != NONE {
                    let t = &mut totals[slot[k]];
                    if self.labels[i] {
                        t.0 += w[i];
                    } else {
                        t.1 += w[i];
                    }
                }
            }
            for (s, &k) in open.iter().enumerate() {
                let (p, n) = totals[s];
                nodes[k] = Node::Leaf {
                    vote: if p > n { 1 } else { -1 },
                };
            }
            if depth == self.max_depth {
                break;
            }
            let mut best: Vec<Option<SplitCandidate>> = vec![None; open.len()];
            let mut sweep = vec![Sweep::default(); open.len()];
            for (f, (idx, values)) in self.order.iter().zip(&self.sorted_values).enumerate() {
                sweep.iter_mut().for_each(|s| *s = Sweep::default());
                for (&i, &v) in idx.iter().zip(values) {
                    let i = i as usize;
                    let k = at[i];
                    if k == NONE || slot[k] == NONE {
                        continue;
                    }
                    let s = slot[k];
                    let sw = &mut sweep[s];
                    if let Some(last) = sw.last
                        && v > last
                    {
                        // Split between `last` and `v`: below = sums so far.
                        let (tp, tn) = totals[s];
                        let (bp, bn) = (sw.pos, sw.neg);
                        let (ap, an) = (tp - bp, tn - bn);
                        let purity = |p: f64, n: f64| {
                            let t = p + n;
                            if t > 0.0 { (p * p + n * n) / t } else { 0.0 }
                        };
                        let score = purity(bp, bn) + purity(ap, an);
                        if best[s].is_none_or(|b| score > b.score) {
                            best[s] = Some(SplitCandidate {
                                score,
                                feature: f,
                                threshold: 0.5 * (last + v),
                            });
                        }
                    }
                    if self.labels[i] {
                        sw.pos += w[i];
                    } else {
                        sw.neg += w[i];
                    }
                    sw.last = Some(v);
                }
            }
            let mut next_open = Vec::new();
            let mut children = vec![(NONE, NONE); open.len()];
            for (s, &k) in open.iter().enumerate() {
                let (p, n) = totals[s];
                // A pure node gains nothing from a split.
                let Some(split) = best[s].filter(|_| p > 0.0 && n > 0.0) else {
                    continue;
                };
                let below = nodes.len();
                nodes.push(Node::Leaf { vote: -1 });
                let above = nodes.len();
                nodes.push(Node::Leaf { vote: -1 });
                nodes[k] = Node::Split {
                    feature: split.feature,
                    threshold: split.threshold,
                    below,
                    above,
                };
                children[s] = (below, above);
                next_open.push(below);
                next_open.push(above);
            }
            for (i, k) in at.iter_mut().enumerate() {
                if *k == NONE || slot[*k] == NONE {
                    *k = NONE;
                    continue;
                }
                let (below, above) = children[slot[*k]];
                if below == NONE {
                    *k = NONE;
                    continue;
                }
                if let Node::Split {
                    feature, threshold, ..
                } = nodes[*k]
                {
                    *k = if self.samples[i][feature] <= threshold {
                        below
                    } else {
                        above
                    };
                }
            }
            open = next_open;
            if open.is_empty() {
                break;
            }
        }
        nodes
    }
}
