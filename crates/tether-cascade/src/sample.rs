//! Training samples: window-sized grey patches kept as their integral images (sum and
//! tilted) with the window's variance normalisation factor, as the detector computes them
//! for a window of the scaled image.

use crate::features::{CompiledFeature, norm_factor};

/// A set of `width x height` samples, each stored as its `(width + 1) x (height + 1)`
/// integral images.
#[derive(Debug, Clone)]
pub struct SampleSet {
    width: usize,
    height: usize,
    cells: usize,
    sum: Vec<i32>,
    tilted: Vec<i32>,
    norm: Vec<f32>,
    positive: Vec<bool>,
}

impl SampleSet {
    /// An empty set for `width x height` windows.
    pub fn new(width: u32, height: u32) -> SampleSet {
        let (width, height) = (width as usize, height as usize);
        SampleSet {
            width,
            height,
            cells: (width + 1) * (height + 1),
            sum: Vec::new(),
            tilted: Vec::new(),
            norm: Vec::new(),
            positive: Vec::new(),
        }
    }

    /// Entries per integral row (`width + 1`): the stride to compile features for.
    pub fn stride(&self) -> usize {
        self.width + 1
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.norm.len()
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.norm.is_empty()
    }

    /// Whether sample `i` is a positive.
    pub fn is_positive(&self, i: usize) -> bool {
        self.positive[i]
    }

    /// Labels, `true` for positives.
    pub fn labels(&self) -> &[bool] {
        &self.positive
    }

    /// Adds a row-major `width x height` patch. Returns `false` (and adds nothing) when
    /// the patch is so flat that the detector would reject it before any stage (standard
    /// deviation 10 or less): such a window can be neither found nor mistaken.
    ///
    /// # Panics
    /// If the patch is not `width x height` (a programming error).
    pub fn push(&mut self, patch: &[u8], positive: bool) -> bool {
        assert_eq!(patch.len(), self.width * self.height);
        let start = self.sum.len();
        self.sum.resize(start + self.cells, 0);
        self.tilted.resize(start + self.cells, 0);
        let mut sq = vec![0i32; self.cells];
        tether_vision::integral::integral_sum_sqsum(
            patch,
            self.width,
            self.height,
            self.width + 1,
            &mut self.sum[start..],
            &mut sq,
        );
        let norm = norm_factor(
            &self.sum[start..],
            &sq,
            0,
            self.width + 1,
            self.width,
            self.height,
        );
        let Some(norm) = norm else {
            self.sum.truncate(start);
            self.tilted.truncate(start);
            return false;
        };
        tether_vision::integral::integral_tilted(
            patch,
            self.width,
            self.height,
            self.width + 1,
            &mut self.tilted[start..],
        );
        self.norm.push(norm);
        self.positive.push(positive);
        true
    }

    /// Appends sample `i` of another set of the same window size.
    ///
    /// # Panics
    /// If the window sizes differ (a programming error).
    pub fn push_integral(&mut self, from: &SampleSet, i: usize) {
        assert_eq!((self.width, self.height), (from.width, from.height));
        let r = i * from.cells..(i + 1) * from.cells;
        self.sum.extend_from_slice(&from.sum[r.clone()]);
        self.tilted.extend_from_slice(&from.tilted[r]);
        self.norm.push(from.norm[i]);
        self.positive.push(from.positive[i]);
    }

    /// The normalised value of a feature (compiled for [`SampleSet::stride`]) on sample
    /// `i`.
    #[inline]
    pub fn value(&self, f: &CompiledFeature, i: usize) -> f32 {
        let base = i * self.cells;
        f.value(&self.sum, &self.tilted, base, self.norm[i])
    }

    /// The sample's integral images and normalisation: `(sum, tilted, base, norm)`.
    pub fn window(&self, i: usize) -> (&[i32], &[i32], usize, f32) {
        (&self.sum, &self.tilted, i * self.cells, self.norm[i])
    }
}

/// A detection-window-sized patch cut from an image, optionally mirrored.
pub fn mirrored(patch: &[u8], width: usize) -> Vec<u8> {
    patch
        .chunks_exact(width)
        .flat_map(|row| row.iter().rev().copied())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::{FeatureMode, enumerate};

    #[test]
    fn flat_patches_are_refused_and_values_match_plain_sums() {
        let mut set = SampleSet::new(6, 8);
        assert!(!set.push(&[100u8; 48], true));
        let patch: Vec<u8> = (0..48).map(|i| ((i * 53) % 251) as u8).collect();
        assert!(set.push(&patch, false));
        assert_eq!(set.len(), 1);
        let px = |x: i32, y: i32| f64::from(patch[(y * 6 + x) as usize]);
        // Reference: plain loops over the pixels of each rectangle (tilted features are
        // checked against the detector in mining's tests).
        let rect_sum = |r: &crate::features::FeatureRect, _tilted: bool| -> f64 {
            let mut s = 0.0;
            for y in 0..8 {
                for x in 0..6 {
                    if x >= r.x && x < r.x + r.w && y >= r.y && y < r.y + r.h {
                        s += px(x, y);
                    }
                }
            }
            s
        };
        let inner: Vec<f64> = (1..7)
            .flat_map(|y| (1..5).map(move |x| (x, y)))
            .map(|(x, y)| px(x, y))
            .collect();
        let (s, q) = (
            inner.iter().sum::<f64>(),
            inner.iter().map(|v| v * v).sum::<f64>(),
        );
        let norm = 1.0 / (inner.len() as f64 * q - s * s).sqrt();
        for f in enumerate(6, 8, FeatureMode::Core) {
            let raw: f64 = f
                .rects
                .iter()
                .map(|r| f64::from(r.weight) * rect_sum(r, f.tilted))
                .sum();
            let got = f64::from(set.value(&f.compile(set.stride()), 0));
            assert!(
                (got - raw * norm).abs() < 1e-4 * (1.0 + (raw * norm).abs()),
                "{f:?}: {got} vs {}",
                raw * norm
            );
        }
    }

    #[test]
    fn mirror_reverses_rows() {
        assert_eq!(mirrored(&[1, 2, 3, 4, 5, 6], 3), vec![3, 2, 1, 6, 5, 4]);
    }
}
