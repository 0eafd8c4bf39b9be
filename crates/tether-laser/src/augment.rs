//! Training scans seen from nearer (design 4.6): a recorded scan re-rendered from a
//! sensor moved along the line of sight toward one of its objects.
//!
//! A follower keeps its person about a metre away, but the labelled recordings hold few
//! legs that close (124 of the 1,164 training legs are under 1 m, 5 under 0.5 m), and a
//! leg seen at 0.5 m is another cluster than the same leg at 2 m: four times the returns,
//! with the other leg and the floor around it at other angles. Rather than fit features
//! to one range, the training split is shown again from nearer:
//!
//! 1. The scan becomes a surface: each pair of returns on neighbouring beams whose
//!    points lie within `max(0.03, 3 r dtheta)` m of each other (and under 0.1 m) is a
//!    segment of it; a return with no such neighbour is a segment one beam wide across
//!    its ray. Returns within [`BODY_RADIUS_M`] of the sensor (the robot's own body) are
//!    left out.
//! 2. A virtual sensor with the scan's own beams stands at `s u`, where `u` is the unit
//!    vector toward the chosen object at range `r` and `s = r - r'`, so that the object
//!    is at range `r'`; it looks the same way as the real one.
//! 3. Each virtual beam returns the nearest crossing with the surface, or nothing.
//!
//! The object keeps the side it showed the real sensor (the virtual one looks along the
//! same ray), other objects are seen from a little aside and occlude each other as
//! geometry says, and what the real sensor never saw returns nothing. Labels move with
//! the frame: `p' = p - s u`. The choice of object and range is a fixed sequence, so
//! training stays deterministic.

use tether_core::{Laser, LaserScan, Point2};

/// Returns nearer the sensor than this belong to the robot and are not part of the
/// surface, m.
pub const BODY_RADIUS_M: f64 = 0.25;

/// Nearest range an object is brought to, m.
pub const NEAREST_M: f64 = 0.3;

/// Farthest range an object is brought to, m: the ranges a follower keeps its person
/// at, and a little beyond.
pub const FARTHEST_M: f64 = 1.5;

/// A segment of the scan's surface, in the real sensor's frame.
#[derive(Debug, Clone, Copy)]
struct Facet {
    a: (f64, f64),
    b: (f64, f64),
}

/// The scan's returns joined into a surface (step 1 above).
fn surface(scan: &LaserScan) -> Vec<Facet> {
    let dtheta = scan.angle_increment_rad.abs();
    let mut facets = Vec::new();
    let point = |i: usize| -> Option<(f64, f64)> {
        let r = f64::from(scan.range_m(i)?);
        if r < BODY_RADIUS_M {
            return None;
        }
        let (s, c) = scan.angle_rad(i).sin_cos();
        Some((r * c, r * s))
    };
    let n = scan.len();
    let mut joined_before = false;
    for i in 0..n {
        let Some(p) = point(i) else {
            joined_before = false;
            continue;
        };
        let r = (p.0 * p.0 + p.1 * p.1).sqrt();
        let joined_after = match (i + 1 < n).then(|| point(i + 1)).flatten() {
            Some(q) => {
                let gap = ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt();
                if gap <= (3.0 * r * dtheta).clamp(0.03, 0.1) {
                    facets.push(Facet { a: p, b: q });
                    true
                } else {
                    false
                }
            }
            None => false,
        };
        if !joined_before && !joined_after {
            // One beam wide across the ray.
            let half = 0.5 * r * dtheta;
            let (ux, uy) = (-p.1 / r, p.0 / r);
            facets.push(Facet {
                a: (p.0 - half * ux, p.1 - half * uy),
                b: (p.0 + half * ux, p.1 + half * uy),
            });
        }
        joined_before = joined_after;
    }
    facets
}

/// Distance along the ray from `o` in direction `d` (unit) to facet `f`, if it crosses.
fn crossing(o: (f64, f64), d: (f64, f64), f: &Facet) -> Option<f64> {
    let e = (f.b.0 - f.a.0, f.b.1 - f.a.1);
    let w = (f.a.0 - o.0, f.a.1 - o.1);
    let den = d.0 * e.1 - d.1 * e.0;
    if den.abs() < 1e-12 {
        return None;
    }
    let t = (w.0 * e.1 - w.1 * e.0) / den;
    let u = (w.0 * d.1 - w.1 * d.0) / den;
    (t > 1e-6 && (-1e-9..=1.0 + 1e-9).contains(&u)).then_some(t)
}

/// `scan` seen by the same scanner moved by `shift_m` (in the scan's frame, looking the
/// same way). `None` when the shifted scan cannot be built (no beam returns).
pub fn shifted_view(scan: &LaserScan, shift_m: (f64, f64)) -> Option<LaserScan> {
    let facets = surface(scan);
    let beams = (scan.angle_min_rad, scan.angle_increment_rad, scan.len());
    render(scan, &facets, shift_m, beams, |_, r| r)
}

/// The surface `facets` (of `scan`) as seen from `origin` by the beams `(angle_min,
/// increment, count)`, each range passed through `finish(beam, range)` (which may
/// return infinity for no return). `None` when no beam returns.
fn render(
    scan: &LaserScan,
    facets: &[Facet],
    origin: (f64, f64),
    (angle_min_rad, increment_rad, count): (f64, f64, usize),
    mut finish: impl FnMut(usize, f64) -> f64,
) -> Option<LaserScan> {
    let mut ranges = Vec::with_capacity(count);
    for i in 0..count {
        let (s, c) = (angle_min_rad + i as f64 * increment_rad).sin_cos();
        let best = facets
            .iter()
            .filter_map(|f| crossing(origin, (c, s), f))
            .fold(f64::INFINITY, f64::min);
        let r = finish(i, best) as f32;
        ranges.push(
            if f64::from(r) <= scan.range_max_m && f64::from(r) >= scan.range_min_m {
                r
            } else {
                f32::INFINITY
            },
        );
    }
    let out = LaserScan::new(
        scan.stamp,
        scan.frame_id.clone(),
        angle_min_rad,
        increment_rad,
        scan.range_min_m,
        scan.range_max_m,
        ranges,
    )
    .ok()?;
    (out.returns() > 0).then_some(out)
}

/// Angular steps of the coarser scanners a view imitates, deg: the 0.5-1 degree
/// steps of the 360-degree scanners most small robots carry (RPLIDAR A1/A2, LDS-01,
/// YDLIDAR X4), against the 0.25-0.36 degrees of the Hokuyo scanners that recorded the
/// training data.
pub const COARSER_STEPS_DEG: [f64; 3] = [0.5, 0.75, 1.0];

/// Largest range noise of a coarser view, as a fraction of the range: triangulation
/// scanners are specified at 1-3.5 % of the distance (1 sigma taken as the figure).
pub const COARSER_MAX_RELATIVE_SIGMA: f64 = 0.025;

/// Largest share of a coarser view's beams that return nothing although they hit
/// something: about one beam in four on the triangulation scanners.
pub const COARSER_MAX_NO_RETURN: f64 = 0.25;

/// A uniform number in [0, 1) from `(view, beam, salt)`: SplitMix64's finaliser, so
/// that the views are a fixed function of the training data.
fn uniform(view: usize, beam: usize, salt: u64) -> f64 {
    let mut z = (view as u64)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((beam as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9))
        .wrapping_add(salt.wrapping_mul(0x94D0_49BB_1331_11EB));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// `scan` as a coarser and noisier scanner at the same place would see it: the `k`-th
/// view of a fixed sequence. The surface (step 1 above) is swept by beams
/// [`COARSER_STEPS_DEG`]`[k mod 3]` apart over the same field of view; each range gets
/// Gaussian noise of `sigma = c r` and each beam returns nothing with probability `q`,
/// where `c` and `q` run through `[0, COARSER_MAX_RELATIVE_SIGMA]` and `[0,
/// COARSER_MAX_NO_RETURN]` by the golden-ratio sequence (as [`target_range_m`]). Labels
/// stay where they are (same frame). `None` when the scan is already that coarse or
/// no beam returns.
pub fn coarser_view(scan: &LaserScan, k: usize) -> Option<LaserScan> {
    const PHI: f64 = 0.618_033_988_749_894_9;
    let step_rad = COARSER_STEPS_DEG[k % COARSER_STEPS_DEG.len()].to_radians();
    let inc = scan.angle_increment_rad;
    if step_rad <= 1.2 * inc.abs() || scan.len() < 2 {
        return None;
    }
    let fov_rad = (scan.len() - 1) as f64 * inc.abs();
    let count = (fov_rad / step_rad).floor() as usize + 1;
    let sigma = COARSER_MAX_RELATIVE_SIGMA * ((k as f64 + 1.0) * PHI).fract();
    let no_return = COARSER_MAX_NO_RETURN * ((k as f64 + 2.0) * PHI * PHI).fract();
    let facets = surface(scan);
    let beams = (scan.angle_min_rad, step_rad * inc.signum(), count);
    render(scan, &facets, (0.0, 0.0), beams, |i, r| {
        if uniform(k, i, 1) < no_return {
            return f64::INFINITY;
        }
        // Box-Muller.
        let (u1, u2) = (uniform(k, i, 2).max(1e-300), uniform(k, i, 3));
        let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        r * (1.0 + sigma * z)
    })
}

/// The `k`-th target range of the fixed sequence, `NEAREST_M + frac(k phi) *
/// (FARTHEST_M - NEAREST_M)` with the golden ratio's fraction `phi`: spread evenly over
/// the range without drawing anything at random.
pub fn target_range_m(k: usize) -> f64 {
    const PHI: f64 = 0.618_033_988_749_894_9;
    let frac = (k as f64 * PHI).fract();
    NEAREST_M + frac * (FARTHEST_M - NEAREST_M)
}

/// `scan` seen from nearer `toward` (a point in the scan's frame): the `k`-th view of
/// the sequence ([`target_range_m`]), with `labels` moved into the new frame. `None`
/// when `toward` is already nearer than the target range (plus 0.2 m), or the view
/// cannot be built.
pub fn nearer_view(
    scan: &LaserScan,
    toward: Point2<Laser>,
    labels: &[Point2<Laser>],
    k: usize,
) -> Option<(LaserScan, Vec<Point2<Laser>>)> {
    let r = toward.range_m();
    let target = target_range_m(k);
    if !(r.is_finite() && r > target + 0.2) {
        return None;
    }
    let s = r - target;
    let shift = (s * toward.x / r, s * toward.y / r);
    let view = shifted_view(scan, shift)?;
    let moved = labels
        .iter()
        .map(|p| Point2::new(p.x - shift.0, p.y - shift.1))
        .collect();
    Some((view, moved))
}

/// Nearest and farthest a backdrop stands behind the farthest labelled leg of a view,
/// m: the walls, furniture and people that stand 1-4 m behind a person followed
/// indoors.
pub const BACKDROP_BEHIND_M: [f64; 2] = [0.8, 4.0];

/// Range noise of a backdrop's returns (one sigma), m.
pub const BACKDROP_SIGMA_M: f64 = 0.01;

/// `scan` with a backdrop behind its people: the `k`-th view of a fixed sequence
/// (design 4.6). The people of the labelled recordings walk in an open hall, where the
/// beams past a leg return nothing or come back from 5 m and more, so that a model
/// trained on them alone learns that a leg has nothing behind it and refuses the legs
/// of a person followed along a corridor or in a room. Here every beam that returns
/// nothing or reads farther than `r_b = max_i |legs_i| + d` reads `r_b` instead (plus
/// Gaussian noise of [`BACKDROP_SIGMA_M`]): a surface at a constant range (locally a
/// wall) `d` behind the farthest leg, `d` running through [`BACKDROP_BEHIND_M`] by the
/// golden-ratio sequence (as [`target_range_m`]). Everything nearer, the legs
/// included, stays as recorded; labels stay where they are. `None` when there is no
/// leg, or the backdrop would lie beyond the scanner's range.
pub fn backdrop_view(scan: &LaserScan, legs: &[Point2<Laser>], k: usize) -> Option<LaserScan> {
    const PHI: f64 = 0.618_033_988_749_894_9;
    let farthest_m = legs
        .iter()
        .map(|l| l.range_m())
        .filter(|r| r.is_finite())
        .reduce(f64::max)?;
    let [near, far] = BACKDROP_BEHIND_M;
    let backdrop_m = farthest_m + near + ((k as f64 + 1.0) * PHI).fract() * (far - near);
    if backdrop_m + 3.0 * BACKDROP_SIGMA_M >= scan.range_max_m {
        return None;
    }
    let ranges = scan
        .ranges_m()
        .iter()
        .enumerate()
        .map(|(i, &r)| {
            let r = f64::from(r);
            if r.is_finite() && r >= scan.range_min_m && r <= backdrop_m {
                return r as f32;
            }
            // Box-Muller.
            let (u1, u2) = (uniform(k, i, 4).max(1e-300), uniform(k, i, 5));
            let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            (backdrop_m + BACKDROP_SIGMA_M * z) as f32
        })
        .collect();
    scan.with_ranges(ranges).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::Stamp;

    /// A disc of radius `radius_m` at `(cx, 0)` seen by a scanner at the origin.
    fn disc_scan(cx: f64, radius_m: f64) -> LaserScan {
        let inc = 0.25f64.to_radians();
        let n = 721;
        let min = -90f64.to_radians();
        let ranges = (0..n)
            .map(|i| {
                let a = min + i as f64 * inc;
                let c = a.cos();
                // Ray x = t c, y = t s against the circle.
                let b = -2.0 * cx * c;
                let cc = cx * cx - radius_m * radius_m;
                let disc = b * b - 4.0 * cc;
                if disc < 0.0 {
                    f32::INFINITY
                } else {
                    ((-b - disc.sqrt()) / 2.0) as f32
                }
            })
            .collect();
        LaserScan::new(Stamp::ZERO, "laser", min, inc, 0.02, 5.6, ranges).unwrap()
    }

    #[test]
    fn a_disc_seen_from_nearer_is_where_the_shift_puts_it() {
        let scan = disc_scan(2.0, 0.06);
        let (view, labels) =
            nearer_view(&scan, Point2::new(2.0, 0.0), &[Point2::new(2.0, 0.0)], 1).unwrap();
        let target = target_range_m(1);
        assert!((labels[0].x - target).abs() < 1e-9, "{labels:?}");
        // The beam straight ahead meets the near side of the disc.
        let ahead = (0.0 - view.angle_min_rad) / view.angle_increment_rad;
        let r = f64::from(view.range_m(ahead.round() as usize).unwrap());
        assert!(
            (r - (target - 0.06)).abs() < 0.01,
            "{r} against {}",
            target - 0.06
        );
        // Nearer, the disc covers more beams.
        assert!(
            view.returns() > scan.returns(),
            "{} vs {}",
            view.returns(),
            scan.returns()
        );
    }

    #[test]
    fn objects_that_are_already_near_are_not_moved() {
        let scan = disc_scan(0.5, 0.06);
        assert!(nearer_view(&scan, Point2::new(0.5, 0.0), &[], 0).is_none());
    }

    #[test]
    fn a_backdrop_stands_behind_the_legs_and_leaves_them_as_recorded() {
        let scan = disc_scan(1.0, 0.06);
        let legs = [Point2::new(1.0, 0.0)];
        assert!(
            backdrop_view(&scan, &[], 0).is_none(),
            "no leg, no backdrop"
        );
        for k in 0..20 {
            let view = backdrop_view(&scan, &legs, k).unwrap();
            assert_eq!(view.len(), scan.len());
            let mut backdrop = Vec::new();
            for (i, (&before, &after)) in scan.ranges_m().iter().zip(view.ranges_m()).enumerate() {
                if before.is_finite() {
                    assert_eq!(before, after, "beam {i} on the disc is kept");
                } else {
                    backdrop.push(f64::from(after));
                }
            }
            let mean = backdrop.iter().sum::<f64>() / backdrop.len() as f64;
            let behind = mean - 1.0;
            assert!(
                (BACKDROP_BEHIND_M[0] - 0.01..=BACKDROP_BEHIND_M[1] + 0.01).contains(&behind),
                "view {k}: {behind} m behind"
            );
            let sd = (backdrop.iter().map(|r| (r - mean).powi(2)).sum::<f64>()
                / backdrop.len() as f64)
                .sqrt();
            assert!(
                (sd - BACKDROP_SIGMA_M).abs() < 0.002,
                "view {k}: sigma {sd}"
            );
        }
        // Deterministic, and the sequence spreads the distances.
        assert_eq!(
            backdrop_view(&scan, &legs, 3),
            backdrop_view(&scan, &legs, 3)
        );
        assert_ne!(
            backdrop_view(&scan, &legs, 3),
            backdrop_view(&scan, &legs, 4)
        );
        // A backdrop past the scanner's range (5.6 m) is not drawn.
        assert!(backdrop_view(&scan, &[Point2::new(5.0, 0.0)], 0).is_none());
    }

    #[test]
    fn a_coarser_view_has_the_coarser_step_over_the_same_field_of_view() {
        let scan = disc_scan(1.0, 0.06);
        for k in 0..6 {
            let view = coarser_view(&scan, k).unwrap();
            let step = COARSER_STEPS_DEG[k % 3].to_radians();
            assert!((view.angle_increment_rad - step).abs() < 1e-12);
            assert_eq!(view.angle_min_rad, scan.angle_min_rad);
            let fov = (scan.len() - 1) as f64 * scan.angle_increment_rad;
            let view_fov = (view.len() - 1) as f64 * view.angle_increment_rad;
            assert!(
                view_fov <= fov + 1e-9 && view_fov > fov - step,
                "{view_fov} {fov}"
            );
            // The disc is still there: its near side at 0.94 m, within the noise.
            let ahead = ((0.0 - view.angle_min_rad) / step).round() as usize;
            let r = (ahead.saturating_sub(1)..=ahead + 1)
                .filter_map(|i| view.range_m(i))
                .map(f64::from)
                .fold(f64::INFINITY, f64::min);
            assert!((r - 0.94).abs() < 0.1, "view {k}: {r}");
        }
        // Deterministic: the same view twice.
        assert_eq!(coarser_view(&scan, 4), coarser_view(&scan, 4));
        // Nothing is coarser than the scan itself at 1 degree.
        let coarse = coarser_view(&scan, 2).unwrap();
        assert!(coarser_view(&coarse, 2).is_none());
    }

    #[test]
    fn coarser_views_lose_up_to_a_quarter_of_the_beams_and_add_noise() {
        let scan = disc_scan(1.0, 0.06);
        let (mut lost, mut returned) = (0usize, 0usize);
        for k in 0..30 {
            // Beams that see the disc in the view (the rest sees nothing).
            let view = coarser_view(&scan, k).unwrap();
            let step = view.angle_increment_rad;
            let on_disc = (0..view.len()).filter(|&i| {
                (view.angle_min_rad + i as f64 * step).abs() < (0.06f64 / 1.0).asin() - step
            });
            for i in on_disc {
                match view.range_m(i) {
                    Some(_) => returned += 1,
                    None => lost += 1,
                }
            }
        }
        let share = lost as f64 / (lost + returned) as f64;
        // The loss probabilities run evenly over [0, 0.25]: about 0.125 on average.
        assert!((0.05..0.2).contains(&share), "{share}");
    }

    #[test]
    fn target_ranges_cover_the_following_distances() {
        let ranges: Vec<f64> = (0..100).map(target_range_m).collect();
        assert!(ranges.iter().all(|r| (NEAREST_M..FARTHEST_M).contains(r)));
        let below_one = ranges.iter().filter(|&&r| r < 0.9).count();
        assert!((45..=55).contains(&below_one), "{below_one}");
    }
}
