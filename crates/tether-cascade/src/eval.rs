//! Precision, recall and F1 of a detector against labelled boxes: in each image,
//! detections and labels are matched greedily, the pair with the highest intersection
//! over union first, a pair counting only at IoU >= [`MATCH_IOU`]; each detection and
//! each label is matched at most once.

use rayon::prelude::*;
use tether_core::GrayImage;
use tether_vision::{DetectError, DetectParams, Detector, Rect};

use crate::info::iou;

/// A detection matches a label at this intersection over union or more.
pub const MATCH_IOU: f64 = 0.4;

/// Matched and unmatched counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Detections matched to a label.
    pub true_positives: usize,
    /// Detections matched to no label.
    pub false_positives: usize,
    /// Labels matched by no detection.
    pub false_negatives: usize,
}

impl Counts {
    /// `tp / (tp + fp)` (0 without detections).
    pub fn precision(&self) -> f64 {
        ratio(
            self.true_positives,
            self.true_positives + self.false_positives,
        )
    }

    /// `tp / (tp + fn)` (0 without labels).
    pub fn recall(&self) -> f64 {
        ratio(
            self.true_positives,
            self.true_positives + self.false_negatives,
        )
    }

    /// Harmonic mean of precision and recall.
    pub fn f1(&self) -> f64 {
        let (p, r) = (self.precision(), self.recall());
        if p + r > 0.0 {
            2.0 * p * r / (p + r)
        } else {
            0.0
        }
    }
}

impl std::ops::AddAssign for Counts {
    fn add_assign(&mut self, o: Counts) {
        self.true_positives += o.true_positives;
        self.false_positives += o.false_positives;
        self.false_negatives += o.false_negatives;
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 { 0.0 } else { a as f64 / b as f64 }
}

/// Greedy matching of one image's detections to its labels.
pub fn match_boxes(detections: &[Rect], labels: &[Rect], min_iou: f64) -> Counts {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (d, det) in detections.iter().enumerate() {
        for (l, lab) in labels.iter().enumerate() {
            let o = iou(det, lab);
            if o >= min_iou {
                pairs.push((o, d, l));
            }
        }
    }
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut det_used = vec![false; detections.len()];
    let mut lab_used = vec![false; labels.len()];
    let mut tp = 0;
    for (_, d, l) in pairs {
        if !det_used[d] && !lab_used[l] {
            det_used[d] = true;
            lab_used[l] = true;
            tp += 1;
        }
    }
    Counts {
        true_positives: tp,
        false_positives: detections.len() - tp,
        false_negatives: labels.len() - tp,
    }
}

/// Runs the detector on every image (in parallel) and matches its boxes with the labels.
pub fn evaluate(
    detector: &Detector,
    images: &[GrayImage],
    labels: &[Vec<Rect>],
    params: &DetectParams,
) -> Result<Counts, DetectError> {
    let per_image: Vec<Counts> = images
        .par_iter()
        .zip(labels)
        .map(|(img, lab)| {
            detector
                .detect(img, params)
                .map(|d| match_boxes(&d, lab, MATCH_IOU))
        })
        .collect::<Result<_, _>>()?;
    let mut total = Counts::default();
    for c in per_image {
        total += c;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x: i32, y: i32, w: i32, h: i32) -> Rect {
        Rect {
            x,
            y,
            width: w,
            height: h,
        }
    }

    #[test]
    fn greedy_matching_takes_the_best_pair_first() {
        let labels = [r(0, 0, 10, 20), r(100, 0, 10, 20)];
        // Two detections on the first label: one matches, one is a false positive.
        let dets = [r(1, 1, 10, 20), r(0, 0, 10, 20), r(300, 0, 10, 20)];
        let c = match_boxes(&dets, &labels, MATCH_IOU);
        assert_eq!(
            c,
            Counts {
                true_positives: 1,
                false_positives: 2,
                false_negatives: 1
            }
        );
        assert!((c.precision() - 1.0 / 3.0).abs() < 1e-12);
        assert!((c.recall() - 0.5).abs() < 1e-12);
        assert!((c.f1() - 0.4).abs() < 1e-12);
        // Below the IoU bar: no match.
        let c = match_boxes(&[r(6, 0, 10, 20)], &[r(0, 0, 10, 20)], MATCH_IOU);
        assert_eq!(c.true_positives, 0);
        assert_eq!(Counts::default().f1(), 0.0);
    }
}
