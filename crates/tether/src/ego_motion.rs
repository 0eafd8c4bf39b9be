//! How a command learns the robot's motion (`--ego-motion` of `track`, `replay`,
//! `eval-track`, `run` and `ros2`): odometry, scan matching
//! ([`tether_live::ego::ScanOdometry`]) or none.

/// `--ego-motion odom` for a recording without odometry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("--ego-motion odom needs odometry: give --odom-topic, or use scans or none")]
pub struct NoOdometry;

/// How a run learns the robot's motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EgoMotion {
    /// Odometry when the recording or robot gives it, scan matching otherwise.
    #[default]
    Auto,
    /// The odometry topic (or, for `run`, dead reckoning of the commands).
    Odom,
    /// Scan matching, even when odometry is given.
    Scans,
    /// None: the robot is taken to stand still.
    None,
    /// The robot drove tether's own commands (a recording of `tether run`): the dead
    /// reckoning of the commands, corrected by scan matching, as the live loop keeps it
    /// (for `run` and `ros2`: scan matching, odometry messages ignored).
    Commands,
}

/// Where a run's poses come from, once [`EgoMotion`] is resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseSource {
    /// Odometry messages (a recording) or dead reckoning (the live robot).
    Odometry,
    /// Scan matching.
    Scans,
    /// None: the robot stands still.
    Still,
    /// The dead reckoning of the pipeline's own commands, corrected by scan matching.
    Commands,
}

impl PoseSource {
    /// The frame name positions are given in.
    pub fn frame(self) -> &'static str {
        match self {
            PoseSource::Odometry | PoseSource::Commands => "odom",
            PoseSource::Scans => "scan_odom",
            PoseSource::Still => "base_link",
        }
    }
}

impl EgoMotion {
    /// Resolves the choice for a run that has (`have_odometry`) or lacks odometry.
    pub fn resolve(self, have_odometry: bool) -> Result<PoseSource, NoOdometry> {
        match (self, have_odometry) {
            (EgoMotion::Auto, true) | (EgoMotion::Odom, true) => Ok(PoseSource::Odometry),
            (EgoMotion::Auto, false) | (EgoMotion::Scans, _) => Ok(PoseSource::Scans),
            (EgoMotion::Odom, false) => Err(NoOdometry),
            (EgoMotion::None, _) => Ok(PoseSource::Still),
            (EgoMotion::Commands, _) => Ok(PoseSource::Commands),
        }
    }

    /// [`EgoMotion::resolve`] for a run over a recording, with the poses the run keeps:
    /// with scan matching (scans or commands), the settings of the run's configuration
    /// (`config.scan_matcher`), for its scanner mounted at `config.laser`'s mount.
    pub fn for_recording(
        self,
        have_odometry: bool,
        config: &tether_pipeline::PipelineConfig,
    ) -> Result<(PoseSource, tether_live::recording_run::KeptPoses), NoOdometry> {
        let source = self.resolve(have_odometry)?;
        let matched = matches!(source, PoseSource::Scans | PoseSource::Commands);
        let scan_odometry = matched.then(|| {
            tether_live::ego::ScanOdometry::new(
                config.scan_matcher.clone(),
                config.laser.robot_from_laser(),
            )
        });
        use tether_live::recording_run::KeptPoses;
        let kept = match (source, scan_odometry) {
            (PoseSource::Commands, matcher) => KeptPoses::commands(matcher),
            (PoseSource::Scans, Some(matcher)) => KeptPoses::ScanMatching(matcher),
            (PoseSource::Odometry, _) => KeptPoses::Odometry,
            _ => KeptPoses::Still,
        };
        Ok((source, kept))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choices_resolve_as_documented() {
        assert_eq!(EgoMotion::Auto.resolve(true), Ok(PoseSource::Odometry));
        assert_eq!(EgoMotion::Auto.resolve(false), Ok(PoseSource::Scans));
        assert_eq!(EgoMotion::Scans.resolve(true), Ok(PoseSource::Scans));
        assert_eq!(EgoMotion::None.resolve(true), Ok(PoseSource::Still));
        assert!(EgoMotion::Odom.resolve(false).is_err());
        assert_eq!(EgoMotion::Commands.resolve(true), Ok(PoseSource::Commands));
    }
}
