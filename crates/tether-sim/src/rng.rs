//! Seeded random streams.
//!
//! Every random draw of the simulator comes from a [`SimRng`] made from the run's seed and
//! the name of the stream (`"laser"`, `"camera"`, `"person/3"`...). Streams are
//! independent: turning the camera off, or adding a person, does not change the laser
//! noise of the others. The same seed gives the same draws on every machine (PCG-64 MCG,
//! no platform-dependent state).

use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use rand_pcg::Pcg64Mcg;

/// One named random stream.
#[derive(Debug, Clone)]
pub struct SimRng(Pcg64Mcg);

/// SplitMix64 finaliser: spreads the bits of a 64-bit value.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl SimRng {
    /// The stream `name` of the run seeded with `seed`.
    pub fn stream(seed: u64, name: &str) -> Self {
        // FNV-1a of the name, then mixed with the seed: stable across platforms and
        // Rust versions (unlike `std::hash`).
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in name.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        let hi = mix64(seed ^ mix64(h));
        let lo = mix64(hi ^ 0x9e37_79b9_7f4a_7c15 ^ h);
        let mut bytes = [0u8; 16];
        bytes[..8].copy_from_slice(&hi.to_le_bytes());
        bytes[8..].copy_from_slice(&lo.to_le_bytes());
        SimRng(Pcg64Mcg::from_seed(bytes))
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        self.0.random::<f64>()
    }

    /// Uniform in `[lo, hi)` (returns `lo` when the interval is empty).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        if hi > lo {
            lo + (hi - lo) * self.unit()
        } else {
            lo
        }
    }

    /// A draw of `N(mean, sd^2)`.
    pub fn normal(&mut self, mean: f64, sd: f64) -> f64 {
        let z: f64 = self.0.sample(StandardNormal);
        mean + sd * z
    }

    /// True with probability `p` (clamped to [0, 1]).
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p.clamp(0.0, 1.0)
    }

    /// A Poisson count with mean `lambda` (by inversion; meant for small means).
    pub fn poisson(&mut self, lambda: f64) -> u32 {
        if lambda.is_nan() || lambda <= 0.0 {
            return 0;
        }
        let u = self.unit();
        let mut k = 0u32;
        let mut p = (-lambda).exp();
        let mut cumulative = p;
        while u > cumulative && k < 1000 {
            k += 1;
            p *= lambda / f64::from(k);
            cumulative += p;
        }
        k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_independent() {
        let a: Vec<f64> = {
            let mut r = SimRng::stream(7, "laser");
            (0..5).map(|_| r.unit()).collect()
        };
        let b: Vec<f64> = {
            let mut r = SimRng::stream(7, "laser");
            (0..5).map(|_| r.unit()).collect()
        };
        let c: Vec<f64> = {
            let mut r = SimRng::stream(7, "camera");
            (0..5).map(|_| r.unit()).collect()
        };
        let d: Vec<f64> = {
            let mut r = SimRng::stream(8, "laser");
            (0..5).map(|_| r.unit()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
    }

    #[test]
    fn moments_are_right() {
        let mut r = SimRng::stream(1, "moments");
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| r.normal(2.0, 0.5)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!((mean - 2.0).abs() < 0.01 && (var.sqrt() - 0.5).abs() < 0.01);
        let counts: Vec<u32> = (0..n).map(|_| r.poisson(0.3)).collect();
        let m = counts.iter().map(|&k| f64::from(k)).sum::<f64>() / n as f64;
        assert!((m - 0.3).abs() < 0.01, "{m}");
    }
}
