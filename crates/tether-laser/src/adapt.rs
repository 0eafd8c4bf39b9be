//! Training the leg classifier on candidates labelled one by one (design 4.7): the
//! labels of [`crate::self_label`] (a leg, a non-leg, or left out), or the truth of a
//! simulated recording ([`LabelledCandidates::from_truth`]), with the AdaBoost of
//! [`crate::training`] and its decision margin chosen by cross-validation.
//!
//! Counts are per candidate: at a decision margin `m`, a leg whose margin `F(x) >= m`
//! is a true positive, a leg below it a false negative, a non-leg at or above it a
//! false positive; candidates left out are not counted.

use crate::classifier::{LegClassifier, Provenance};
use crate::self_label::LabelledCandidates;
use crate::training::{
    AdaBoostConfig, CrossValidation, MatchCounts, TrainError, TrainingSet, cross_validate_with,
    train_adaboost,
};

/// Splits the scans of one recording (in time order) into the part trained on and the
/// last `held_back_share` of the scans, held back for measuring (a later stretch of the
/// walk: other moments, other steps, than any trained on).
pub fn split_held_back(
    mut scans: Vec<LabelledCandidates>,
    held_back_share: f64,
) -> (Vec<LabelledCandidates>, Vec<LabelledCandidates>) {
    let share = if held_back_share.is_finite() {
        held_back_share.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let keep = scans.len() - (share * scans.len() as f64).round() as usize;
    let held = scans.split_off(keep.min(scans.len()));
    (scans, held)
}

/// Cuts scans (in time order) into `k` blocks of consecutive scans, one per fold, so
/// that a held-out fold holds moments that no training scan saw. `k` is at least 1.
pub fn time_folds(scans: Vec<LabelledCandidates>, k: usize) -> Vec<Vec<LabelledCandidates>> {
    let k = k.max(1);
    let n = scans.len();
    let mut folds: Vec<Vec<LabelledCandidates>> = (0..k).map(|_| Vec::new()).collect();
    for (i, s) in scans.into_iter().enumerate() {
        folds[(i * k / n.max(1)).min(k - 1)].push(s);
    }
    folds
}

/// The labelled candidates of `scans` as a training set (those left out are not in it).
pub fn training_set<'a>(scans: impl IntoIterator<Item = &'a LabelledCandidates>) -> TrainingSet {
    let mut set = TrainingSet::default();
    for s in scans {
        for (f, label) in s.sample.features.iter().zip(&s.labels) {
            if let Some(leg) = label {
                set.samples.push(*f);
                set.labels.push(*leg);
            }
        }
    }
    set
}

/// The per-candidate counts of a scan whose candidates have `margins`, at
/// `decision_margin` (see the module's doc).
pub fn count_candidates(
    scan: &LabelledCandidates,
    margins: &[f64],
    decision_margin: f64,
) -> MatchCounts {
    let mut c = MatchCounts::default();
    for (label, &m) in scan.labels.iter().zip(margins) {
        match (label, m >= decision_margin) {
            (Some(true), true) => c.true_positives += 1,
            (Some(true), false) => c.false_negatives += 1,
            (Some(false), true) => c.false_positives += 1,
            _ => {}
        }
    }
    c
}

/// The per-candidate counts of `model` at its own decision margin on `scans`.
pub fn measure_on_candidates(model: &LegClassifier, scans: &[LabelledCandidates]) -> MatchCounts {
    let mut c = MatchCounts::default();
    for s in scans {
        let margins: Vec<f64> = s.sample.features.iter().map(|f| model.margin(f)).collect();
        c.add(count_candidates(s, &margins, model.decision_margin));
    }
    c
}

/// K-fold cross-validation over `folds`: for each, trains on the others with `config`
/// and counts the held-out candidates at every margin of [`margin_grid`](crate::training::margin_grid); picks the
/// margin with the highest F1 of all folds' counts together (the first of equals).
pub fn cross_validate_candidates(
    folds: &[Vec<LabelledCandidates>],
    config: &AdaBoostConfig,
) -> Result<CrossValidation, TrainError> {
    cross_validate_with(
        folds,
        config,
        |scans| training_set(scans.iter().copied()),
        |scan| &scan.sample.features,
        count_candidates,
    )
}

/// Trains on every candidate of `folds` with the decision margin that
/// [`cross_validate_candidates`] over the same folds chooses; `command` and `sources`
/// go into the model's provenance. Returns the model, its training set and the
/// cross-validation.
pub fn train_on_candidates(
    folds: &[Vec<LabelledCandidates>],
    config: &AdaBoostConfig,
    command: String,
    sources: Vec<String>,
) -> Result<(LegClassifier, TrainingSet, CrossValidation), TrainError> {
    let cv = cross_validate_candidates(folds, config)?;
    let config = AdaBoostConfig {
        decision_margin: cv.margin(),
        ..*config
    };
    let set = training_set(folds.iter().flatten());
    let c = cv.best_counts();
    let margin_choice = format!(
        "{}-fold cross-validation on blocks of consecutive scans, per candidate: F(x) >= {} \
         gives the highest F1 of the held-out labels, precision {:.3}, recall {:.3}",
        folds.len(),
        cv.margin(),
        c.precision(),
        c.recall()
    );
    let model = train_adaboost(
        &set.samples,
        &set.labels,
        &config,
        Provenance {
            command,
            sources,
            margin_choice,
            ..Provenance::default()
        },
    )?;
    Ok((model, set, cv))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(labels: Vec<Option<bool>>) -> LabelledCandidates {
        LabelledCandidates {
            labels,
            ..LabelledCandidates::default()
        }
    }

    #[test]
    fn counts_skip_what_is_left_out() {
        let s = scan(vec![Some(true), Some(true), Some(false), Some(false), None]);
        let c = count_candidates(&s, &[0.5, -0.5, 0.5, -0.5, 0.9], 0.0);
        assert_eq!(
            (c.true_positives, c.false_negatives, c.false_positives),
            (1, 1, 1)
        );
    }

    #[test]
    fn held_back_is_the_last_share_and_folds_are_blocks() {
        let scans: Vec<LabelledCandidates> = (0..8).map(|k| scan(vec![None; k])).collect();
        let (train, held) = split_held_back(scans, 0.25);
        assert_eq!(train.len(), 6);
        assert_eq!(
            held.iter().map(|s| s.labels.len()).collect::<Vec<_>>(),
            [6, 7]
        );
        let folds = time_folds(train, 3);
        let sizes: Vec<Vec<usize>> = folds
            .iter()
            .map(|f| f.iter().map(|s| s.labels.len()).collect())
            .collect();
        assert_eq!(sizes, [vec![0, 1], vec![2, 3], vec![4, 5]]);
    }
}
