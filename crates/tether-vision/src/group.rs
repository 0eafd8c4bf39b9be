//! Grouping of overlapping detections, as OpenCV's `cv::groupRectangles(rects,
//! groupThreshold, eps)` (module objdetect, `cascadedetect.cpp`) which
//! `detectMultiScale` calls with `eps = 0.2` and `groupThreshold = minNeighbors`.
//!
//! 1. With `min_neighbors == 0` the raw windows are returned untouched.
//! 2. Two rectangles are similar when every edge moves by at most
//!    `delta = eps (min(w1, w2) + min(h1, h2)) / 2`; the groups are the classes of the
//!    transitive closure of that relation (`cv::partition`).
//! 3. A group becomes the average of its rectangles, each coordinate
//!    `round_half_even(sum * (1 / n))` in `f32`.
//! 4. Groups of `n <= min_neighbors` rectangles are dropped, and so is a group lying
//!    inside another group (grown by `round(eps w2)`, `round(eps h2)`) that has more than
//!    `max(3, n)` members, or any other kept group when it has fewer than 3 members.

use serde::{Deserialize, Serialize};

/// An axis-aligned box in image pixels, as OpenCV's `cv::Rect`. Serialises as
/// `[x, y, width, height]`, the layout of `opencv_reference.py`'s JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(from = "[i32; 4]", into = "[i32; 4]")]
pub struct Rect {
    /// Left column, px.
    pub x: i32,
    /// Top row, px.
    pub y: i32,
    /// Width, px.
    pub width: i32,
    /// Height, px.
    pub height: i32,
}

impl From<[i32; 4]> for Rect {
    fn from([x, y, width, height]: [i32; 4]) -> Rect {
        Rect {
            x,
            y,
            width,
            height,
        }
    }
}

impl From<Rect> for [i32; 4] {
    fn from(r: Rect) -> [i32; 4] {
        [r.x, r.y, r.width, r.height]
    }
}

impl From<Rect> for tether_core::PixelBox {
    fn from(r: Rect) -> Self {
        tether_core::PixelBox {
            x: f64::from(r.x),
            y: f64::from(r.y),
            w: f64::from(r.width),
            h: f64::from(r.height),
        }
    }
}

impl Rect {
    /// Intersection (`cv::Rect::operator&`): the empty rectangle `(0, 0, 0, 0)` when the two
    /// do not overlap.
    pub fn intersect(&self, other: &Rect) -> Rect {
        let x0 = self.x.max(other.x);
        let y0 = self.y.max(other.y);
        let x1 = (self.x + self.width).min(other.x + other.width);
        let y1 = (self.y + self.height).min(other.y + other.height);
        if x1 <= x0 || y1 <= y0 {
            Rect::from([0, 0, 0, 0])
        } else {
            Rect::from([x0, y0, x1 - x0, y1 - y0])
        }
    }

    /// Area, px^2.
    pub fn area(&self) -> i64 {
        i64::from(self.width) * i64::from(self.height)
    }
}

/// OpenCV's `SimilarRects`: every edge within `delta` of the other's.
fn similar(a: &Rect, b: &Rect, eps: f64) -> bool {
    let delta = eps * f64::from(a.width.min(b.width) + a.height.min(b.height)) * 0.5;
    f64::from((a.x - b.x).abs()) <= delta
        && f64::from((a.y - b.y).abs()) <= delta
        && f64::from((a.x + a.width - b.x - b.width).abs()) <= delta
        && f64::from((a.y + a.height - b.y - b.height).abs()) <= delta
}

/// Union-find with path halving.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Class labels `0..n_classes` of the transitive closure of [`similar`], numbered in order
/// of first appearance.
fn partition(rects: &[Rect], eps: f64) -> (Vec<usize>, usize) {
    let n = rects.len();
    let mut parent: Vec<usize> = (0..n).collect();
    // Sorting by x lets the pair scan stop early: similar rectangles have left edges
    // within delta <= eps * (w_max + h_max) / 2 of each other.
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| rects[i].x);
    let max_extent = rects
        .iter()
        .map(|r| f64::from(r.width.max(0)) + f64::from(r.height.max(0)))
        .fold(0.0, f64::max);
    let reach = eps * max_extent * 0.5;
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if f64::from(rects[j].x - rects[i].x) > reach {
                break;
            }
            if similar(&rects[i], &rects[j], eps) {
                let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
                if ri != rj {
                    parent[ri.max(rj)] = ri.min(rj);
                }
            }
        }
    }
    let mut label_of_root = vec![usize::MAX; n];
    let mut labels = vec![0; n];
    let mut n_classes = 0;
    for (i, label) in labels.iter_mut().enumerate() {
        let r = find(&mut parent, i);
        if label_of_root[r] == usize::MAX {
            label_of_root[r] = n_classes;
            n_classes += 1;
        }
        *label = label_of_root[r];
    }
    (labels, n_classes)
}

/// Groups detections as `cv::groupRectangles(rects, min_neighbors, eps)`; see the module
/// documentation. The order of the result follows the order of first appearance of each
/// group in `rects`.
pub fn group_rectangles(rects: &[Rect], min_neighbors: u32, eps: f64) -> Vec<Rect> {
    if min_neighbors == 0 || rects.is_empty() {
        return rects.to_vec();
    }
    let threshold = i64::from(min_neighbors);
    let (labels, n_classes) = partition(rects, eps);
    let mut sums = vec![[0i64; 4]; n_classes];
    let mut counts = vec![0i64; n_classes];
    for (r, &c) in rects.iter().zip(&labels) {
        let s = &mut sums[c];
        s[0] += i64::from(r.x);
        s[1] += i64::from(r.y);
        s[2] += i64::from(r.width);
        s[3] += i64::from(r.height);
        counts[c] += 1;
    }
    let averaged: Vec<Rect> = sums
        .iter()
        .zip(&counts)
        .map(|(s, &n)| {
            // OpenCV: float s = 1.f / n; saturate_cast<int>(sum * s) in float.
            let inv = 1.0f32 / n as f32;
            let avg = |v: i64| ((v as f32) * inv).round_ties_even() as i32;
            Rect::from([avg(s[0]), avg(s[1]), avg(s[2]), avg(s[3])])
        })
        .collect();
    let mut out = Vec::new();
    for i in 0..n_classes {
        let n1 = counts[i];
        if n1 <= threshold {
            continue;
        }
        let r1 = averaged[i];
        let swallowed = (0..n_classes).any(|j| {
            let n2 = counts[j];
            if j == i || n2 <= threshold {
                return false;
            }
            let r2 = averaged[j];
            let dx = (f64::from(r2.width) * eps).round_ties_even() as i32;
            let dy = (f64::from(r2.height) * eps).round_ties_even() as i32;
            r1.x >= r2.x - dx
                && r1.y >= r2.y - dy
                && r1.x + r1.width <= r2.x + r2.width + dx
                && r1.y + r1.height <= r2.y + r2.height + dy
                && (n2 > n1.max(3) || n1 < 3)
        });
        if !swallowed {
            out.push(r1);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn r(x: i32, y: i32, w: i32, h: i32) -> Rect {
        Rect::from([x, y, w, h])
    }

    #[test]
    fn zero_neighbours_returns_raw_windows() {
        let raw = vec![r(0, 0, 10, 10), r(1, 1, 10, 10), r(1, 1, 10, 10)];
        assert_eq!(group_rectangles(&raw, 0, 0.2), raw);
    }

    #[test]
    fn averages_a_cluster_and_drops_small_ones() {
        let raw = vec![
            r(10, 10, 20, 20),
            r(11, 10, 20, 20),
            r(12, 11, 21, 21),
            r(11, 12, 20, 20),
            r(200, 200, 20, 20),
        ];
        // Cluster of 4 -> (44/4, 43/4 = 10.75 -> 11, 81/4 = 20.25 -> 20, 20.25 -> 20).
        assert_eq!(group_rectangles(&raw, 3, 0.2), vec![r(11, 11, 20, 20)]);
        assert_eq!(group_rectangles(&raw, 4, 0.2), vec![]);
    }

    #[test]
    fn rounds_averages_half_to_even() {
        // x: (10 + 11) / 2 = 10.5 -> 10; y: (11 + 12) / 2 = 11.5 -> 12.
        let raw = vec![r(10, 11, 20, 20), r(11, 12, 20, 20)];
        assert_eq!(group_rectangles(&raw, 1, 0.2), vec![r(10, 12, 20, 20)]);
    }

    #[test]
    fn small_group_inside_a_big_one_is_dropped() {
        let mut raw: Vec<Rect> = (0..6).map(|k| r(100 + k % 2, 100, 100, 100)).collect();
        raw.extend([r(130, 130, 30, 30), r(131, 130, 30, 30)]);
        // The inner pair (n = 2 < 3) lies inside the big group and is swallowed.
        assert_eq!(group_rectangles(&raw, 1, 0.2), vec![r(100, 100, 100, 100)]);
    }

    #[test]
    fn intersection() {
        assert_eq!(r(0, 0, 10, 10).intersect(&r(5, 5, 10, 10)), r(5, 5, 5, 5));
        assert_eq!(r(0, 0, 10, 10).intersect(&r(10, 0, 5, 5)).area(), 0);
    }

    /// Labels by brute force: repeated relaxation over all pairs.
    fn slow_partition(rects: &[Rect], eps: f64) -> Vec<usize> {
        let n = rects.len();
        let mut label: Vec<usize> = (0..n).collect();
        loop {
            let mut changed = false;
            for i in 0..n {
                for j in 0..n {
                    if similar(&rects[i], &rects[j], eps) && label[j] < label[i] {
                        label[i] = label[j];
                        changed = true;
                    }
                }
            }
            if !changed {
                return label;
            }
        }
    }

    proptest! {
        /// The sorted, early-stopping union-find gives the same classes as brute force.
        #[test]
        fn partition_matches_brute_force(raw in proptest::collection::vec((0i32..60, 0i32..60, 5i32..40, 5i32..40), 0..40)) {
            let rects: Vec<Rect> = raw.iter().map(|&(x, y, w, h)| r(x, y, w, h)).collect();
            let (labels, n) = partition(&rects, 0.2);
            let slow = slow_partition(&rects, 0.2);
            for i in 0..rects.len() {
                prop_assert!(labels[i] < n);
                for j in 0..rects.len() {
                    prop_assert_eq!(labels[i] == labels[j], slow[i] == slow[j]);
                }
            }
        }
    }
}
