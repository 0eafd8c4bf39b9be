//! Pre-processing (design 4.1): keep the beams with a return and remove the range bias.

use tether_core::{Laser, LaserScan, Point2, RangeNoiseModel};

/// One return of a scan after pre-processing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanPoint {
    /// Index of the beam in beam order from the scan's seam ([`seam_beam`]): the beam
    /// index of the scan itself, except on a scan that closes the circle, where it
    /// counts from the seam (`(i - seam) mod n`, and `(beam + seam) mod n` is the scan's).
    pub beam: usize,
    /// Range with the bias removed, `r - bias(r)`, m.
    pub range_m: f64,
    /// Direction of the beam, rad.
    pub bearing_rad: f64,
    /// The return as a point: `(r cos(bearing), r sin(bearing))`, m.
    pub point_in_laser: Point2<Laser>,
}

/// Cosines and sines of a scan's beam directions, kept between scans of the same
/// geometry so that a scan costs no trigonometry.
#[derive(Debug, Clone, Default)]
pub struct BeamTable {
    angle_min_rad: f64,
    angle_increment_rad: f64,
    cos_sin: Vec<(f64, f64)>,
}

impl BeamTable {
    /// Makes the table fit `scan` (recomputing it only if the geometry changed).
    pub fn update(&mut self, scan: &LaserScan) {
        if self.cos_sin.len() == scan.len()
            && self.angle_min_rad == scan.angle_min_rad
            && self.angle_increment_rad == scan.angle_increment_rad
        {
            return;
        }
        self.angle_min_rad = scan.angle_min_rad;
        self.angle_increment_rad = scan.angle_increment_rad;
        self.cos_sin.clear();
        self.cos_sin.extend((0..scan.len()).map(|i| {
            let (s, c) = scan.angle_rad(i).sin_cos();
            (c, s)
        }));
    }

    /// `out` = the points of [`LaserScan::points`] through `map`, in order: the same
    /// values (the same `sin_cos` of the same angles, the same products) from the
    /// table instead of trigonometry per beam, and without a branch on which beams
    /// returned (every beam's point is written at the end of the kept ones, which only
    /// move past it when the beam returned): on a scanner that loses beams at random,
    /// the CPU cannot predict that branch. `map` also sees the non-finite points of
    /// beams of no return; what it makes of them is dropped. The table must have been
    /// updated for `scan`; beams past it are left out.
    pub fn points_into<T: Copy>(
        &self,
        scan: &LaserScan,
        map: impl Fn(Point2<Laser>) -> T,
        out: &mut Vec<T>,
    ) {
        // Whatever the buffer holds from the last scan is written over: only a longer
        // scan makes it fill new room.
        let ranges = &scan.ranges_m()[..scan.len().min(self.cos_sin.len())];
        out.resize(ranges.len(), map(Point2::ORIGIN));
        let mut kept = 0;
        for (&r, &(c, s)) in ranges.iter().zip(&self.cos_sin) {
            let range_m = f64::from(r);
            out[kept] = map(Point2::new(range_m * c, range_m * s));
            kept += usize::from(r.is_finite());
        }
        out.truncate(kept);
    }
}

/// Pre-processing counts for one scan.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PreprocessStats {
    /// Beams with no return (error codes, out of range, malformed), dropped.
    pub no_return: usize,
    /// Returns whose bias-corrected range is not a positive finite number, dropped.
    pub bad_after_correction: usize,
    /// The scan's beam that beam order starts from ([`seam_beam`]; 0 unless the scan
    /// closes the circle).
    pub seam_beam: usize,
}

/// Turns the returns of `scan` into points with the range calibration applied:
/// `r_corrected = r - bias(r)` (design 2.1, 4.1). Beams with no return are dropped (the
/// scan already maps error codes, NaN and out-of-range values to "no return").
/// `table` must have been updated for `scan` ([`BeamTable::update`]).
pub fn preprocess_into(
    scan: &LaserScan,
    noise: &RangeNoiseModel,
    table: &BeamTable,
    out: &mut Vec<ScanPoint>,
) -> PreprocessStats {
    let mut stats = PreprocessStats::default();
    let unbiased = noise.bias_m.0.is_empty();
    let n = scan.len().min(table.cos_sin.len());
    let seam = seam_beam(scan, table);
    stats.seam_beam = seam;
    // Beam order from the seam: beams `seam..n`, then `0..seam` (no remainder per beam).
    let ranges = &scan.ranges_m()[..n];
    let cos_sin = &table.cos_sin[..n];
    let start = seam.checked_rem(n).unwrap_or(0);
    let from_seam = (start..n).chain(0..start);
    // Every beam's point is written at the end of the kept ones and kept by moving the
    // end past it: no branch on which beams returned, which on a scanner that loses
    // beams at random (a quarter on the YDLIDAR X4) the CPU cannot predict. What `out`
    // holds from the last scan is written over (only a longer scan fills new room).
    out.resize(
        n,
        ScanPoint {
            beam: 0,
            range_m: 0.0,
            bearing_rad: 0.0,
            point_in_laser: Point2::ORIGIN,
        },
    );
    let mut kept = 0;
    for (beam, i) in from_seam.enumerate() {
        let (r, (c, s)) = (ranges[i], cos_sin[i]);
        let returned = r.is_finite();
        let measured_m = f64::from(r);
        // (A beam of no return is corrected too, to no use: the correction is
        // arithmetic, and the beam is dropped whatever it gives.)
        let range_m = if unbiased {
            measured_m
        } else {
            noise.corrected_m(measured_m)
        };
        let good = range_m.is_finite() && range_m > 0.0;
        stats.no_return += usize::from(!returned);
        stats.bad_after_correction += usize::from(returned & !good);
        out[kept] = ScanPoint {
            beam,
            range_m,
            bearing_rad: scan.angle_min_rad + i as f64 * scan.angle_increment_rad,
            point_in_laser: Point2::new(range_m * c, range_m * s),
        };
        kept += usize::from(returned & good);
    }
    out.truncate(kept);
    stats
}

/// Whether the scan's beams go all the way round: `n |dtheta| >= 2 pi - |dtheta| / 2`
/// (a 360-degree scanner, whose last beam neighbours its first).
pub fn closes_the_circle(scan: &LaserScan) -> bool {
    let inc = scan.angle_increment_rad.abs();
    scan.len() as f64 * inc >= std::f64::consts::TAU - 0.5 * inc
}

/// The beam a scan's beam order starts from. On a scan that does not close the circle,
/// beam 0. On one that does, the first and last beams are neighbours, and an object
/// across that seam would be cut in two, so beam order starts instead after the widest
/// gap between returns next to each other in angle (no-return beams skipped): the
/// return with the greatest distance `|p_i - p_prev|` to the return before it, where
/// no object can span. `table` must have been updated for `scan`.
pub fn seam_beam(scan: &LaserScan, table: &BeamTable) -> usize {
    if !closes_the_circle(scan) {
        return 0;
    }
    let ranges = scan.ranges_m();
    let point = |i: usize| {
        let r = f64::from(ranges[i]);
        let (c, s) = table.cos_sin[i];
        (r * c, r * s)
    };
    let n = ranges.len().min(table.cos_sin.len());
    let Some(last) = (0..n).rev().find(|&i| ranges[i].is_finite()) else {
        return 0;
    };
    let mut prev = point(last);
    let (mut best, mut best_gap_sq) = (0, f64::NEG_INFINITY);
    // Every beam is visited and a beam of no return changes nothing: no branch on
    // which beams returned (see `preprocess_into`).
    for (i, r) in ranges[..n].iter().enumerate() {
        let returned = r.is_finite();
        let p = point(i);
        let gap_sq = (p.0 - prev.0).powi(2) + (p.1 - prev.1).powi(2);
        if returned & (gap_sq > best_gap_sq) {
            (best, best_gap_sq) = (i, gap_sq);
        }
        let keep = if returned { u64::MAX } else { 0 };
        let select =
            |new: f64, old: f64| f64::from_bits((new.to_bits() & keep) | (old.to_bits() & !keep));
        prev = (select(p.0, prev.0), select(p.1, prev.1));
    }
    best
}

/// [`preprocess_into`] for a one-off call.
pub fn preprocess(scan: &LaserScan, noise: &RangeNoiseModel) -> Vec<ScanPoint> {
    let mut table = BeamTable::default();
    table.update(scan);
    let mut out = Vec::with_capacity(scan.len());
    preprocess_into(scan, noise, &table, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{Polynomial, Stamp};

    #[test]
    fn drops_no_return_and_removes_bias() {
        let scan = LaserScan::new(
            Stamp::ZERO,
            "laser",
            0.0,
            std::f64::consts::FRAC_PI_2,
            0.02,
            5.6,
            vec![1.0, f32::INFINITY, f32::NAN, 2.0],
        )
        .unwrap();
        let noise = RangeNoiseModel {
            bias_m: Polynomial(vec![0.01, 0.02]),
            ..RangeNoiseModel::default()
        };
        let pts = preprocess(&scan, &noise);
        assert_eq!(pts.len(), 2);
        assert_eq!(pts[0].beam, 0);
        assert!((pts[0].range_m - (1.0 - 0.03)).abs() < 1e-12);
        assert_eq!(pts[1].beam, 3);
        // Beam 3 points along 3 * 90 deg = -y.
        assert!((pts[1].point_in_laser.y + (2.0 - 0.05)).abs() < 1e-9);
    }

    #[test]
    fn the_table_gives_the_scans_own_points() {
        let ranges: Vec<f32> = (0..720)
            .map(|i| match i % 7 {
                3 => f32::INFINITY,
                _ => 0.1 + 0.013 * i as f32,
            })
            .collect();
        let scan = LaserScan::new(
            Stamp::ZERO,
            "laser",
            -3.1,
            0.5f64.to_radians(),
            0.02,
            12.0,
            ranges,
        )
        .unwrap();
        let mut table = BeamTable::default();
        table.update(&scan);
        let mut points = vec![Point2::ORIGIN; 3];
        table.points_into(&scan, |p| p, &mut points);
        assert!(points.iter().copied().eq(scan.points().map(|(_, p)| p)));
        let mut doubled = Vec::new();
        table.points_into(
            &scan,
            |p| Point2::<Laser>::new(2.0 * p.x, 2.0 * p.y),
            &mut doubled,
        );
        assert!(
            doubled.iter().copied().eq(scan
                .points()
                .map(|(_, p)| Point2::new(2.0 * p.x, 2.0 * p.y)))
        );
    }

    #[test]
    fn a_bias_larger_than_the_range_drops_the_return() {
        let scan =
            LaserScan::new(Stamp::ZERO, "laser", 0.0, 0.1, 0.02, 5.6, vec![0.05, 1.0]).unwrap();
        let noise = RangeNoiseModel {
            bias_m: Polynomial(vec![0.1]),
            ..RangeNoiseModel::default()
        };
        let mut table = BeamTable::default();
        table.update(&scan);
        let mut out = Vec::new();
        let stats = preprocess_into(&scan, &noise, &table, &mut out);
        assert_eq!(out.len(), 1);
        assert_eq!(stats.bad_after_correction, 1);
    }

    #[test]
    fn table_follows_the_geometry() {
        let a = LaserScan::new(Stamp::ZERO, "l", 0.0, 0.1, 0.02, 5.6, vec![1.0; 3]).unwrap();
        let b = LaserScan::new(Stamp::ZERO, "l", 0.5, 0.1, 0.02, 5.6, vec![1.0; 3]).unwrap();
        let mut table = BeamTable::default();
        table.update(&a);
        table.update(&b);
        let mut out = Vec::new();
        preprocess_into(&b, &RangeNoiseModel::default(), &table, &mut out);
        assert!((out[0].point_in_laser.x - 0.5f64.cos()).abs() < 1e-12);
    }
}
