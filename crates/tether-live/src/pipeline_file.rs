//! The configuration file of a command that is not a live run (`track`, `replay`,
//! `eval-track`, `eval-target`, `sim`, `config show`): a pipeline's own (every table
//! optional, the layout of `tether config defaults`) or a robot's (`tether run`'s, with
//! `[robot]`), whose robot, laser mount, camera, follower and `[pipeline]` tables make
//! the pipeline's configuration. One reader for every command (issue 33).

use std::path::Path;

use tether_pipeline::PipelineConfig;

use crate::config::{ConfigError, RobotConfig};

/// Reads a configuration file (`None`: the defaults). A robot's live-only tables
/// (`[base]`, `[output]`, the laser's port) are accepted and, with `-v`, listed as
/// unused.
pub fn load(path: Option<&Path>) -> Result<PipelineConfig, ConfigError> {
    let Some(path) = path else {
        return Ok(PipelineConfig::default());
    };
    let text = std::fs::read_to_string(path).map_err(|error| ConfigError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    let table = toml::from_str::<toml::Table>(&text).ok();
    if table.as_ref().is_some_and(|t| t.contains_key("robot")) {
        let robot = RobotConfig::load_for_recordings(path)?;
        if let Some(table) = &table {
            log_unused(path, table);
        }
        return robot.pipeline_config().map_err(|e| ConfigError::Invalid {
            path: path.to_path_buf(),
            field: "pipeline".into(),
            message: e.to_string(),
        });
    }
    let mut config: PipelineConfig = toml::from_str(&text).map_err(|e| ConfigError::Parse {
        path: path.to_path_buf(),
        message: format!(
            "not a valid tether configuration: {}",
            e.to_string().trim_end()
        ),
    })?;
    crate::leg_model::resolve(&mut config.legs, crate::leg_model::folder_of(path));
    check_ranges(path, &config)?;
    Ok(config)
}

/// The first key of `config` (read from `path`) outside its range
/// ([`crate::config_docs::out_of_range`]), as the error that names it.
pub fn check_ranges(path: &Path, config: &PipelineConfig) -> Result<(), ConfigError> {
    match crate::config_docs::out_of_range(config).into_iter().next() {
        Some((field, message)) => Err(ConfigError::Invalid {
            path: path.to_path_buf(),
            field,
            message,
        }),
        None => Ok(()),
    }
}

/// [`load`] for a recording with (`has_odometry`) or without odometry: without, the
/// sensor is taken as still, its mount zeroed (the scan's frame is the robot's and the
/// world's).
pub fn load_for_recording(
    path: Option<&Path>,
    has_odometry: bool,
) -> Result<PipelineConfig, ConfigError> {
    let mut config = load(path)?;
    if !has_odometry {
        config.laser.mount.x_m = 0.0;
        config.laser.mount.y_m = 0.0;
        config.laser.mount.yaw_rad = 0.0;
    }
    Ok(config)
}

/// Says, with `-v`, which of a robot file's tables a command that is not a live run
/// leaves unused.
fn log_unused(path: &Path, table: &toml::Table) {
    let unused: Vec<String> = ["base", "output"]
        .iter()
        .filter(|k| table.contains_key(**k))
        .map(|k| format!("[{k}]"))
        .chain(["serial", "tcp", "baud"].iter().filter_map(|k| {
            table
                .get("laser")
                .and_then(|l| l.get(k))
                .map(|_| format!("laser.{k}"))
        }))
        .collect();
    tracing::debug!(
        "config {} is a robot's: its robot, laser mount, camera, follow and pipeline \
         tables are used; not used here: {}",
        path.display(),
        if unused.is_empty() {
            "nothing".to_string()
        } else {
            unused.join(", ")
        }
    );
}
