//! The target selector's settings.

use serde::{Deserialize, Serialize};

/// Target selection settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct TargetConfig {
    /// Follow this track id instead of choosing (when it exists).
    pub track_id: Option<u64>,
    /// Follow the person nearest this point, `[x, y]` in the robot frame at the time of
    /// the choice, m (within `near_point_radius_m`), instead of the one nearest the
    /// heading.
    pub near_point_m: Option<[f64; 2]>,
    /// How close to `near_point_m` the chosen person must be, m.
    #[config(range = "> 0")]
    pub near_point_radius_m: f64,
    /// Only people seen by both sensors within this window can be chosen at start, s.
    #[config(range = "> 0")]
    pub both_sensors_window_s: f64,
    /// Only a person seen by both sensors can be chosen at start, and, where the camera
    /// sees, re-acquired (turned off when one sensor is absent).
    pub require_both_sensors: bool,
    /// Farthest person that can be chosen at start, m.
    #[config(range = "> 0")]
    pub max_select_range_m: f64,
    /// Largest bearing off the robot's heading for the choice at start, rad.
    #[config(range = "> 0")]
    pub max_select_bearing_rad: f64,
    /// The target counts as lost when its track has not been updated for this long, s
    /// (until then it coasts, still locked).
    #[config(range = "> 0")]
    pub lost_after_s: f64,
    /// Leg-pair observations a walking track needs before the laser alone vouches for
    /// it when re-acquiring (walking already sets it apart from static clutter; one
    /// pair says it walks on legs).
    pub min_leg_pairs: u32,
    /// Leg-pair observations a track that has not walked needs before the laser alone
    /// vouches for it at the start (a person standing in front of the robot; nothing
    /// but the legs sets them apart from a pair of table legs until the clutter map
    /// has learned the room).
    pub min_leg_pairs_standing: u32,
    /// Distance a track must have walked before the laser alone vouches for it when
    /// re-acquiring, m: about one step (a post's or a table leg's track moves a few
    /// centimetres; a bush's, whose returns wander over it, is kept out by the learned
    /// static clutter). Each tenth of a metre costs a tenth of a second of a walker
    /// who reappears.
    #[config(range = ">= 0")]
    pub min_walked_m: f64,
    /// Share of a track's (not weak) updates that must be leg pairs before the laser
    /// alone vouches for it when re-acquiring: a bush or a phantom that now and then
    /// looks like a pair seldom does (under a tenth of its updates in the simulated
    /// park), while a real person, even when the recordings show one leg as often as
    /// two (leg_tracker's labelled `positive_*` bags), shows a pair in more than a
    /// fifth.
    #[config(range = ">= 0")]
    pub min_pair_share: f64,
    /// Largest share of a track's updates that may be weak (legs the classifier barely
    /// accepts) for the laser alone to vouch for it.
    #[config(range = ">= 0")]
    pub max_weak_share: f64,
    /// Margin added to the region where a lost target can be, beyond three standard
    /// deviations of its last estimate and of the candidate's, m.
    #[config(range = ">= 0")]
    pub region_margin_m: f64,
    /// Another track is somebody else, never the target taken up again, once it has
    /// been updated at the same instants as the locked target, farther from it than
    /// `beside_distance_m`, for this long in all, s. One person's legs seen as two
    /// tracks for a moment, or a track that takes the person's legs while the target's
    /// own track is led off by clutter, do not add up to that; a bystander walking
    /// beside the target does.
    #[config(range = ">= 0")]
    pub beside_s: f64,
    /// How far apart two tracks updated together must be to count as two people, m.
    #[config(range = ">= 0")]
    pub beside_distance_m: f64,
    /// Another track closer than this to the target is a close encounter (a bystander
    /// passing, a crossing): the tracker may swap the two, so the target's own motion
    /// is carried on from before the encounter and checked against its track, m.
    #[config(range = ">= 0")]
    pub encounter_distance_m: f64,
    /// Longest an encounter is bridged by the target's motion from before it, s.
    #[config(range = ">= 0")]
    pub encounter_max_s: f64,
    /// Typical acceleration of a walker, m/s^2: how fast the prediction through an
    /// encounter spreads (`sigma(dt) = sqrt(sigma_0^2 + (sigma_v dt)^2 + (a dt^2 / 2)^2)`).
    #[config(range = ">= 0")]
    pub encounter_accel_mps2: f64,
    /// During an encounter, the target is handed over from its track to another one
    /// when that track explains the target's motion from before the encounter
    /// (position and velocity) better by at least this much: the difference of their
    /// squared normalised distances, `d_track^2 - d_other^2` (twice the log-likelihood
    /// ratio; 4 is a ratio of e^2, about 7), and better than any third track by as much.
    #[config(range = ">= 0")]
    pub handover_margin: f64,
    /// ...and the other track is within this normalised distance of the prediction.
    #[config(range = ">= 0")]
    pub handover_within_sigma: f64,
    /// A target's track that has coasted this long while exactly one other track takes
    /// up the target hands it over ([`super::TargetSelector`]'s coasting handover), s.
    #[config(range = ">= 0")]
    pub handover_coast_s: f64,
    /// The target's track that stays within `led_off_distance_m` of somebody else's
    /// track for `led_off_after_s` has been led off onto that person: the target is
    /// lost. Two people passing shoulder to shoulder are closer than half a metre for
    /// a moment only; two tracks on one person stay within a few centimetres, m.
    #[config(range = ">= 0")]
    pub led_off_distance_m: f64,
    /// See `led_off_distance_m`, s.
    #[config(range = ">= 0")]
    pub led_off_after_s: f64,
    /// After the target has been lost this long, s, it is taken up again as at the
    /// start: the one person standing in front of the robot (within
    /// `max_select_range_m` and `max_select_bearing_rad`, vouched for as at the start)
    /// for `restart_dwell_s` (0: never). By then the region where the target can be
    /// covers everything in view, and a verdict that a track is somebody else may rest
    /// on a lock that had gone astray; the followed person comes back in front of the
    /// robot, a passer-by does not stay there.
    #[config(range = ">= 0")]
    pub restart_after_s: f64,
    /// See `restart_after_s`, s.
    #[config(range = ">= 0")]
    pub restart_dwell_s: f64,
}

impl Default for TargetConfig {
    fn default() -> Self {
        TargetConfig {
            track_id: None,
            near_point_m: None,
            near_point_radius_m: 1.0,
            both_sensors_window_s: 1.0,
            require_both_sensors: true,
            max_select_range_m: 4.0,
            max_select_bearing_rad: 0.6,
            lost_after_s: 1.0,
            min_leg_pairs: 1,
            min_leg_pairs_standing: 2,
            min_walked_m: 0.3,
            min_pair_share: 0.2,
            max_weak_share: 0.5,
            region_margin_m: 0.3,
            beside_s: 0.5,
            beside_distance_m: 0.45,
            encounter_distance_m: 1.0,
            encounter_max_s: 3.0,
            encounter_accel_mps2: 0.5,
            handover_margin: 4.0,
            handover_within_sigma: 3.0,
            handover_coast_s: 0.3,
            led_off_distance_m: 0.3,
            led_off_after_s: 0.5,
            restart_after_s: 10.0,
            restart_dwell_s: 3.0,
        }
    }
}

impl TargetConfig {
    /// Checks every field; says what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("near_point_radius_m", self.near_point_radius_m),
            ("both_sensors_window_s", self.both_sensors_window_s),
            ("max_select_range_m", self.max_select_range_m),
            ("max_select_bearing_rad", self.max_select_bearing_rad),
            ("lost_after_s", self.lost_after_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("target {name} must be > 0, got {v}"));
            }
        }
        for (name, v) in [
            ("min_walked_m", self.min_walked_m),
            ("region_margin_m", self.region_margin_m),
            ("beside_s", self.beside_s),
            ("beside_distance_m", self.beside_distance_m),
            ("min_pair_share", self.min_pair_share),
            ("max_weak_share", self.max_weak_share),
            ("encounter_distance_m", self.encounter_distance_m),
            ("encounter_max_s", self.encounter_max_s),
            ("encounter_accel_mps2", self.encounter_accel_mps2),
            ("handover_margin", self.handover_margin),
            ("handover_coast_s", self.handover_coast_s),
            ("handover_within_sigma", self.handover_within_sigma),
            ("led_off_distance_m", self.led_off_distance_m),
            ("led_off_after_s", self.led_off_after_s),
            ("restart_after_s", self.restart_after_s),
            ("restart_dwell_s", self.restart_dwell_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("target {name} must be >= 0, got {v}"));
            }
        }
        if let Some([x, y]) = self.near_point_m
            && !(x.is_finite() && y.is_finite())
        {
            return Err(format!(
                "target near_point_m must be finite, got [{x}, {y}]"
            ));
        }
        Ok(())
    }
}
