//! The leg model a config names (`[legs] model`, `[pipeline.legs] model` in a robot's
//! config, or `--leg-model`): read and checked here, for every pipeline a command
//! builds, so that `run`, `ros2`, `track`, `replay`, `sim` and the evaluations all use
//! the same model. The pipeline itself does no I/O ([`Pipeline::new`] takes the
//! classifier).

use std::path::Path;

use tether_core::LaserModel;
use tether_laser::{DetectorKind, LegClassifier, LegDetector};
use tether_pipeline::{LegsConfig, Pipeline, PipelineConfig, PipelineError};

/// Why the named model cannot be used; names the file.
fn model_error(message: String) -> PipelineError {
    PipelineError::Config {
        part: "legs.model",
        message,
    }
}

/// The classifier `legs.model` names, read and checked (format, this build's features,
/// trees); `None` when no file is named (the pipeline then takes the built-in model).
/// A model named for the arc detector is refused: it would not be used.
pub fn classifier(legs: &LegsConfig) -> Result<Option<LegClassifier>, PipelineError> {
    let Some(path) = &legs.model else {
        return Ok(None);
    };
    if let DetectorKind::Arc = legs.detector {
        return Err(model_error(format!(
            "{} is a model of the learned detector, but `detector = \"arc\"` would not \
             use it: remove one of them",
            path.display()
        )));
    }
    let bytes = std::fs::read(path)
        .map_err(|e| model_error(format!("cannot read the leg model {}: {e}", path.display())))?;
    let text = String::from_utf8(bytes).map_err(|_| {
        model_error(format!(
            "{} is not a leg model (not text; `tether train-legs` writes JSON)",
            path.display()
        ))
    })?;
    LegClassifier::from_json(&text)
        .map(Some)
        .map_err(|e| model_error(format!("{}: {e}", path.display())))
}

/// [`Pipeline::new`] with the leg model the config names (the built-in one if none).
pub fn pipeline(config: PipelineConfig) -> Result<Pipeline, PipelineError> {
    let model = classifier(&config.legs)?;
    Pipeline::new(config, model)
}

/// The leg detector of `legs` for a scanner of `laser`'s noise, with the model the
/// config names read here ([`classifier`]): the detector the pipeline builds, for
/// commands that detect legs outside a pipeline (`tether legs`, `eval-legs`, the
/// replay's snapshots).
pub fn detector(legs: &LegsConfig, laser: &LaserModel) -> Result<LegDetector, PipelineError> {
    tether_pipeline::leg_detector(legs, laser.noise.clone(), classifier(legs)?)
}

/// Resolves a relative `legs.model` against `config_dir`, the folder of the config file
/// that named it (an absolute path is kept).
pub fn resolve(legs: &mut LegsConfig, config_dir: &Path) {
    if let Some(path) = &legs.model {
        legs.model = Some(config_dir.join(path));
    }
}

/// The folder of a config file, against which the paths it names are resolved (`.` for
/// a bare file name).
pub fn folder_of(config_path: &Path) -> &Path {
    match config_path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_model_named_is_the_built_in_one() {
        assert!(classifier(&LegsConfig::default()).unwrap().is_none());
        assert!(pipeline(PipelineConfig::default()).is_ok());
    }

    #[test]
    fn a_relative_model_is_resolved_against_the_config_folder() {
        let mut legs = LegsConfig {
            model: Some("legs.json".into()),
            ..LegsConfig::default()
        };
        resolve(&mut legs, folder_of(Path::new("/robots/a/robot.toml")));
        assert_eq!(
            legs.model.as_deref(),
            Some(Path::new("/robots/a/legs.json"))
        );
        resolve(&mut legs, Path::new("/elsewhere"));
        assert_eq!(
            legs.model.as_deref(),
            Some(Path::new("/robots/a/legs.json"))
        );
        assert_eq!(folder_of(Path::new("robot.toml")), Path::new("."));
    }

    #[test]
    fn a_missing_or_bad_model_is_an_error_naming_the_file() {
        let dir = std::env::temp_dir().join(format!("tether-leg-model-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let missing = dir.join("missing.json");
        let not_a_model = dir.join("not_a_model.json");
        std::fs::write(&not_a_model, "{\"trees\": 3}").unwrap();
        for path in [&missing, &not_a_model] {
            let config = PipelineConfig {
                legs: LegsConfig {
                    model: Some(path.clone()),
                    ..LegsConfig::default()
                },
                ..PipelineConfig::default()
            };
            let Err(error) = pipeline(config) else {
                panic!("{} was taken for a model", path.display());
            };
            let message = error.to_string();
            assert!(message.contains(&path.display().to_string()), "{message}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_model_for_the_arc_detector_is_refused() {
        let legs = LegsConfig {
            detector: DetectorKind::Arc,
            model: Some("legs.json".into()),
            ..LegsConfig::default()
        };
        let message = classifier(&legs).expect_err("refused").to_string();
        assert!(message.contains("legs.json"), "{message}");
    }

    #[test]
    fn the_pipeline_refuses_a_named_model_it_was_not_given() {
        let config = PipelineConfig {
            legs: LegsConfig {
                model: Some("legs.json".into()),
                ..LegsConfig::default()
            },
            ..PipelineConfig::default()
        };
        assert!(Pipeline::new(config, None).is_err());
    }
}
