//! Every key of [`PipelineConfig`] with what it means: the fields of each configuration
//! struct and enum in it ([`ConfigDocs`], derived), gathered in one list for `tether
//! config defaults` and `tether config show` (design 13). A type added to the
//! configuration is added here; the app's test of the printed defaults fails on a key
//! this list does not explain.

use tether_core::config_docs::{ConfigDocs, FieldDoc};

use crate::PipelineConfig;

/// The fields of every configuration type of the pipeline.
pub fn config_docs() -> Vec<FieldDoc> {
    [
        PipelineConfig::FIELDS,
        crate::LegsConfig::FIELDS,
        crate::FusionConfig::FIELDS,
        crate::vision::VisionConfig::FIELDS,
        tether_core::LaserModel::FIELDS,
        tether_core::ExtraLaser::FIELDS,
        tether_core::LaserMount::FIELDS,
        tether_core::UrgGeometry::FIELDS,
        tether_core::laser::RangeNoiseModel::FIELDS,
        tether_core::CameraModel::FIELDS,
        tether_core::CameraIntrinsics::FIELDS,
        tether_core::CameraMount::FIELDS,
        tether_laser::DetectorConfig::FIELDS,
        tether_laser::ArcTestConfig::FIELDS,
        tether_laser::Breakpoint::FIELDS,
        tether_laser::PairingConfig::FIELDS,
        tether_laser::ConfirmConfig::FIELDS,
        tether_fusion::ClutterConfig::FIELDS,
        tether_fusion::Gate::FIELDS,
        tether_fusion::MotionBounds::FIELDS,
        tether_fusion::TargetConfig::FIELDS,
        tether_fusion::TrackerConfig::FIELDS,
        tether_control::MotionLimits::FIELDS,
        tether_control::SafetyConfig::FIELDS,
        tether_control::SpringConfig::FIELDS,
        tether_control::SpringGains::FIELDS,
        tether_scanmatch::ScanMatcherConfig::FIELDS,
        tether_scanmatch::RobotBounds::FIELDS,
        tether_scanmatch::IcpConfig::FIELDS,
        tether_scanmatch::LineFit::FIELDS,
    ]
    .concat()
}
