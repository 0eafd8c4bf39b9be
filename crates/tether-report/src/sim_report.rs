//! `report.html`: one self-contained page (inline SVG, no scripts, no network) with,
//! per scenario, a top-down map of the true and estimated paths of target and robot,
//! the laser, vision and fused estimates with their covariance ellipses at a few
//! instants (the paper's Fig. 14), distance and bearing to the target over time (Fig.
//! 15) against the comfort band, the commands, and the measures; magnified views of
//! the target's estimates at a few instants show what fusion buys ([`insets`]).
//!
//! The page opens with a navigation to every run and the summary of their measures,
//! each measure explained under it ([`table::definitions`]). A run driven by the laser
//! alone is named so: its row says "laser only", its RMSE stands under "laser only",
//! and its section says that there is no fusion to magnify.
//!
//! The pictures fit the page: a map's scale is chosen so that it is at most
//! [`MAP_MAX_WIDTH_PX`] wide (the page's width) and its map at most
//! [`MAP_MAX_HEIGHT_PX`] high, and every picture shrinks with a narrower window. No
//! text of a picture overlaps another (the browser test measures them all).

use std::fmt::Write as _;

use tether_live::target_log::TargetLog;
use tether_sim::Scenario;
use tether_svg::xml_escape;

use tether_eval::closed_loop::RunLog;
use tether_eval::metrics::RunMetrics;

pub mod insets;
pub mod map;
pub mod plots;
pub mod table;
pub mod target;

pub use map::run_map;
pub use plots::{plots_html, run_plots};
pub use table::{Driver, Row, definitions, metrics_table};
pub use target::target_html;

/// Widest map, px: within the page's 1,100 px.
pub const MAP_MAX_WIDTH_PX: f64 = 1040.0;
/// Highest map (without its title and legend), px.
pub const MAP_MAX_HEIGHT_PX: f64 = 720.0;
/// A map's largest scale, px per m.
const MAP_MAX_PX_PER_M: f64 = 50.0;

/// One scenario's material for the report.
pub struct ScenarioRun<'a> {
    /// The scenario.
    pub scenario: &'a Scenario,
    /// The run.
    pub log: &'a RunLog,
    /// Its measures.
    pub metrics: &'a RunMetrics,
}

impl ScenarioRun<'_> {
    /// Whose estimate drove the robot.
    pub fn driver(&self) -> Driver {
        Driver::of(self.scenario)
    }

    /// Its row of the table of measures, linked to its section.
    pub fn row(&self) -> Row<'_> {
        Row {
            name: self.scenario.name.clone(),
            anchor: Some(self.scenario.name.clone()),
            driver: self.driver(),
            metrics: self.metrics,
        }
    }
}

/// A section of the page after the scenarios' (the printed controller's run, say).
#[derive(Debug, Clone)]
pub struct Extra<'a> {
    /// Its id, which the navigation links to.
    pub id: String,
    /// Its heading.
    pub title: String,
    /// Its HTML.
    pub body: String,
    /// Its run's row in the summary, when it is about a run.
    pub row: Option<Row<'a>>,
}

const LASER: &str = "#1f77b4";
const VISION: &str = "#2ca02c";
const FUSED: &str = "#9467bd";
const ESTIMATE: &str = "#ff7f0e";

/// A line under a run's table pointing to the definitions under the summary.
fn see_definitions() -> String {
    format!(
        "<p class=\"note\">The measures are explained under the <a href=\"#{}\">summary</a>.</p>\n",
        table::MEASURES_ID
    )
}

/// A scenario's section.
pub fn scenario_section(run: &ScenarioRun<'_>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<section id=\"{0}\"><h2>{0}</h2><p>{1}</p>",
        xml_escape(&run.scenario.name),
        xml_escape(&run.scenario.description)
    );
    let _ = writeln!(
        s,
        "<div class=\"figure\">{}</div>",
        run_map(run.scenario, run.log)
    );
    s.push_str(&insets::html(
        &run.scenario.name,
        &insets::insets(run.log),
        run.driver() == Driver::LaserOnly,
    ));
    s.push_str(&plots_html(run.log));
    s.push_str(&metrics_table(&[run.row()]));
    s.push_str(&see_definitions());
    let mut target = TargetLog::new();
    for step in &run.log.steps {
        if let Some(tick) = &step.tick {
            target.record_tick(tick);
        }
    }
    let _ = writeln!(
        s,
        "<h3>Target: locks, losses and why</h3>{}",
        target_html(&target, target.counts_from_events())
    );
    s.push_str("</section>\n");
    s
}

/// The whole page: the navigation to every run and section, the summary of every
/// run's measures with their definitions, each scenario's section, then the `extra`
/// sections.
pub fn html(
    title: &str,
    intro_html: &str,
    runs: &[ScenarioRun<'_>],
    extra: &[Extra<'_>],
) -> String {
    let mut s = page_head(title);
    let _ = writeln!(s, "<h1>{}</h1>{intro_html}", xml_escape(title));
    s.push_str("<nav>");
    for r in runs {
        let _ = write!(s, "<a href=\"#{0}\">{0}</a>", xml_escape(&r.scenario.name));
    }
    for e in extra {
        let _ = write!(
            s,
            "<a href=\"#{}\">{}</a>",
            xml_escape(&e.id),
            xml_escape(&e.title)
        );
    }
    s.push_str("</nav>\n<h2 id=\"summary\">Summary</h2>\n");
    let rows: Vec<Row<'_>> = runs
        .iter()
        .map(ScenarioRun::row)
        .chain(extra.iter().filter_map(|e| e.row.clone()))
        .collect();
    s.push_str(&metrics_table(&rows));
    s.push_str(&definitions());
    for r in runs {
        s.push_str(&scenario_section(r));
    }
    for e in extra {
        let _ = writeln!(
            s,
            "<section id=\"{}\"><h2>{}</h2>{}</section>",
            xml_escape(&e.id),
            xml_escape(&e.title),
            e.body
        );
    }
    s.push_str("</body></html>\n");
    s
}

/// A page of plain sections (title, HTML), in the report's style.
pub fn simple_page(title: &str, intro_html: &str, sections: &[(String, String)]) -> String {
    let mut s = page_head(title);
    let _ = writeln!(s, "<h1>{}</h1>{intro_html}", xml_escape(title));
    for (t, body) in sections {
        let _ = writeln!(s, "<section><h2>{}</h2>{body}</section>", xml_escape(t));
    }
    s.push_str("</body></html>\n");
    s
}

/// The document head with the report's style, and the opening `body` tag.
fn page_head(title: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\n<style>\n\
         body {{ font-family: sans-serif; margin: 24px auto; max-width: 1100px; color: #222; }}\n\
         table {{ border-collapse: collapse; margin: 12px 0; font-size: 13px; }}\n\
         th, td {{ border: 1px solid #ccc; padding: 3px 7px; text-align: right; }}\n\
         th {{ background: #f3f3f3; }} td:first-child {{ text-align: left; }}\n\
         .table-wrap {{ overflow-x: auto; }} table.measures th {{ text-align: center; }}\n\
         dl.measures {{ font-size: 13px; display: grid; grid-template-columns: max-content 1fr; \
         gap: 3px 12px; max-width: 1000px; }}\n\
         dl.measures dt {{ font-weight: bold; }} dl.measures dd {{ margin: 0; }}\n\
         .figure {{ margin: 10px 0; overflow-x: auto; }} nav a {{ margin-right: 12px; }}\n\
         .insets {{ display: flex; flex-wrap: wrap; gap: 14px; margin: 10px 0; }}\n\
         figure.inset {{ margin: 0; max-width: 320px; font-size: 13px; }}\n\
         section {{ border-top: 1px solid #ddd; margin-top: 28px; }}\n</style></head><body>",
        xml_escape(title)
    );
    s
}
