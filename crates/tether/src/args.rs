//! Options more than one command takes, flattened into their `Args`: the leg model
//! (`--leg-model`), the leg detector of `legs` and `eval-legs`, the laser and detector
//! files, the cascade's search settings and how a recording's camera frames are
//! searched. A command takes them from here, never from another command.

use std::path::{Path, PathBuf};

use anyhow::Context;
use tether_core::LaserModel;
use tether_laser::{DetectorConfig, DetectorKind, LegDetector};
use tether_live::sources::camera::BoxDetector;
use tether_pipeline::{LegsConfig, PipelineConfig};
use tether_vision::{Cascade, DetectParams};

/// `--leg-model FILE`: the leg model of `tether train-legs` for every command that runs
/// the pipeline (`track`, `eval-track`, `replay`, `run`, `ros2`, `eval-target`, `sim`,
/// `demo`), in place of the config's `[legs] model` (`[pipeline.legs] model` in a
/// robot's config) and of the built-in model. `tether legs` and `eval-legs`, which run
/// the detector alone, take it as `--model`.
/// The option, flattened into each command's arguments.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct LegModelArg {
    /// A leg model of `tether train-legs` (JSON) for the learned leg detector, in place
    /// of the config's `[legs] model` and of the built-in model; read and checked at
    /// start (a model trained on other features must be retrained).
    #[arg(long, value_name = "FILE.json")]
    pub leg_model: Option<PathBuf>,
}

impl LegModelArg {
    /// Names the model in `config` (the pipeline reads it through
    /// `tether_live::leg_model`); without the option, `config` is left as it is.
    pub fn apply(&self, config: &mut PipelineConfig) {
        if let Some(path) = &self.leg_model {
            config.legs.model = Some(path.clone());
        }
    }

    /// [`LegModelArg::apply`] to each configuration.
    pub fn apply_all<'a>(&self, configs: impl IntoIterator<Item = &'a mut PipelineConfig>) {
        for config in configs {
            self.apply(config);
        }
    }
}

/// The leg test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Detector {
    /// The paper's arc test (bisectors of chords, delta = 40 mm).
    Arc,
    /// The learned classifier (AdaBoost on segment features).
    Learned,
}

/// Reads the laser config, if any.
pub fn laser_model(path: Option<&PathBuf>) -> anyhow::Result<LaserModel> {
    let Some(path) = path else {
        return Ok(LaserModel::urg_04lx());
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read laser config {}", path.display()))?;
    let model: LaserModel = toml::from_str(&text)
        .with_context(|| format!("laser config {} is not a valid laser model", path.display()))?;
    model
        .validate()
        .with_context(|| format!("laser config {}", path.display()))?;
    Ok(model)
}

/// Reads a detector config for `tether legs` and `eval-legs`: JSON when the file's first
/// non-blank character is `{`, TOML otherwise (keys it leaves out keep
/// `DetectorConfig`'s defaults, confirmation off); without a file,
/// [`DetectorConfig::per_scan`] (narrow legs confirmed over the last scans, design 4.6).
pub fn detector_config(path: Option<&PathBuf>) -> anyhow::Result<DetectorConfig> {
    let Some(path) = path else {
        return Ok(DetectorConfig::per_scan());
    };
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read detector config {}", path.display()))?;
    let config: DetectorConfig = if text.trim_start().starts_with('{') {
        serde_json::from_str(&text).with_context(|| {
            format!(
                "detector config {} is not a valid JSON DetectorConfig",
                path.display()
            )
        })?
    } else {
        toml::from_str(&text).with_context(|| {
            format!(
                "detector config {} is not a valid TOML DetectorConfig",
                path.display()
            )
        })?
    };
    config
        .validate()
        .with_context(|| format!("detector config {}", path.display()))?;
    Ok(config)
}

/// Builds the detector the options ask for: the config's one constructor
/// ([`tether_live::leg_model::detector`]) with these choices.
pub fn detector(
    kind: DetectorKind,
    model: Option<&PathBuf>,
    laser: &LaserModel,
    config: DetectorConfig,
) -> anyhow::Result<LegDetector> {
    let legs = LegsConfig {
        detector: kind,
        config,
        model: model.cloned(),
    };
    Ok(tether_live::leg_model::detector(&legs, laser)?)
}

/// The cascade to use: the given file, or Debian's upper-body cascade
/// (`tether_live::sources::camera::DEFAULT_CASCADE` in `DEBIAN_CASCADE_DIR`).
pub fn resolve_cascade(cascade: Option<&Path>) -> anyhow::Result<PathBuf> {
    Ok(tether_live::sources::camera::resolve_cascade(cascade)?)
}

/// `[W, H]` from a two-value option.
fn size(option: Option<&Vec<u32>>, name: &str) -> anyhow::Result<[u32; 2]> {
    match option.map(Vec::as_slice) {
        None => Ok([0, 0]),
        Some([w, h]) => Ok([*w, *h]),
        Some(other) => anyhow::bail!("--{name} takes two numbers, W and H; got {other:?}"),
    }
}

/// The search settings of `detectMultiScale`, taken by every command that runs a
/// cascade (`detect`, `eval-cascade`, `track`, `replay`, `calibrate camera`).
#[derive(Debug, Clone, clap::Args)]
pub struct DetectOptions {
    /// Ratio between consecutive pyramid scales (> 1).
    #[arg(long, default_value_t = 1.1, value_name = "F")]
    pub scale_factor: f64,
    /// Neighbours a group of windows needs to be kept; 0 keeps the raw windows.
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub min_neighbors: u32,
    /// Smallest box, px.
    #[arg(long, num_args = 2, value_names = ["W", "H"])]
    pub min_size: Option<Vec<u32>>,
    /// Largest box, px (default: the image size).
    #[arg(long, num_args = 2, value_names = ["W", "H"])]
    pub max_size: Option<Vec<u32>>,
}

impl DetectOptions {
    /// The detector's parameters, checked.
    pub fn params(&self) -> anyhow::Result<DetectParams> {
        let scale_factor = self.scale_factor;
        anyhow::ensure!(
            scale_factor.is_finite() && scale_factor > 1.0,
            "--scale-factor must be a number above 1 (OpenCV's default is 1.1), got {scale_factor}"
        );
        Ok(DetectParams {
            scale_factor,
            min_neighbors: self.min_neighbors,
            min_size_px: size(self.min_size.as_ref(), "min-size")?,
            max_size_px: size(self.max_size.as_ref(), "max-size")?,
        })
    }
}

/// How camera frames of a recording are searched for people (shared by `track` and
/// `replay`).
#[derive(Debug, Clone, clap::Args)]
pub struct CameraArgs {
    /// Cascade XML for the camera frames (default: Debian's
    /// /usr/share/opencv4/haarcascades/haarcascade_upperbody.xml).
    #[arg(long, value_name = "FILE")]
    pub cascade: Option<PathBuf>,
    /// The cascade's search settings.
    #[command(flatten)]
    pub search: DetectOptions,
    /// Detection threads (0: one per core); results do not depend on it.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub threads: usize,
}

/// The detector the options ask for.
pub fn camera(args: &CameraArgs) -> anyhow::Result<BoxDetector> {
    let cascade_path = resolve_cascade(args.cascade.as_deref())?;
    let cascade = Cascade::load(&cascade_path)?;
    let params = args.search.params()?;
    Ok(BoxDetector::new(cascade, params, args.threads)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_option_overrides_the_config_and_its_absence_changes_nothing() {
        let mut config = PipelineConfig::default();
        config.legs.model = Some("from_config.json".into());
        LegModelArg::default().apply(&mut config);
        assert_eq!(config.legs.model, Some("from_config.json".into()));
        let arg = LegModelArg {
            leg_model: Some("from_flag.json".into()),
        };
        arg.apply(&mut config);
        assert_eq!(config.legs.model, Some("from_flag.json".into()));
    }
}
