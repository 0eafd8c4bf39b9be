//! leg_tracker's labelled recordings as data (design 4.6, issue 3's splits): the
//! labelled scans of its positive bags and the scans of its bag without people, read
//! from the folder that holds them. `tether train-legs` trains on the training split,
//! `tether eval-legs` scores on the test split; both read them here.

use std::path::Path;

use anyhow::Context;
use tether_core::{Laser, LaserScan, Point2};
use tether_laser::training::{
    NEGATIVE_BAG, POSITIVE_LABEL_TOPIC, POSITIVE_SCAN_TOPIC, TRAIN_POSITIVE_BAGS,
};
use tether_recording::rosbag::{read_labelled_scans, read_scans};

/// The labelled scans of the given positive bags, as (scan, leg centres) pairs.
pub fn labelled_scans(
    data: &Path,
    bags: &[&str],
) -> anyhow::Result<Vec<(LaserScan, Vec<Point2<Laser>>)>> {
    let mut out = Vec::new();
    for bag in bags {
        let path = data.join(bag);
        let read = read_labelled_scans(&path, POSITIVE_SCAN_TOPIC, POSITIVE_LABEL_TOPIC)
            .with_context(|| format!("reading {}", path.display()))?;
        if read.bad_count > 0 || read.unlabelled > 0 {
            tracing::warn!(
                "{}: skipped {} bad messages and {} scans without labels",
                path.display(),
                read.bad_count,
                read.unlabelled
            );
        }
        tracing::info!("{}: {} labelled scans", path.display(), read.scans.len());
        out.extend(
            read.scans
                .into_iter()
                .map(|s| (s.scan.scan, s.legs_in_laser)),
        );
    }
    Ok(out)
}

/// Refuses a `--data` that is not a folder, saying where it looked (a relative default
/// is relative to the current folder, not to the checkout).
pub fn check_data_folder(data: &Path) -> anyhow::Result<()> {
    if data.is_dir() {
        return Ok(());
    }
    let looked = std::path::absolute(data).unwrap_or_else(|_| data.to_path_buf());
    anyhow::bail!(
        "{} is not a folder (looked for {}); pass --data with the folder of leg_tracker's \
         bags (their test split: {}; training: {})",
        data.display(),
        looked.display(),
        tether_laser::training::TEST_POSITIVE_BAGS.join(", "),
        TRAIN_POSITIVE_BAGS.join(", ")
    )
}

/// The scans of the given topics of the bag without people.
pub fn negative_scans(data: &Path, topics: &[&str]) -> anyhow::Result<Vec<LaserScan>> {
    let path = data.join(NEGATIVE_BAG);
    let mut out = Vec::new();
    for topic in topics {
        let read =
            read_scans(&path, topic).with_context(|| format!("reading {}", path.display()))?;
        if read.bad_count > 0 {
            tracing::warn!(
                "{} {topic}: skipped {} bad messages",
                path.display(),
                read.bad_count
            );
        }
        tracing::info!("{} {topic}: {} scans", path.display(), read.scans.len());
        out.extend(read.scans.into_iter().map(|m| m.scan));
    }
    Ok(out)
}
