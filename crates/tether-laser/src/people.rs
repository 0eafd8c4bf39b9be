//! From legs to people (design 4.4, 4.5): pair leg candidates into person observations,
//! keep lone legs as weaker hypotheses, and give each observation a covariance.

use serde::{Deserialize, Serialize};
use tether_core::{Cov2, Gaussian2, Laser, Point2, RangeNoiseModel};

/// A leg candidate found in a scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    /// Estimated centre of the leg's cross-section, m.
    pub centre_in_laser: Point2<Laser>,
    /// Estimated radius of the cross-section, m.
    pub radius_m: f64,
    /// Mean of the cluster's returns, m: where the returns are, in front of the centre.
    pub centroid_in_laser: Point2<Laser>,
    /// Confidence in `[0, 1]`: `1 - spread / delta` for the arc test, `(F + 1) / 2`
    /// for the learned classifier.
    pub score: f64,
    /// First beam of the cluster.
    pub first_beam: usize,
    /// Last beam of the cluster.
    pub last_beam: usize,
    /// Number of returns in the cluster.
    pub n_points: usize,
}

/// Parameters of pairing and of the observation covariance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct PairingConfig {
    /// Largest distance between the centres of two legs of one person, m (default 0.6;
    /// real data: 0.21-0.34 m typical, up to 0.58 m).
    #[config(range = "> 0")]
    pub max_separation_m: f64,
    /// Report a lone leg as a (weaker) person hypothesis (default true).
    pub single_leg_people: bool,
    /// Standard deviation of the leg midpoint about the body centre along the line
    /// through the two legs (the walking direction during a stride), m (default 0.1).
    #[config(range = "> 0")]
    pub gait_sigma_along_m: f64,
    /// The same across that line, m (default 0.03).
    #[config(range = "> 0")]
    pub gait_sigma_across_m: f64,
    /// Standard deviation of the body centre about a lone leg, m (default 0.15: the
    /// other leg is up to ~0.3 m from the midpoint).
    #[config(range = "> 0")]
    pub single_leg_sigma_m: f64,
    /// A lone leg's person score is its leg score times this (default 0.5).
    #[config(range = ">= 0, <= 1")]
    pub single_leg_score_factor: f64,
}

impl Default for PairingConfig {
    fn default() -> Self {
        PairingConfig {
            max_separation_m: 0.6,
            single_leg_people: true,
            gait_sigma_along_m: 0.1,
            gait_sigma_across_m: 0.03,
            single_leg_sigma_m: 0.15,
            single_leg_score_factor: 0.5,
        }
    }
}

impl PairingConfig {
    /// Checks the parameter ranges; returns what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("max_separation_m", self.max_separation_m),
            ("gait_sigma_along_m", self.gait_sigma_along_m),
            ("gait_sigma_across_m", self.gait_sigma_across_m),
            ("single_leg_sigma_m", self.single_leg_sigma_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("pairing {name} must be > 0, got {v}"));
            }
        }
        if !(0.0..=1.0).contains(&self.single_leg_score_factor) {
            return Err(format!(
                "pairing single_leg_score_factor must be in [0, 1], got {}",
                self.single_leg_score_factor
            ));
        }
        Ok(())
    }
}

/// What an observation is made of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PersonKind {
    /// Two legs; indices into the scan's legs.
    TwoLegs([usize; 2]),
    /// One leg whose partner is hidden or merged; index into the scan's legs.
    OneLeg(usize),
}

/// A person seen by the laser: a position with its covariance, in the laser frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PersonObservation {
    /// Position and covariance, m and m^2.
    pub estimate: Gaussian2<Laser>,
    /// The legs it is made of.
    pub kind: PersonKind,
    /// Confidence in `[0, 1]`: the mean leg score for a pair, the leg score times
    /// `single_leg_score_factor` for a lone leg.
    pub score: f64,
}

/// Covariance of a point measured at range `r` and bearing `theta`, `(xx, xy, yy)`:
/// the polar noise `diag(sigma_r^2, sigma_theta^2)` propagated through
/// `J = d(x, y)/d(r, theta) = [[cos, -r sin], [sin, r cos]]`, i.e.
/// `R(theta) diag(sigma_r^2, r^2 sigma_theta^2) R(theta)^T`, with `sigma_r(r)` from the
/// noise model and `sigma_theta` half the angular resolution (design 4.5).
fn polar_cov(p: Point2<Laser>, noise: &RangeNoiseModel, sigma_theta_rad: f64) -> (f64, f64, f64) {
    let r = p.range_m();
    let (s, c) = p.bearing_rad().sin_cos();
    let a = noise.sigma_m(r).powi(2);
    let b = (r * sigma_theta_rad).powi(2);
    (
        a * c * c + b * s * s,
        (a - b) * s * c,
        a * s * s + b * c * c,
    )
}

/// `R(angle) diag(along^2, across^2) R(angle)^T` as `(xx, xy, yy)`.
fn axes_cov(along_m: f64, across_m: f64, angle_rad: f64) -> (f64, f64, f64) {
    let (s, c) = angle_rad.sin_cos();
    let (a, b) = (along_m * along_m, across_m * across_m);
    (
        a * c * c + b * s * s,
        (a - b) * s * c,
        a * s * s + b * c * c,
    )
}

/// Scratch space for [`pair_legs`].
#[derive(Debug, Default, Clone)]
pub struct PairScratch {
    pairs: Vec<(f64, usize, usize)>,
    used: Vec<bool>,
}

/// Pairs legs into people (design 4.4): every two legs within `max_separation_m` are a
/// candidate pair; pairs are taken greedily from the closest, each leg in at most one
/// person, and the person is at the pair's midpoint. Lone legs become one-leg
/// hypotheses when `single_leg_people` is set.
///
/// Covariance (design 4.5), for a pair with legs at `a` and `b`:
/// `P = (P_a + P_b) / 4 + R(phi) diag(g_along^2, g_across^2) R(phi)^T` with `P_a`, `P_b`
/// the polar noise of each leg centre, `phi` the direction from `a` to `b`; for a lone
/// leg at `a`: `P = P_a + s^2 I` with `s = single_leg_sigma_m`.
/// `angle_increment_rad` is the scan's; `sigma_theta = |angle_increment| / 2`.
pub fn pair_legs(
    legs: &[Leg],
    angle_increment_rad: f64,
    noise: &RangeNoiseModel,
    config: &PairingConfig,
    scratch: &mut PairScratch,
    out: &mut Vec<PersonObservation>,
) {
    out.clear();
    let sigma_theta = 0.5 * angle_increment_rad.abs();
    let max_sq = config.max_separation_m * config.max_separation_m;
    scratch.pairs.clear();
    for i in 0..legs.len() {
        for j in i + 1..legs.len() {
            let d = legs[j].centre_in_laser - legs[i].centre_in_laser;
            let d_sq = d.x * d.x + d.y * d.y;
            if d_sq <= max_sq {
                scratch.pairs.push((d_sq, i, j));
            }
        }
    }
    scratch
        .pairs
        .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
    scratch.used.clear();
    scratch.used.resize(legs.len(), false);
    for &(_, i, j) in &scratch.pairs {
        if scratch.used[i] || scratch.used[j] {
            continue;
        }
        scratch.used[i] = true;
        scratch.used[j] = true;
        let (a, b) = (legs[i].centre_in_laser, legs[j].centre_in_laser);
        let mid = a.lerp(b, 0.5);
        let pa = polar_cov(a, noise, sigma_theta);
        let pb = polar_cov(b, noise, sigma_theta);
        let phi = (b - a).angle_rad();
        let g = axes_cov(config.gait_sigma_along_m, config.gait_sigma_across_m, phi);
        let cov = Cov2::new(
            0.25 * (pa.0 + pb.0) + g.0,
            0.25 * (pa.1 + pb.1) + g.1,
            0.25 * (pa.2 + pb.2) + g.2,
        );
        if let Some(estimate) = cov.ok().and_then(|c| Gaussian2::new(mid, c).ok()) {
            out.push(PersonObservation {
                estimate,
                kind: PersonKind::TwoLegs([i, j]),
                score: 0.5 * (legs[i].score + legs[j].score),
            });
        }
    }
    if !config.single_leg_people {
        return;
    }
    for (i, leg) in legs.iter().enumerate() {
        if scratch.used[i] {
            continue;
        }
        if let Some(estimate) = lone_leg_estimate(leg, angle_increment_rad, noise, config) {
            out.push(PersonObservation {
                estimate,
                kind: PersonKind::OneLeg(i),
                score: leg.score * config.single_leg_score_factor,
            });
        }
    }
}

/// The person hypothesis of a lone leg at `a` (design 4.5): `P = P_a + s^2 I` with `P_a`
/// the polar noise of the leg centre and `s = single_leg_sigma_m`.
pub fn lone_leg_estimate(
    leg: &Leg,
    angle_increment_rad: f64,
    noise: &RangeNoiseModel,
    config: &PairingConfig,
) -> Option<Gaussian2<Laser>> {
    let a = leg.centre_in_laser;
    let pa = polar_cov(a, noise, 0.5 * angle_increment_rad.abs());
    let s2 = config.single_leg_sigma_m * config.single_leg_sigma_m;
    let cov = Cov2::new(pa.0 + s2, pa.1, pa.2 + s2);
    cov.ok().and_then(|c| Gaussian2::new(a, c).ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leg(x: f64, y: f64) -> Leg {
        Leg {
            centre_in_laser: Point2::new(x, y),
            radius_m: 0.06,
            centroid_in_laser: Point2::new(x - 0.05, y),
            score: 0.8,
            first_beam: 0,
            last_beam: 0,
            n_points: 10,
        }
    }

    fn pair(legs: &[Leg], config: &PairingConfig) -> Vec<PersonObservation> {
        let mut out = Vec::new();
        pair_legs(
            legs,
            0.006_136,
            &RangeNoiseModel::default(),
            config,
            &mut PairScratch::default(),
            &mut out,
        );
        out
    }

    #[test]
    fn pairs_the_closest_legs_first() {
        // Legs at y = 0, 0.25 and 0.55: (0, 0.25) pair, 0.55 stays alone.
        let legs = [leg(2.0, 0.55), leg(2.0, 0.0), leg(2.0, 0.25), leg(4.0, 3.0)];
        let people = pair(&legs, &PairingConfig::default());
        assert_eq!(people.len(), 3);
        assert_eq!(people[0].kind, PersonKind::TwoLegs([1, 2]));
        assert!((people[0].estimate.mean.y - 0.125).abs() < 1e-12);
        assert_eq!(people[1].kind, PersonKind::OneLeg(0));
        assert_eq!(people[2].kind, PersonKind::OneLeg(3));
        assert!((people[1].score - 0.4).abs() < 1e-12);
        let no_singles = PairingConfig {
            single_leg_people: false,
            ..PairingConfig::default()
        };
        assert_eq!(pair(&legs, &no_singles).len(), 1);
    }

    #[test]
    fn pair_covariance_is_long_along_the_stride() {
        // Legs one behind the other along x (a stride seen from the front).
        let people = pair(&[leg(2.0, 0.0), leg(2.3, 0.0)], &PairingConfig::default());
        let cov = people[0].estimate.cov;
        let (major, minor, angle) = cov.principal_axes();
        assert!(angle.abs() < 1e-6 || (angle.abs() - std::f64::consts::PI).abs() < 1e-6);
        // along: 0.1^2 + range noise / 2; across: 0.03^2 + bearing noise / 2.
        assert!((major - (0.01 + 0.5 * (0.02f64.powi(2) + 0.023f64.powi(2)) / 2.0)).abs() < 1e-4);
        assert!(minor > 0.03 * 0.03 && minor < 0.0011, "{minor}");
    }

    #[test]
    fn lone_leg_covariance_is_wide() {
        let people = pair(&[leg(1.0, 1.0)], &PairingConfig::default());
        let (major, minor, _) = people[0].estimate.cov.principal_axes();
        assert!(minor >= 0.15 * 0.15 && major < 0.15 * 0.15 + 0.001);
    }
}
