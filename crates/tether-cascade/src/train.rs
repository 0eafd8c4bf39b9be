//! The cascade trainer (design 3.1; `opencv_traincascade`'s algorithm, Viola and Jones
//! 2001 with Lienhart and Maydt's features):
//!
//! 1. Positives are cut from the annotated images: each labelled box (its top `upper`
//!    share for an upper-body detector) is widened or heightened to the window's aspect
//!    about its centre, resized to the window (OpenCV's bilinear rule), optionally
//!    mirrored and jittered. Windows too flat for the detector (grey-level standard
//!    deviation 10 or less) are left out: they can never be found.
//! 2. For each stage: the positives the cascade so far still accepts (the first
//!    `num_pos` of them; rejected ones are dropped for good), and `num_neg` negatives mined
//!    with the cascade so far ([`crate::mining`]) from background images and from the
//!    annotated images away from every labelled box.
//! 3. Every feature of the stage's pool (all of them, or a seeded random subset of
//!    `max_features`) is valued on every sample and sorted once; boosting adds stumps until
//!    the stage's false-alarm rate reaches `max_false_alarm` at the threshold that keeps
//!    `min_hit_rate` of the positives ([`crate::boost`]).
//! 4. The state (configuration and stages so far) is saved after every stage; a run that
//!    finds a matching state resumes after its last stage, and gives the same cascade as an
//!    uninterrupted run (every random choice is seeded by the stage). Only `stages` may
//!    differ between the two runs, so a trained cascade can also be extended.

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tether_core::GrayImage;
use tether_image::{ImreadError, imread_gray};
use tether_vision::Rect;
use tether_vision::resize::resize_linear;
use thiserror::Error;

use crate::boost::{BoostType, MAX_SAMPLES, SortedValues, StageParams, train_stage};
use crate::features::{Feature, FeatureMode, enumerate};
use crate::info::{Annotation, InfoError, read_info, upper_part};
use crate::mining::{Miner, Source};
use crate::model::{CascadeModel, CompiledCascade};
use crate::rng::SplitMix;
use crate::sample::{SampleSet, mirrored};

/// The window area the automatic window size aims at, px^2 (OpenCV's pretrained
/// full-body cascade is 14x28 = 392, the upper-body one 22x18 = 396).
pub const AUTO_WINDOW_AREA_PX2: f64 = 512.0;

/// Version of the saved state's layout.
pub const STATE_VERSION: u32 = 1;

/// Training options. [`TrainConfig::default`] gives the documented defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// Window `[width, height]`, px; `None`: the boxes' median aspect with an area of
    /// about [`AUTO_WINDOW_AREA_PX2`] (see [`auto_window`]).
    pub window: Option<[u32; 2]>,
    /// Use the top share of each labelled box (an upper-body detector from whole-person
    /// labels); `None`: the whole box. Default `None`.
    pub upper: Option<f64>,
    /// Number of stages. Default 12.
    pub stages: usize,
    /// Share of the positives each stage must accept. Default 0.995.
    pub min_hit_rate: f64,
    /// Largest share of the negatives a stage may accept. Default 0.5.
    pub max_false_alarm: f64,
    /// Positives per stage; `None`: 90 % of the positives available (leaving room for
    /// the ones the stages reject). Default `None`.
    pub num_pos: Option<usize>,
    /// Negatives per stage. Default 3000 (the paper's).
    pub num_neg: usize,
    /// Boosting algorithm. Default Gentle AdaBoost.
    pub boost: BoostType,
    /// Feature pool. Default [`FeatureMode::Basic`].
    pub mode: FeatureMode,
    /// Most stumps per stage. Default 100 (OpenCV's).
    pub max_weak_count: usize,
    /// Features valued per stage: a seeded random subset of the pool of this size (a new
    /// one each stage); 0: the whole pool. Default 20,000.
    pub max_features: usize,
    /// Add each box mirrored left-right. Default true.
    pub mirror: bool,
    /// Extra jittered copies of each box (shifted by up to 4 % of the window, scaled by
    /// up to 5 %, as the detector's 2-px step and 1.1 scale factor see people). Default 0.
    pub jitter: u32,
    /// A window of an annotated image is a negative only when its intersection over union
    /// with every labelled box is below this (0: when it touches none). Default 0.2.
    pub neg_max_overlap: f64,
    /// Scale factor of the mining pyramid (the detector's `scaleFactor`). Default 1.1.
    pub scale_factor: f64,
    /// Seed of every random choice. Default 1.
    pub seed: u64,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            window: None,
            upper: None,
            stages: 12,
            min_hit_rate: 0.995,
            max_false_alarm: 0.5,
            num_pos: None,
            num_neg: 3000,
            boost: BoostType::Gentle,
            mode: FeatureMode::Basic,
            max_weak_count: 100,
            max_features: 20_000,
            mirror: true,
            jitter: 0,
            neg_max_overlap: 0.2,
            scale_factor: 1.1,
            seed: 1,
        }
    }
}

impl TrainConfig {
    /// What each stage must achieve.
    pub fn stage_params(&self) -> StageParams {
        StageParams {
            boost: self.boost,
            min_hit_rate: self.min_hit_rate,
            max_false_alarm: self.max_false_alarm,
            max_weak_count: self.max_weak_count,
        }
    }

    fn check(&self) -> Result<(), TrainError> {
        let bad = |what: String| Err(TrainError::BadOption(what));
        if self.stages == 0 {
            return bad("--stages must be at least 1".into());
        }
        if !(self.min_hit_rate > 0.0 && self.min_hit_rate <= 1.0) {
            return bad(format!(
                "--min-hit-rate must be in (0, 1], got {} (OpenCV's default is 0.995)",
                self.min_hit_rate
            ));
        }
        if !(self.max_false_alarm > 0.0 && self.max_false_alarm < 1.0) {
            return bad(format!(
                "--max-false-alarm must be in (0, 1), got {} (OpenCV's default is 0.5)",
                self.max_false_alarm
            ));
        }
        if let Some(u) = self.upper
            && !(u > 0.0 && u <= 1.0)
        {
            return bad(format!(
                "--upper must be in (0, 1], got {u} (0.4 keeps the top 40 % of each box)"
            ));
        }
        if self.num_neg == 0 || self.num_pos == Some(0) {
            return bad("--num-pos and --num-neg must be at least 1".into());
        }
        if self.max_weak_count == 0 {
            return bad("--max-weak-count must be at least 1".into());
        }
        if !(self.neg_max_overlap >= 0.0 && self.neg_max_overlap <= 1.0) {
            return bad(format!(
                "--neg-max-overlap must be in [0, 1], got {}",
                self.neg_max_overlap
            ));
        }
        if !(self.scale_factor.is_finite() && self.scale_factor > 1.0) {
            return bad(format!(
                "--scale-factor must be above 1, got {}",
                self.scale_factor
            ));
        }
        Ok(())
    }
}

/// Why training cannot run or could not finish.
#[derive(Debug, Error)]
pub enum TrainError {
    /// The annotation file.
    #[error(transparent)]
    Info(#[from] InfoError),
    /// An image could not be read.
    #[error("{image} (listed at {info}:{line}) cannot be used")]
    Image {
        /// The image.
        image: PathBuf,
        /// The annotation file.
        info: PathBuf,
        /// Its line.
        line: usize,
        /// Why.
        #[source]
        source: ImreadError,
    },
    /// A background image or folder could not be read.
    #[error("background {path}: {why}")]
    Background {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// A labelled box is not inside its image.
    #[error(
        "{info}:{line}: box {x} {y} {w} {h} is not inside {image} ({width}x{height}); fix or \
         remove the box (boxes must satisfy 0 <= x, 0 <= y, x + w <= width, y + h <= height)"
    )]
    BoxOutside {
        /// The annotation file.
        info: PathBuf,
        /// Its line.
        line: usize,
        /// The image.
        image: PathBuf,
        /// Image width, px.
        width: usize,
        /// Image height, px.
        height: usize,
        /// The box.
        x: i32,
        /// The box.
        y: i32,
        /// The box.
        w: i32,
        /// The box.
        h: i32,
    },
    /// An option is out of range.
    #[error("{0}")]
    BadOption(String),
    /// No Haar feature fits the window.
    #[error(
        "a {width}x{height} window is too small: no Haar feature fits (the detector's variance \
         window also needs 3 px per side); use --window with sides of at least 4 px, e.g. 16x32"
    )]
    WindowTooSmall {
        /// Window width, px.
        width: u32,
        /// Window height, px.
        height: u32,
    },
    /// Fewer positives than asked for.
    #[error(
        "{asked} positives asked for (--num-pos) but only {available} could be cut from the \
         annotations ({boxes} boxes{mirror}); lower --num-pos (about 90 % of the available \
         ones leaves room for those the stages reject), add --jitter N or label more boxes"
    )]
    TooFewPositives {
        /// Asked for.
        asked: usize,
        /// Available.
        available: usize,
        /// Labelled boxes.
        boxes: usize,
        /// ", mirrored" when mirroring is on.
        mirror: &'static str,
    },
    /// A stage would hold more samples than the trainer indexes.
    #[error("--num-pos + --num-neg is {0}, above the {MAX_SAMPLES} samples a stage can hold")]
    TooManySamples(usize),
    /// The images hold too few windows the cascade still accepts.
    #[error(
        "negatives exhausted at stage {stage}: only {found} of the {wanted} negatives wanted \
         are left among the {considered} candidate windows of the {images} images (the cascade \
         of {trained} stages already rejects the rest); add background images without the \
         object (--bg DIR), lower --num-neg, or train fewer stages"
    )]
    NegativesExhausted {
        /// 1-based stage that could not be trained.
        stage: usize,
        /// Negatives found.
        found: usize,
        /// Negatives wanted.
        wanted: usize,
        /// Windows considered.
        considered: u64,
        /// Images mined.
        images: usize,
        /// Stages trained before.
        trained: usize,
    },
    /// The state file could not be read or written.
    #[error("training state {path}: {why}")]
    State {
        /// The file.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// The state file belongs to another training.
    #[error(
        "training state {path} was saved by a run with other inputs or options ({what}); \
         delete it to start over, or rerun with the same options to resume"
    )]
    StateMismatch {
        /// The file.
        path: PathBuf,
        /// What differs.
        what: String,
    },
    /// The mining pyramid could not be built.
    #[error(transparent)]
    Detect(#[from] tether_vision::DetectError),
    /// The observer asked to stop ([`Observer::stop_after_stage`]); the finished stages
    /// are in the saved state, from which the same training resumes.
    #[error("training stopped after stage {trained} at the caller's request")]
    Stopped {
        /// Stages trained (and saved) so far.
        trained: usize,
    },
}

/// The annotated images and background images of a training.
#[derive(Debug, Clone)]
pub struct TrainingData {
    /// The annotation file.
    pub info: PathBuf,
    /// Its lines.
    pub annotations: Vec<Annotation>,
    /// The annotated images, in the same order.
    pub frames: Vec<GrayImage>,
    /// The background folders.
    pub bg_dirs: Vec<PathBuf>,
    /// Background images (no object anywhere).
    pub backgrounds: Vec<GrayImage>,
}

/// Image files of a background folder: PNG and JPEG, sorted by name.
fn background_files(dir: &Path) -> Result<Vec<PathBuf>, TrainError> {
    let entries = std::fs::read_dir(dir).map_err(|e| TrainError::Background {
        path: dir.to_path_buf(),
        why: format!("cannot list the folder ({e})"),
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .map(str::to_ascii_lowercase)
                    .is_some_and(|e| matches!(e.as_str(), "png" | "jpg" | "jpeg"))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(TrainError::Background {
            path: dir.to_path_buf(),
            why: "the folder holds no PNG or JPEG image".into(),
        });
    }
    Ok(files)
}

impl TrainingData {
    /// Reads the annotation file, its images and the background folders' images, and
    /// checks that every box is inside its image.
    pub fn load(info: &Path, bg_dirs: &[PathBuf]) -> Result<TrainingData, TrainError> {
        let annotations = read_info(info)?;
        let frames: Vec<GrayImage> = annotations
            .par_iter()
            .map(|a| {
                imread_gray(&a.image).map_err(|source| TrainError::Image {
                    image: a.image.clone(),
                    info: info.to_path_buf(),
                    line: a.line,
                    source,
                })
            })
            .collect::<Result<_, _>>()?;
        for (a, f) in annotations.iter().zip(&frames) {
            let (iw, ih) = (f.width() as i64, f.height() as i64);
            for b in &a.boxes {
                let (x, y, w, h) = (
                    i64::from(b.x),
                    i64::from(b.y),
                    i64::from(b.width),
                    i64::from(b.height),
                );
                if x < 0 || y < 0 || x + w > iw || y + h > ih {
                    return Err(TrainError::BoxOutside {
                        info: info.to_path_buf(),
                        line: a.line,
                        image: a.image.clone(),
                        width: f.width(),
                        height: f.height(),
                        x: b.x,
                        y: b.y,
                        w: b.width,
                        h: b.height,
                    });
                }
            }
        }
        let mut bg_files = Vec::new();
        for d in bg_dirs {
            bg_files.extend(background_files(d)?);
        }
        let backgrounds = bg_files
            .par_iter()
            .map(|p| {
                imread_gray(p).map_err(|e| TrainError::Background {
                    path: p.clone(),
                    why: e.to_string(),
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(TrainingData {
            info: info.to_path_buf(),
            annotations,
            frames,
            bg_dirs: bg_dirs.to_vec(),
            backgrounds,
        })
    }

    /// The training boxes: the labelled boxes, or their top `upper` share.
    pub fn boxes(&self, upper: Option<f64>) -> Vec<Vec<Rect>> {
        self.annotations
            .iter()
            .map(|a| {
                a.boxes
                    .iter()
                    .map(|b| upper.map_or(*b, |u| upper_part(b, u)))
                    .collect()
            })
            .collect()
    }
}

/// The automatic window: the median aspect of the boxes, sized to an area of about
/// [`AUTO_WINDOW_AREA_PX2`] (full-body boxes of aspect 1:2 give 16x32; their top 40 %,
/// aspect 5:4, gives 25x20).
pub fn auto_window(boxes: &[Rect]) -> [u32; 2] {
    let mut aspects: Vec<f64> = boxes
        .iter()
        .map(|b| f64::from(b.width) / f64::from(b.height))
        .collect();
    aspects.sort_unstable_by(f64::total_cmp);
    let aspect = aspects.get(aspects.len() / 2).copied().unwrap_or(1.0);
    let h = (AUTO_WINDOW_AREA_PX2 / aspect).sqrt().round().max(4.0);
    let w = (h * aspect).round().max(4.0);
    [w as u32, h as u32]
}

/// The window-aspect box around a labelled box: same height and centre when the box is
/// narrower than the window's aspect, else same width; `scale` and `(dx, dy)` (shares of
/// the size) jitter it. Shifted inside the image; `None` when larger than the image.
fn fit_box(
    b: &Rect,
    window: [u32; 2],
    scale: f64,
    shift: (f64, f64),
    image: (usize, usize),
) -> Option<Rect> {
    let aspect = f64::from(window[0]) / f64::from(window[1]);
    let (bw, bh) = (f64::from(b.width), f64::from(b.height));
    let (mut w, mut h) = if bw / bh <= aspect {
        (bh * aspect, bh)
    } else {
        (bw, bw / aspect)
    };
    w *= scale;
    h *= scale;
    let cx = f64::from(b.x) + bw / 2.0 + shift.0 * w;
    let cy = f64::from(b.y) + bh / 2.0 + shift.1 * h;
    let (wi, hi) = (w.round() as i64, h.round() as i64);
    let (iw, ih) = (image.0 as i64, image.1 as i64);
    if wi < 1 || hi < 1 || wi > iw || hi > ih {
        return None;
    }
    let x = ((cx - w / 2.0).round() as i64).clamp(0, iw - wi);
    let y = ((cy - h / 2.0).round() as i64).clamp(0, ih - hi);
    Some(Rect {
        x: x as i32,
        y: y as i32,
        width: wi as i32,
        height: hi as i32,
    })
}

/// The region `r` of an image resized to the window (OpenCV's bilinear rule).
fn cut(image: &GrayImage, r: &Rect, window: [u32; 2]) -> Vec<u8> {
    let (x, y, w, h) = (
        r.x as usize,
        r.y as usize,
        r.width as usize,
        r.height as usize,
    );
    let mut region = Vec::with_capacity(w * h);
    for row in y..y + h {
        region.extend_from_slice(&image.row(row)[x..x + w]);
    }
    resize_linear(&region, w, h, window[0] as usize, window[1] as usize)
}

/// The positives of a training, shuffled (seeded): each box, then its mirror image, then
/// its jittered copies (each also mirrored).
pub fn positive_patches(
    data: &TrainingData,
    config: &TrainConfig,
    window: [u32; 2],
) -> Vec<Vec<u8>> {
    let mut rng = SplitMix::new(config.seed ^ 0x5057_4f53);
    let mut out = Vec::new();
    for (frame, boxes) in data.frames.iter().zip(data.boxes(config.upper)) {
        let size = (frame.width(), frame.height());
        for b in &boxes {
            for copy in 0..=config.jitter {
                let (scale, shift) = if copy == 0 {
                    (1.0, (0.0, 0.0))
                } else {
                    let u = |r: &mut SplitMix, a: f64| (r.unit() * 2.0 - 1.0) * a;
                    (
                        1.0 + u(&mut rng, 0.05),
                        (u(&mut rng, 0.04), u(&mut rng, 0.04)),
                    )
                };
                let Some(r) = fit_box(b, window, scale, shift, size) else {
                    continue;
                };
                let patch = cut(frame, &r, window);
                if config.mirror {
                    out.push(mirrored(&patch, window[0] as usize));
                }
                out.push(patch);
            }
        }
    }
    rng.shuffle(&mut out);
    out
}

/// One stage's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageReport {
    /// 1-based stage number.
    pub stage: usize,
    /// Weak classifiers (stumps) in the stage.
    pub weak_count: usize,
    /// Share of the stage's positives it accepts.
    pub hit_rate: f64,
    /// Share of the stage's negatives it accepts.
    pub false_alarm: f64,
    /// Share of the candidate windows the cascade before this stage accepted while the
    /// negatives were mined (OpenCV's "acceptanceRatio"); the product of the earlier
    /// stages' false-alarm rates, measured.
    pub acceptance_ratio: f64,
    /// Positives the stage was trained on.
    pub positives: usize,
    /// Negatives the stage was trained on.
    pub negatives: usize,
    /// Positives of the pool the earlier stages had rejected.
    pub positives_dropped: usize,
    /// Features valued for this stage.
    pub features: usize,
    /// Time the stage took, s (from the observer's clock; `None` without one).
    pub seconds: Option<f64>,
}

/// What the inputs of a training were, to tell whether a saved state belongs to it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Inputs {
    /// The annotation file as given.
    pub info: String,
    /// Its images.
    pub images: usize,
    /// Its boxes.
    pub boxes: usize,
    /// The background folders as given.
    pub bg_dirs: Vec<String>,
    /// Their images.
    pub backgrounds: usize,
}

impl Inputs {
    fn of(data: &TrainingData) -> Inputs {
        Inputs {
            info: data.info.display().to_string(),
            images: data.annotations.len(),
            boxes: data.annotations.iter().map(|a| a.boxes.len()).sum(),
            bg_dirs: data
                .bg_dirs
                .iter()
                .map(|d| d.display().to_string())
                .collect(),
            backgrounds: data.backgrounds.len(),
        }
    }
}

/// Everything needed to resume a training: saved after every stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainState {
    /// [`STATE_VERSION`].
    pub version: u32,
    /// The options.
    pub config: TrainConfig,
    /// The inputs.
    pub inputs: Inputs,
    /// The cascade so far.
    pub cascade: CascadeModel,
    /// One report per stage trained.
    pub reports: Vec<StageReport>,
}

impl TrainState {
    /// Reads a saved state.
    pub fn load(path: &Path) -> Result<TrainState, TrainError> {
        let err = |why: String| TrainError::State {
            path: path.to_path_buf(),
            why,
        };
        let text =
            std::fs::read_to_string(path).map_err(|e| err(format!("cannot read it ({e})")))?;
        let state: TrainState = serde_json::from_str(&text).map_err(|e| {
            err(format!(
                "not a training state ({e}); delete it to start over"
            ))
        })?;
        if state.version != STATE_VERSION {
            return Err(err(format!(
                "saved by layout version {}, this trainer writes {STATE_VERSION}; delete it to start over",
                state.version
            )));
        }
        Ok(state)
    }

    /// Writes the state (to a temporary file first, then renamed, so an interruption
    /// never leaves a half-written state).
    pub fn save(&self, path: &Path) -> Result<(), TrainError> {
        let err = |why: String| TrainError::State {
            path: path.to_path_buf(),
            why,
        };
        let json = serde_json::to_string(self).map_err(|e| err(e.to_string()))?;
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".tmp");
        let tmp = PathBuf::from(tmp);
        std::fs::write(&tmp, json).map_err(|e| err(format!("cannot write it ({e})")))?;
        std::fs::rename(&tmp, path).map_err(|e| err(format!("cannot write it ({e})")))
    }
}

/// What the trainer reports while it works (from the calling thread).
#[derive(Debug, Clone, PartialEq)]
pub enum Event<'a> {
    /// Data and pools are ready.
    Ready {
        /// Window `[width, height]`, px.
        window: [u32; 2],
        /// Positives cut from the annotations.
        positives: usize,
        /// Positives per stage.
        num_pos: usize,
        /// Boxes too flat (or too large) to give a positive.
        positives_skipped: usize,
        /// Features in the pool.
        pool: usize,
        /// Images negatives are mined from.
        mining_images: usize,
        /// Candidate windows in them.
        mining_windows: u64,
    },
    /// A saved state was found: training resumes after its stages.
    Resumed {
        /// Stages already trained.
        stages: usize,
    },
    /// A stage begins (1-based).
    StageStarted {
        /// The stage.
        stage: usize,
    },
    /// Negatives found so far.
    Mining {
        /// Found.
        found: usize,
        /// Wanted.
        wanted: usize,
        /// Windows considered.
        considered: u64,
    },
    /// Features valued and sorted so far.
    Features {
        /// Done.
        done: usize,
        /// Of.
        total: usize,
    },
    /// A weak classifier was added.
    Weak {
        /// Weak classifiers in the stage.
        count: usize,
        /// The stage's hit rate on its positives.
        hit_rate: f64,
        /// The stage's false-alarm rate on its negatives.
        false_alarm: f64,
    },
    /// A stage is done (and saved).
    StageDone(&'a StageReport),
    /// Something the user should know.
    Warning(String),
}

/// Receives the trainer's [`Event`]s.
pub trait Observer: Sync {
    /// Called for every event.
    fn event(&self, event: &Event<'_>);

    /// Seconds on the caller's clock, for the stages' times; the trainer reads no clock
    /// itself. Default: none.
    fn now_secs(&self) -> Option<f64> {
        None
    }

    /// Asked after each stage is saved: true ends the training there with
    /// [`TrainError::Stopped`] (the stage in progress is finished first, so no work is
    /// lost). Default: never.
    fn stop_after_stage(&self) -> bool {
        false
    }
}

/// An observer that ignores everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Observer for Silent {
    fn event(&self, _: &Event<'_>) {}
}

/// The state to train from: the one saved at `state_path` when it was made from the same
/// `inputs`, options (but for the number of stages) and `window`, else a new one.
fn start_state(
    state_path: Option<&Path>,
    config: &TrainConfig,
    inputs: Inputs,
    window: [u32; 2],
    observer: &dyn Observer,
) -> Result<TrainState, TrainError> {
    Ok(match state_path.filter(|p| p.exists()) {
        Some(path) => {
            let s = TrainState::load(path)?;
            let what = if s.inputs != inputs {
                Some("annotations or background images".to_string())
            } else if (TrainConfig {
                stages: config.stages,
                ..s.config.clone()
            }) != *config
            {
                // Only the number of stages may change: a longer run continues a shorter one.
                Some("options".to_string())
            } else if [s.cascade.width, s.cascade.height] != window {
                Some("window size".to_string())
            } else {
                None
            };
            if let Some(what) = what {
                return Err(TrainError::StateMismatch {
                    path: path.to_path_buf(),
                    what,
                });
            }
            observer.event(&Event::Resumed {
                stages: s.cascade.stages.len(),
            });
            s
        }
        None => TrainState {
            version: STATE_VERSION,
            config: config.clone(),
            inputs,
            cascade: CascadeModel::empty(window[0], window[1], config.mode),
            reports: Vec::new(),
        },
    })
}

/// Where negatives are mined: every frame, its boxes avoided, then every background.
fn mining_sources(data: &TrainingData, boxes: &[Vec<Rect>]) -> Vec<Source> {
    data.frames
        .iter()
        .zip(boxes)
        .map(|(f, b)| Source {
            image: f.clone(),
            avoid: b.clone(),
        })
        .chain(data.backgrounds.iter().map(|f| Source {
            image: f.clone(),
            avoid: Vec::new(),
        }))
        .collect()
}

/// The first `num_pos` positives the cascade so far accepts, and how many it refused on
/// the way.
fn accepted_positives(
    positives: &SampleSet,
    compiled: &CompiledCascade,
    num_pos: usize,
    window: [u32; 2],
) -> (SampleSet, usize) {
    let mut set = SampleSet::new(window[0], window[1]);
    let mut dropped = 0;
    for i in 0..positives.len() {
        if set.len() == num_pos {
            break;
        }
        if compiled.accepts_sample(positives, i) {
            set.push_integral(positives, i);
        } else {
            dropped += 1;
        }
    }
    (set, dropped)
}

/// Trains a cascade (or resumes one from `state_path` when it holds a matching state) and
/// saves the state there after every stage.
pub fn train(
    data: &TrainingData,
    config: &TrainConfig,
    state_path: Option<&Path>,
    observer: &dyn Observer,
) -> Result<TrainState, TrainError> {
    config.check()?;
    let boxes = data.boxes(config.upper);
    let all_boxes: Vec<Rect> = boxes.iter().flatten().copied().collect();
    let window = config.window.unwrap_or_else(|| auto_window(&all_boxes));
    let pool = enumerate(window[0], window[1], config.mode);
    if pool.is_empty() || window[0] < 3 || window[1] < 3 {
        return Err(TrainError::WindowTooSmall {
            width: window[0],
            height: window[1],
        });
    }
    let inputs = Inputs::of(data);
    let mut state = start_state(state_path, config, inputs, window, observer)?;

    // Positives: cut, then the flat ones left out.
    let patches = positive_patches(data, config, window);
    let fitted = all_boxes.len() * (config.jitter as usize + 1) * (1 + usize::from(config.mirror));
    let mut positives = SampleSet::new(window[0], window[1]);
    for p in &patches {
        positives.push(p, true);
    }
    let skipped = fitted - positives.len();
    let num_pos = config
        .num_pos
        .unwrap_or((positives.len() as f64 * 0.9).floor() as usize)
        .max(1);
    if num_pos > positives.len() {
        return Err(TrainError::TooFewPositives {
            asked: num_pos,
            available: positives.len(),
            boxes: all_boxes.len(),
            mirror: if config.mirror { ", mirrored" } else { "" },
        });
    }
    if num_pos + config.num_neg > MAX_SAMPLES {
        return Err(TrainError::TooManySamples(num_pos + config.num_neg));
    }
    let sources = mining_sources(data, &boxes);
    let miner = Miner::new(
        sources,
        window[0],
        window[1],
        config.scale_factor,
        config.neg_max_overlap,
    )?;
    observer.event(&Event::Ready {
        window,
        positives: positives.len(),
        num_pos,
        positives_skipped: skipped,
        pool: pool.len(),
        mining_images: miner.source_count(),
        mining_windows: miner.total_windows(),
    });

    let mut acceptance = state
        .reports
        .last()
        .map_or(1.0, |r| (r.acceptance_ratio * r.false_alarm).max(1e-12));
    while state.cascade.stages.len() < config.stages {
        let stage_no = state.cascade.stages.len() + 1;
        observer.event(&Event::StageStarted { stage: stage_no });
        let started = observer.now_secs();
        let stage_seed = crate::rng::unit_hash(config.seed, stage_no as u64);
        let compiled = state.cascade.compile(positives.stride());
        let (mut set, dropped) = accepted_positives(&positives, &compiled, num_pos, window);
        let used_pos = set.len();
        if used_pos < num_pos {
            observer.event(&Event::Warning(format!(
                "stage {stage_no}: only {used_pos} positives are still accepted by the cascade \
                 (of {num_pos} asked for); training the stage with them"
            )));
        }
        let mined = miner
            .mine(
                &state.cascade,
                config.num_neg,
                stage_seed,
                acceptance,
                &|found, considered| {
                    observer.event(&Event::Mining {
                        found,
                        wanted: config.num_neg,
                        considered,
                    })
                },
            )
            .map_err(|e| TrainError::NegativesExhausted {
                stage: stage_no,
                found: e.found,
                wanted: e.wanted,
                considered: e.considered,
                images: miner.source_count(),
                trained: stage_no - 1,
            })?;
        for p in &mined.patches {
            set.push(p, false);
        }
        let features = stage_features(&pool, config.max_features, stage_seed);
        let total = features.len();
        let sorted = SortedValues::build(&set, &features, &|done| {
            observer.event(&Event::Features { done, total })
        });
        let outcome = train_stage(
            &set,
            &features,
            &sorted,
            &config.stage_params(),
            &|count, hit_rate, false_alarm| {
                observer.event(&Event::Weak {
                    count,
                    hit_rate,
                    false_alarm,
                })
            },
        );
        drop(sorted);
        let report = StageReport {
            stage: stage_no,
            weak_count: outcome.stage.stumps.len(),
            hit_rate: outcome.hit_rate,
            false_alarm: outcome.false_alarm,
            acceptance_ratio: mined.acceptance_ratio(),
            positives: used_pos,
            negatives: mined.patches.len(),
            positives_dropped: dropped,
            features: total,
            seconds: started.zip(observer.now_secs()).map(|(a, b)| b - a),
        };
        acceptance = (report.acceptance_ratio * report.false_alarm).max(1e-12);
        state.cascade.stages.push(outcome.stage);
        state.reports.push(report);
        if let Some(path) = state_path {
            state.save(path)?;
        }
        if let Some(r) = state.reports.last() {
            observer.event(&Event::StageDone(r));
        }
        if state.cascade.stages.len() < config.stages && observer.stop_after_stage() {
            return Err(TrainError::Stopped {
                trained: state.cascade.stages.len(),
            });
        }
    }
    Ok(state)
}

/// The features valued for a stage: the whole pool, or a seeded random subset of
/// `max_features` in pool order.
fn stage_features(pool: &[Feature], max_features: usize, seed: u64) -> Vec<Feature> {
    if max_features == 0 || pool.len() <= max_features {
        return pool.to_vec();
    }
    let mut idx: Vec<usize> = (0..pool.len()).collect();
    let mut rng = SplitMix::new(seed ^ 0x4645_4154);
    // Partial Fisher-Yates: the first max_features entries are a uniform subset.
    for i in 0..max_features {
        let j = i + rng.below(pool.len() - i);
        idx.swap(i, j);
    }
    let mut chosen = idx[..max_features].to_vec();
    chosen.sort_unstable();
    chosen.into_iter().map(|i| pool[i]).collect()
}

#[cfg(test)]
mod tests;
