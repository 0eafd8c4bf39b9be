//! Which snapshots to draw, chosen as a replay goes (see the module's documentation).

use super::snapshot::{Chosen, Snapshot};
use super::{EVEN_CANDIDATES, LOSS_CANDIDATES, MAX_LOSS_SNAPSHOTS, MAX_SNAPSHOTS};

/// Keeps every `stride`-th of a stream of items by their index, doubling the stride
/// (and dropping every other item held) whenever more than `cap` are held: a bounded,
/// evenly spread sample of a stream whose length is known only at its end.
#[derive(Debug, Clone)]
pub struct Thinned<T> {
    cap: usize,
    stride: usize,
    items: Vec<(usize, T)>,
}

impl<T> Thinned<T> {
    /// Holds at most `cap` (at least 2) items.
    pub fn new(cap: usize) -> Self {
        Thinned {
            cap: cap.max(2),
            stride: 1,
            items: Vec::new(),
        }
    }

    /// Whether the item of this index would be kept.
    pub fn wants(&self, index: usize) -> bool {
        index.is_multiple_of(self.stride)
    }

    /// Offers the item of `index` (indices increasing); `make` is called only when it
    /// is kept.
    pub fn offer(&mut self, index: usize, make: impl FnOnce() -> T) {
        if !self.wants(index) {
            return;
        }
        self.items.push((index, make()));
        if self.items.len() > self.cap {
            self.stride *= 2;
            let stride = self.stride;
            self.items.retain(|(i, _)| i.is_multiple_of(stride));
        }
    }

    /// The indices held.
    pub fn indices(&self) -> Vec<usize> {
        self.items.iter().map(|(i, _)| *i).collect()
    }

    /// `n` items of a stream of `total`: for each of `n` equal parts of the stream,
    /// the item held nearest its middle (not one taken already); all of them when
    /// `n` or fewer are held.
    pub fn pick(self, n: usize, total: usize) -> Vec<(usize, T)> {
        if self.items.len() <= n {
            return self.items;
        }
        let mut taken = vec![false; self.items.len()];
        for k in 0..n {
            let middle = (k as f64 + 0.5) * total as f64 / n as f64 - 0.5;
            let best = self
                .items
                .iter()
                .enumerate()
                .filter(|(j, _)| !taken[*j])
                .min_by(|(_, a), (_, b)| {
                    (a.0 as f64 - middle)
                        .abs()
                        .total_cmp(&(b.0 as f64 - middle).abs())
                        .then(a.0.cmp(&b.0))
                })
                .map(|(j, _)| j);
            if let Some(j) = best {
                taken[j] = true;
            }
        }
        self.items
            .into_iter()
            .zip(taken)
            .filter(|(_, t)| *t)
            .map(|(item, _)| item)
            .collect()
    }
}

/// Chooses the snapshots as a replay goes (see the module's documentation).
#[derive(Debug, Clone)]
pub struct SnapshotPicker {
    evenly: Thinned<Snapshot>,
    losses: Thinned<Snapshot>,
    loss_count: usize,
}

impl Default for SnapshotPicker {
    fn default() -> Self {
        SnapshotPicker {
            evenly: Thinned::new(EVEN_CANDIDATES),
            losses: Thinned::new(LOSS_CANDIDATES),
            loss_count: 0,
        }
    }
}

impl SnapshotPicker {
    /// Nothing chosen yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Scan `index` (counted from 0, in order) has been replayed; `make` builds its
    /// snapshot, called only when the scan is kept as a candidate.
    pub fn scan(&mut self, index: usize, make: impl FnOnce() -> Snapshot) {
        self.evenly.offer(index, make);
    }

    /// The target was just lost; `make` builds the snapshot, called only when the
    /// loss is kept as a candidate.
    pub fn loss(&mut self, make: impl FnOnce() -> Snapshot) {
        self.losses.offer(self.loss_count, make);
        self.loss_count += 1;
    }

    /// The snapshots of a replay of `scans` scans, in time order.
    pub fn finish(self, scans: usize) -> Vec<Snapshot> {
        let losses: Vec<Snapshot> = self
            .losses
            .pick(MAX_LOSS_SNAPSHOTS, self.loss_count)
            .into_iter()
            .map(|(_, s)| s)
            .collect();
        let mut out: Vec<Snapshot> = self
            .evenly
            .pick(MAX_SNAPSHOTS - losses.len(), scans)
            .into_iter()
            .map(|(_, s)| s)
            .filter(|s| !losses.iter().any(|l| l.scan_index == s.scan_index))
            .collect();
        out.extend(losses);
        out.sort_by(|a, b| {
            a.stamp
                .cmp(&b.stamp)
                .then(a.scan_index.cmp(&b.scan_index))
                .then((a.chosen == Chosen::Evenly).cmp(&(b.chosen == Chosen::Evenly)))
        });
        out
    }
}
