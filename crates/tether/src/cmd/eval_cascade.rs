//! `tether eval-cascade`: precision, recall and F1 of a Haar cascade against the boxes of
//! an `info.dat` annotation file (a detection matches a label at IoU >= 0.4, greedily,
//! best pair first).

use std::path::PathBuf;

use anyhow::Context;
use rayon::prelude::*;
use serde_json::json;
use tether_cascade::eval::{MATCH_IOU, evaluate};
use tether_cascade::info::{read_info, upper_part};
use tether_image::imread_gray;
use tether_vision::{Cascade, Detector};

/// Options of `tether eval-cascade`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Cascade XML file (OpenCV's traincascade or haartraining layout).
    #[arg(long, value_name = "FILE")]
    pub cascade: PathBuf,
    /// Annotation file in OpenCV's info.dat format (the labels).
    #[arg(long, value_name = "FILE")]
    pub info: PathBuf,
    /// Compare with the top FRAC of each labelled box (for an upper-body cascade).
    #[arg(long, value_name = "FRAC")]
    pub upper: Option<f64>,
    /// The cascade's search settings.
    #[command(flatten)]
    pub search: tether::args::DetectOptions,
    /// Threads (0: one per core); images are shared among them.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub threads: usize,
    /// Print JSON instead of a line of text.
    #[arg(long)]
    pub json: bool,
}

/// Detects in every annotated image and prints precision, recall and F1.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(u) = args.upper {
        anyhow::ensure!(
            u > 0.0 && u <= 1.0,
            "--upper must be in (0, 1], got {u} (0.4 keeps the top 40 % of each box)"
        );
    }
    let params = args.search.params()?;
    let cascade = Cascade::load(&args.cascade)?;
    let annotations = read_info(&args.info)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .context("cannot start the evaluation threads")?;
    let counts = pool.install(|| -> anyhow::Result<_> {
        let images = annotations
            .par_iter()
            .map(|a| {
                imread_gray(&a.image).with_context(|| {
                    format!(
                        "{} (line {} of {})",
                        a.image.display(),
                        a.line,
                        args.info.display()
                    )
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let labels: Vec<_> = annotations
            .iter()
            .map(|a| {
                a.boxes
                    .iter()
                    .map(|b| args.upper.map_or(*b, |u| upper_part(b, u)))
                    .collect::<Vec<_>>()
            })
            .collect();
        Ok(evaluate(
            &Detector::new(cascade),
            &images,
            &labels,
            &params,
        )?)
    })?;
    if args.json {
        let report = json!({
            "cascade": args.cascade.display().to_string(),
            "info": args.info.display().to_string(),
            "upper": args.upper,
            "scale_factor": params.scale_factor,
            "min_neighbors": params.min_neighbors,
            "match_iou": MATCH_IOU,
            "images": annotations.len(),
            "true_positives": counts.true_positives,
            "false_positives": counts.false_positives,
            "false_negatives": counts.false_negatives,
            "precision": counts.precision(),
            "recall": counts.recall(),
            "f1": counts.f1(),
        });
        tether::outln!("{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        tether::outln!(
            "{}: precision {:.3}, recall {:.3}, F1 {:.3} ({} true positives, {} false positives, \
             {} missed; {} images, scale factor {}, minNeighbors {}, match at IoU >= {MATCH_IOU})",
            args.cascade.display(),
            counts.precision(),
            counts.recall(),
            counts.f1(),
            counts.true_positives,
            counts.false_positives,
            counts.false_negatives,
            annotations.len(),
            params.scale_factor,
            params.min_neighbors
        )?;
    }
    Ok(())
}
