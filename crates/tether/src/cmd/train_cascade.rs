//! `tether train-cascade`: train a boosted Haar cascade (design 3.1, issue 8) from an
//! OpenCV `info.dat` annotation file and write OpenCV's cascade XML.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tether_cascade::train::{Event, Observer, StageReport, TrainConfig, TrainState, TrainingData};
use tether_cascade::{BoostType, FeatureMode, TrainError};

/// Boosting algorithm, as `opencv_traincascade -bt`.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum Boost {
    /// Gentle AdaBoost (OpenCV's GAB, the default).
    Gentle,
    /// Discrete AdaBoost (DAB).
    Discrete,
    /// Real AdaBoost (RAB).
    Real,
}

/// Feature pool, as `opencv_traincascade -mode`.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum Features {
    /// Upright edge, line and diagonal features (BASIC).
    Basic,
    /// All upright features (CORE).
    Core,
    /// Upright and 45-degree tilted features (ALL).
    All,
}

/// Options of `tether train-cascade`. Defaults: 12 stages, min hit rate 0.995, max false
/// alarm 0.5, Gentle AdaBoost with stumps, basic features, a window of the boxes' median
/// aspect and about 512 px^2 (16x32 for whole people, 25x20 for their top 40 %).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Annotation file in OpenCV's info.dat format (`path count x y w h ...`).
    #[arg(long, value_name = "FILE")]
    pub info: PathBuf,
    /// Use the top FRAC of each box (an upper-body detector from whole-person labels).
    #[arg(long, value_name = "FRAC")]
    pub upper: Option<f64>,
    /// Folder of background images (no object anywhere) to mine negatives from; repeatable.
    /// Negatives are also mined from the annotated images away from every labelled box.
    #[arg(long, value_name = "DIR")]
    pub bg: Vec<PathBuf>,
    /// Detection window, WxH px (default: from the boxes' aspect).
    #[arg(long, value_name = "WxH", value_parser = parse_window)]
    pub window: Option<[u32; 2]>,
    /// Number of stages.
    #[arg(long, default_value_t = 12, value_name = "N")]
    pub stages: usize,
    /// Share of the positives each stage must keep.
    #[arg(long, default_value_t = 0.995, value_name = "R")]
    pub min_hit_rate: f64,
    /// Largest share of the negatives a stage may accept.
    #[arg(long, default_value_t = 0.5, value_name = "F")]
    pub max_false_alarm: f64,
    /// Positives per stage (default: 90 % of those cut from the annotations).
    #[arg(long, value_name = "N")]
    pub num_pos: Option<usize>,
    /// Negatives per stage.
    #[arg(long, default_value_t = 3000, value_name = "N")]
    pub num_neg: usize,
    /// Boosting algorithm.
    #[arg(long, value_enum, default_value_t = Boost::Gentle)]
    pub boost: Boost,
    /// Feature pool.
    #[arg(long, value_enum, default_value_t = Features::Basic)]
    pub features: Features,
    /// Most weak classifiers per stage.
    #[arg(long, default_value_t = 100, value_name = "N")]
    pub max_weak_count: usize,
    /// Features valued per stage: a random subset of the pool (new each stage); 0: all.
    #[arg(long, default_value_t = 20_000, value_name = "N")]
    pub max_features: usize,
    /// Do not add mirrored copies of the positives.
    #[arg(long)]
    pub no_mirror: bool,
    /// Extra jittered copies of each positive (shifted up to 4 %, scaled up to 5 %).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub jitter: u32,
    /// A window of an annotated image is a negative only when its IoU with every
    /// labelled box is below this (0: when it touches no box).
    #[arg(long, default_value_t = 0.2, value_name = "IOU")]
    pub neg_max_overlap: f64,
    /// Scale factor of the pyramid negatives are mined from (the detector's).
    #[arg(long, default_value_t = 1.1, value_name = "F")]
    pub scale_factor: f64,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Threads (0: one per core).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub threads: usize,
    /// Training state, saved after every stage; a run finding it resumes (default:
    /// FILE.xml.state.json beside --out).
    #[arg(long, value_name = "FILE")]
    pub state: Option<PathBuf>,
    /// Per-stage report, Markdown (default: FILE.xml.report.md beside --out).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// The cascade, OpenCV XML.
    #[arg(long, value_name = "FILE.xml")]
    pub out: PathBuf,
}

fn parse_window(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WxH (e.g. 16x32)"))?;
    let side = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{s}` is not WxH with whole numbers (e.g. 16x32)"))
    };
    Ok([side(w)?, side(h)?])
}

fn beside(out: &Path, suffix: &str) -> PathBuf {
    let mut p = out.as_os_str().to_owned();
    p.push(suffix);
    PathBuf::from(p)
}

/// Progress bar and per-stage lines.
struct Cli {
    bar: ProgressBar,
    start: Instant,
    stage: Mutex<usize>,
    /// Set when stdout was closed by its reader: the training stops after the stage in
    /// progress (saved), instead of losing it.
    stdout_closed: AtomicBool,
}

impl Cli {
    /// A line above the progress bar (on stdout when there is no terminal to draw on).
    fn say(&self, line: String) {
        if self.bar.is_hidden() {
            if self.stdout_closed.load(Ordering::Relaxed) {
                return;
            }
            if let Err(e) = tether::outln!("{line}") {
                if !tether::output::is_stdout_closed(&e) {
                    tracing::warn!("{e:#}");
                }
                self.stdout_closed.store(true, Ordering::Relaxed);
            }
        } else {
            self.bar.println(line);
        }
    }
}

impl Observer for Cli {
    fn event(&self, event: &Event<'_>) {
        let stage = self.stage.lock().map(|s| *s).unwrap_or(0);
        match event {
            Event::Ready {
                window,
                positives,
                num_pos,
                positives_skipped,
                pool,
                mining_images,
                mining_windows,
            } => {
                self.say(format!(
                    "window {}x{}, {positives} positives ({num_pos} per stage, {positives_skipped} \
                     boxes too flat or too large left out), {pool} features in the pool, \
                     negatives mined from {mining_images} images ({mining_windows} windows)",
                    window[0], window[1]
                ));
                self.say(header());
            }
            Event::Resumed { stages } => self.say(format!(
                "resuming after {stages} stages from the saved state"
            )),
            Event::StageStarted { stage } => {
                if let Ok(mut s) = self.stage.lock() {
                    *s = *stage;
                }
            }
            Event::Mining {
                found,
                wanted,
                considered,
            } => {
                self.bar.set_length(*wanted as u64);
                self.bar.set_position(*found as u64);
                self.bar.set_message(format!(
                    "stage {stage}: mining negatives ({considered} windows looked at)"
                ));
            }
            Event::Features { done, total } => {
                self.bar.set_length(*total as u64);
                self.bar.set_position(*done as u64);
                self.bar
                    .set_message(format!("stage {stage}: valuing and sorting features"));
            }
            Event::Weak {
                count,
                hit_rate,
                false_alarm,
            } => {
                self.bar.set_length(100);
                self.bar.set_position((*count as u64).min(100));
                self.bar.set_message(format!(
                    "stage {stage}: {count} weak classifiers, hit rate {hit_rate:.4}, false alarm \
                     {false_alarm:.4}"
                ));
            }
            Event::StageDone(r) => self.say(row(r)),
            Event::Warning(w) => self.say(format!("warning: {w}")),
        }
    }

    fn now_secs(&self) -> Option<f64> {
        Some(self.start.elapsed().as_secs_f64())
    }

    fn stop_after_stage(&self) -> bool {
        self.stdout_closed.load(Ordering::Relaxed)
    }
}

fn header() -> String {
    "| stage | weak | hit rate | false alarm | acceptance ratio | pos | neg | pos dropped | time (s) |\n\
     |---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        .to_string()
}

fn row(r: &StageReport) -> String {
    format!(
        "| {} | {} | {:.4} | {:.4} | {:.3e} | {} | {} | {} | {} |",
        r.stage,
        r.weak_count,
        r.hit_rate,
        r.false_alarm,
        r.acceptance_ratio,
        r.positives,
        r.negatives,
        r.positives_dropped,
        r.seconds.map_or("-".into(), |s| format!("{s:.1}"))
    )
}

fn write_outputs(
    state: &TrainState,
    config: &TrainConfig,
    out: &Path,
    report: &Path,
    command: &str,
) -> anyhow::Result<()> {
    let xml = tether_cascade::xml::to_xml(&state.cascade, &config.stage_params());
    std::fs::write(out, xml).with_context(|| format!("cannot write {}", out.display()))?;
    let mut md = format!(
        "# Cascade training report\n\n`{command}`\n\nwindow {}x{}, {} stages\n\n{}\n",
        state.cascade.width,
        state.cascade.height,
        state.cascade.stages.len(),
        header()
    );
    for r in &state.reports {
        md.push_str(&row(r));
        md.push('\n');
    }
    let total: f64 = state.reports.iter().filter_map(|r| r.seconds).sum();
    md.push_str(&format!(
        "\ntotal {total:.1} s over the stages timed, overall acceptance ratio after the last \
         stage {:.3e}\n",
        state
            .reports
            .last()
            .map_or(1.0, |r| r.acceptance_ratio * r.false_alarm)
    ));
    std::fs::write(report, md).with_context(|| format!("cannot write {}", report.display()))?;
    Ok(())
}

/// Trains and writes the cascade.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = TrainConfig {
        window: args.window,
        upper: args.upper,
        stages: args.stages,
        min_hit_rate: args.min_hit_rate,
        max_false_alarm: args.max_false_alarm,
        num_pos: args.num_pos,
        num_neg: args.num_neg,
        boost: match args.boost {
            Boost::Gentle => BoostType::Gentle,
            Boost::Discrete => BoostType::Discrete,
            Boost::Real => BoostType::Real,
        },
        mode: match args.features {
            Features::Basic => FeatureMode::Basic,
            Features::Core => FeatureMode::Core,
            Features::All => FeatureMode::All,
        },
        max_weak_count: args.max_weak_count,
        max_features: args.max_features,
        mirror: !args.no_mirror,
        jitter: args.jitter,
        neg_max_overlap: args.neg_max_overlap,
        scale_factor: args.scale_factor,
        seed: args.seed,
    };
    let state_path = args
        .state
        .clone()
        .unwrap_or_else(|| beside(&args.out, ".state.json"));
    let report_path = args
        .report
        .clone()
        .unwrap_or_else(|| beside(&args.out, ".report.md"));
    let command = std::iter::once("tether".to_string())
        .chain(std::env::args().skip(1))
        .collect::<Vec<_>>()
        .join(" ");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .context("cannot start the training threads")?;
    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let cli = Cli {
        bar,
        start: Instant::now(),
        stage: Mutex::new(0),
        stdout_closed: AtomicBool::new(false),
    };
    let result = pool.install(|| -> Result<TrainState, TrainError> {
        let data = TrainingData::load(&args.info, &args.bg)?;
        tether_cascade::train(&data, &config, Some(&state_path), &cli)
    });
    cli.bar.finish_and_clear();
    match result {
        Ok(state) => {
            write_outputs(&state, &config, &args.out, &report_path, &command)?;
            tether::outln!(
                "wrote {} ({} stages, {} weak classifiers) in {:.1} s; report {}, state {}",
                args.out.display(),
                state.cascade.stages.len(),
                state.cascade.weak_count(),
                cli.start.elapsed().as_secs_f64(),
                report_path.display(),
                state_path.display()
            )?;
            Ok(())
        }
        Err(e @ TrainError::NegativesExhausted { trained, .. }) if trained > 0 => {
            // Keep what was trained: the saved state holds the finished stages.
            let partial = TrainState::load(&state_path)?;
            write_outputs(&partial, &config, &args.out, &report_path, &command)?;
            Err(anyhow::Error::new(e).context(format!(
                "the cascade of the {trained} stages trained so far was written to {}",
                args.out.display()
            )))
        }
        Err(TrainError::Stopped { trained }) => {
            tracing::warn!(
                "standard output was closed: the training stopped after stage {trained}, saved \
                 in {}; the same command resumes from it",
                state_path.display()
            );
            Err(tether::output::StdoutClosed.into())
        }
        Err(e) => Err(e.into()),
    }
}
