//! The table of measures, one row per run, and what each of its columns means.

use std::fmt::Write as _;

use tether_sim::Scenario;
use tether_svg::xml_escape;

use tether_eval::metrics::{BAND_M, MATCH_M, RunMetrics};

/// Whose estimate of the target drove the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Driver {
    /// The fused pipeline (laser and camera); laser-only and vision-only pipelines
    /// ride along on the same data.
    Fused,
    /// The laser alone: the camera is off, nothing rides along.
    LaserOnly,
}

impl Driver {
    /// The driver of a run of `scenario`: the laser alone when its camera is off.
    pub fn of(scenario: &Scenario) -> Driver {
        if scenario.camera_sim.enabled {
            Driver::Fused
        } else {
            Driver::LaserOnly
        }
    }

    /// The RMSE of the run's fused, laser-only and camera-only estimates, m: a
    /// laser-only run's driving estimate (its `rmse_fused_m`) is the laser's, with no
    /// fusion and no camera.
    pub fn rmse_columns(self, m: &RunMetrics) -> [Option<f64>; 3] {
        match self {
            Driver::Fused => [m.rmse_fused_m, m.rmse_laser_m, m.rmse_vision_m],
            Driver::LaserOnly => [None, m.rmse_fused_m, None],
        }
    }

    /// As the table says it.
    pub fn text(self) -> &'static str {
        match self {
            Driver::Fused => "fused",
            Driver::LaserOnly => "laser only",
        }
    }
}

/// One row of the table.
#[derive(Debug, Clone)]
pub struct Row<'a> {
    /// The run's name.
    pub name: String,
    /// The id of the run's section, which the name links to.
    pub anchor: Option<String>,
    /// Whose estimate drove the robot.
    pub driver: Driver,
    /// The measures.
    pub metrics: &'a RunMetrics,
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.filter(|x| x.is_finite())
        .map_or("–".to_owned(), |x| format!("{x:.digits$}"))
}

/// The id of the definitions under the summary.
pub const MEASURES_ID: &str = "measures";

/// The table of measures, one row per run. The RMSE of a run's driving estimate
/// stands under what it is: fused, or laser only when the laser alone drove.
pub fn metrics_table(rows: &[Row<'_>]) -> String {
    let mut s = String::from(
        "<div class=\"table-wrap\"><table class=\"measures\"><tr><th rowspan=\"2\">run</th>\
         <th rowspan=\"2\">driven by</th><th rowspan=\"2\">seed</th>\
         <th rowspan=\"2\">mean |d−d0| (m)</th><th rowspan=\"2\">RMS d−d0 (m)</th>\
         <th rowspan=\"2\">min d (m)</th><th rowspan=\"2\">in band</th>\
         <th rowspan=\"2\">target lost (s)</th><th rowspan=\"2\">swaps</th>\
         <th rowspan=\"2\">collisions</th><th colspan=\"3\">RMSE of the target (m)</th>\
         <th rowspan=\"2\">NEES</th><th rowspan=\"2\">MOTA</th><th rowspan=\"2\">MOTP (m)</th>\
         <th rowspan=\"2\">ID switches</th><th rowspan=\"2\">RMS jerk (m/s³)</th></tr>\n\
         <tr><th>fused</th><th>laser only</th><th>vision only</th></tr>\n",
    );
    for row in rows {
        let m = row.metrics;
        let name = match &row.anchor {
            Some(id) => format!(
                "<a href=\"#{}\">{}</a>",
                xml_escape(id),
                xml_escape(&row.name)
            ),
            None => xml_escape(&row.name),
        };
        let [fused, laser, vision] = row.driver.rmse_columns(m);
        let _ = writeln!(
            s,
            "<tr><td>{name}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td>\
             <td>{}</td><td>{:.1}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td><td>{:.1}</td></tr>",
            row.driver.text(),
            m.seed,
            fmt_opt(m.mean_abs_distance_error_m, 3),
            fmt_opt(m.rms_distance_error_m, 3),
            m.min_distance_m,
            m.time_in_band_frac
                .map_or("–".to_owned(), |f| format!("{:.0} %", 100.0 * f)),
            m.target_lost_s,
            m.target_swaps,
            m.collisions,
            fmt_opt(fused, 3),
            fmt_opt(laser, 3),
            fmt_opt(vision, 3),
            fmt_opt(m.nees_mean, 2),
            m.mota,
            m.motp_m,
            m.id_switches,
            m.rms_jerk
        );
    }
    s.push_str("</table></div>\n");
    s
}

/// What each column of [`metrics_table`] means, as a definitions list.
pub fn definitions() -> String {
    let (near, far) = (1.0 - BAND_M.0, BAND_M.1 - 1.0);
    let terms: [(&str, String); 16] = [
        (
            "run",
            "the scenario, linked to its section; <code>-laser-only</code>: the same \
             scenario with the camera off."
                .to_owned(),
        ),
        (
            "driven by",
            "whose estimate of the target the robot followed: <i>fused</i> (laser and \
             camera, with laser-only and vision-only pipelines riding along on the same \
             data for comparison) or <i>laser only</i> (the camera off, nothing riding \
             along)."
                .to_owned(),
        ),
        (
            "seed",
            "the seed of the simulated world: the same seed, the same run.".to_owned(),
        ),
        (
            "d, d0",
            "d is the distance from the spring's attachment point (a little ahead of the \
             wheel axle) to the true target; d0 the follow distance the controller aims \
             for."
                .to_owned(),
        ),
        (
            "mean |d−d0|, RMS d−d0",
            "the mean absolute and the root mean square following error, over the time \
             after the target was first locked, m."
                .to_owned(),
        ),
        ("min d", "the smallest d of the run, m.".to_owned()),
        (
            "in band",
            format!(
                "the share of the time after the first lock with d in the comfort band, \
                 from d0 − {near:.1} m to d0 + {far:.1} m."
            ),
        ),
        (
            "target lost",
            "the time after the first lock without a locked target, s.".to_owned(),
        ),
        (
            "swaps",
            "how often the followed estimate moved from the true target to someone else."
                .to_owned(),
        ),
        (
            "collisions",
            "contacts of the robot with walls or furniture.".to_owned(),
        ),
        (
            "RMSE of the target",
            "the root mean square distance between an estimate of the target and its true \
             position, over the scans with a locked estimate, m: of the fused pipeline, of \
             the laser-only and of the vision-only one. In a laser-only run the laser's \
             pipeline drives and its RMSE stands under <i>laser only</i>; with the camera \
             off there is no fused and no vision-only estimate (–)."
                .to_owned(),
        ),
        (
            "NEES",
            "normalised estimation error squared of the estimate that drove the robot: the \
             error weighed by the estimate's own covariance (eᵀP⁻¹e), averaged over the \
             scans. An honest 2-D estimate averages 2; below 2 its ellipses are larger than \
             its errors need (cautious), above 2 smaller (overconfident)."
                .to_owned(),
        ),
        (
            "MOTA",
            format!(
                "multiple object tracking accuracy (CLEAR MOT) of all confirmed tracks \
                 against the people the laser sees, matched within {MATCH_M} m: 1 − (misses \
                 + false tracks + ID switches) / (people in view, counted in every scan). 1 \
                 is perfect. It is <b>negative</b> when the errors outnumber the people in \
                 view: with one or two people in view, a confirmed track on clutter (a \
                 pillar, a bush, a bin) or on a person the laser cannot see counts one false \
                 track in every scan it lasts, and such tracks can add up to more errors than \
                 there were people to see. It measures every track, not the following: a run \
                 can follow its target throughout with a negative MOTA."
            ),
        ),
        (
            "MOTP",
            "multiple object tracking precision: the mean distance between the matched \
             tracks and their people, m."
                .to_owned(),
        ),
        (
            "ID switches",
            "how often a person's matched track changed its id (a track lost and born \
             again, or two people's tracks exchanged)."
                .to_owned(),
        ),
        (
            "RMS jerk",
            "the root mean square jerk (the rate of change of acceleration) of the \
             commanded forward speed, from its second difference over the control period, \
             m/s³: lower is smoother."
                .to_owned(),
        ),
    ];
    let mut s = format!("<dl class=\"measures\" id=\"{MEASURES_ID}\">");
    for (term, text) in terms {
        let _ = write!(s, "<dt>{}</dt><dd>{text}</dd>", xml_escape(term));
    }
    s.push_str("</dl>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(name: &str) -> RunMetrics {
        RunMetrics {
            scenario: name.to_owned(),
            seed: 1,
            rmse_fused_m: Some(0.028),
            rmse_laser_m: None,
            rmse_vision_m: None,
            rmse_common_m: None,
            common_scans: 0,
            nees_mean: Some(0.4),
            mota: -0.3,
            motp_m: 0.03,
            id_switches: 1,
            target_swaps: 0,
            mean_abs_distance_error_m: Some(0.1),
            rms_distance_error_m: Some(0.2),
            min_distance_m: 0.8,
            time_in_band_frac: Some(0.9),
            target_lost_s: 0.0,
            collisions: 0,
            rms_jerk: 6.0,
            rms_angular_jerk: 1.0,
            first_lock_s: Some(1.0),
            rmse_per_frame_fused_m: None,
            nees_per_frame_fused: None,
        }
    }

    #[test]
    fn a_laser_only_rows_rmse_stands_under_laser_only() {
        let m = metrics("corridor-laser-only");
        let table = metrics_table(&[Row {
            name: m.scenario.clone(),
            anchor: Some(m.scenario.clone()),
            driver: Driver::LaserOnly,
            metrics: &m,
        }]);
        assert!(
            table.contains("<td>laser only</td>")
                && table.contains("<td>–</td><td>0.028</td><td>–</td>"),
            "{table}"
        );
        let fused = metrics("corridor");
        let table = metrics_table(&[Row {
            name: "corridor".to_owned(),
            anchor: None,
            driver: Driver::Fused,
            metrics: &fused,
        }]);
        assert!(
            table.contains("<td>0.028</td><td>–</td><td>–</td>"),
            "{table}"
        );
    }

    #[test]
    fn every_column_is_defined() {
        let table = metrics_table(&[]);
        let dl = definitions();
        for term in [
            "driven by",
            "seed",
            "min d",
            "in band",
            "target lost",
            "swaps",
            "collisions",
            "RMSE",
            "NEES",
            "MOTA",
            "MOTP",
            "ID switches",
            "RMS jerk",
        ] {
            assert!(table.contains(term), "{term} is no column");
            assert!(dl.contains(&format!("<dt>{term}")), "{term} undefined");
        }
        assert!(dl.contains("<b>negative</b>"));
    }
}
