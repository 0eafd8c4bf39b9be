//! Whole topics read into memory: the scans of a topic, and scans paired with labelled
//! leg positions as leg_tracker's training bags store them (Leigh et al., ICRA 2015).

use std::path::Path;

use tether_core::{Laser, Point2};

use super::error::BagError;
use super::reader::{BadMessage, Bag, SkippedRecord};
use tether_msgs::{LaserScanMsg, PoseArrayMsg};

/// The scans of one topic, in bag order, and what had to be skipped.
#[derive(Debug, Clone)]
pub struct ScanSet {
    /// The scans that decoded.
    pub scans: Vec<LaserScanMsg>,
    /// Messages on the topic that did not decode (skipped).
    pub bad_count: usize,
    /// The first bad messages with reasons.
    pub bad: Vec<BadMessage>,
    /// Message records skipped because no connection defines them.
    pub skipped: Vec<SkippedRecord>,
}

/// Reads every scan of `topic`. Fails if the bag is damaged or has no such topic.
pub fn read_scans(path: impl AsRef<Path>, topic: &str) -> Result<ScanSet, BagError> {
    let mut bag = Bag::open(&path)?;
    check_topic(&bag, path.as_ref(), topic)?;
    let mut it = bag.decoded::<LaserScanMsg>(&[topic]);
    let mut scans = Vec::new();
    for m in &mut it {
        scans.push(m?.message);
    }
    Ok(ScanSet {
        scans,
        bad_count: it.bad_count(),
        bad: it.bad_messages().to_vec(),
        skipped: it.skipped().to_vec(),
    })
}

/// A scan and the labelled centres of the leg clusters in it, in the scan's frame.
#[derive(Debug, Clone)]
pub struct LabelledScan {
    /// The scan.
    pub scan: LaserScanMsg,
    /// Labelled leg positions, m, in the scan's frame.
    pub legs_in_laser: Vec<Point2<Laser>>,
}

/// Scans with their labels, as read by [`read_labelled_scans`].
#[derive(Debug, Clone)]
pub struct LabelledScans {
    /// Scans that had a label message just before them.
    pub scans: Vec<LabelledScan>,
    /// Scans with no label message since the previous scan (left out).
    pub unlabelled: usize,
    /// Messages of either topic that did not decode (skipped).
    pub bad_count: usize,
}

/// Reads scans of `scan_topic` paired with `geometry_msgs/PoseArray` labels of
/// `label_topic`, following leg_tracker's `extract_positive_training_clusters`: it
/// writes, for each scan with legs, the array of labelled leg-cluster centres and then
/// the scan. A label array applies to the next scan in bag order only; a scan without
/// a label array since the previous scan is counted in
/// [`LabelledScans::unlabelled`] and left out.
pub fn read_labelled_scans(
    path: impl AsRef<Path>,
    scan_topic: &str,
    label_topic: &str,
) -> Result<LabelledScans, BagError> {
    let mut bag = Bag::open(&path)?;
    check_topic(&bag, path.as_ref(), scan_topic)?;
    check_topic(&bag, path.as_ref(), label_topic)?;
    let mut messages = bag.messages().only_topics(&[scan_topic, label_topic]);
    let mut out = LabelledScans {
        scans: Vec::new(),
        unlabelled: 0,
        bad_count: 0,
    };
    let mut pending: Option<Vec<Point2<Laser>>> = None;
    for raw in &mut messages {
        let raw = raw?;
        if raw.topic() == label_topic {
            match raw.decode::<PoseArrayMsg>() {
                Ok(labels) => pending = Some(labels.positions_2d()),
                Err(_) => {
                    out.bad_count += 1;
                    pending = None;
                }
            }
        } else {
            match raw.decode::<LaserScanMsg>() {
                Ok(scan) => match pending.take() {
                    Some(legs_in_laser) => out.scans.push(LabelledScan {
                        scan,
                        legs_in_laser,
                    }),
                    None => out.unlabelled += 1,
                },
                Err(_) => {
                    out.bad_count += 1;
                    pending = None;
                }
            }
        }
    }
    out.bad_count += messages.skipped_count();
    Ok(out)
}

fn check_topic<R: std::io::Read + std::io::Seek>(
    bag: &Bag<R>,
    path: &Path,
    topic: &str,
) -> Result<(), BagError> {
    if bag.topics().contains(&topic) {
        Ok(())
    } else {
        Err(BagError::NoSuchTopic {
            path: path.to_path_buf(),
            topic: topic.to_string(),
            available: bag.topics().join(", "),
        })
    }
}
