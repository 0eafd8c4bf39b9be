//! The log's own writer thread: log lines go to stderr through a bounded queue, so that a
//! stderr nobody reads (a terminal over a failing link, a full pipe) never holds up the
//! thread that logs, above all the live loop that drives the base. When the queue is
//! full a line is dropped and counted; [`LogQueue::drain`] at the end waits a moment for
//! what is queued and reports what was dropped.

use std::io::Write;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError};
use std::time::{Duration, Instant};

/// Lines waiting to be written at most.
pub const CAPACITY: usize = 1024;

#[derive(Default)]
struct Counts {
    queued: AtomicU64,
    written: AtomicU64,
    dropped: AtomicU64,
}

/// The queue in front of stderr (cheap to clone: every clone feeds the same thread).
#[derive(Clone)]
pub struct LogQueue {
    queue: SyncSender<Vec<u8>>,
    counts: Arc<Counts>,
}

impl LogQueue {
    /// Starts the writer thread, writing to `out` (stderr in the binary).
    pub fn start<W: Write + Send + 'static>(mut out: W) -> std::io::Result<LogQueue> {
        let (queue, lines) = std::sync::mpsc::sync_channel::<Vec<u8>>(CAPACITY);
        let counts = Arc::new(Counts::default());
        let shared = Arc::clone(&counts);
        std::thread::Builder::new()
            .name("log-writer".into())
            .spawn(move || {
                for line in lines {
                    // Nowhere to report a failed log write: it counts as written.
                    let _ = out.write_all(&line).and_then(|()| out.flush());
                    shared.written.fetch_add(1, Ordering::Release);
                }
            })?;
        Ok(LogQueue { queue, counts })
    }

    fn push(&self, line: Vec<u8>) {
        match self.queue.try_send(line) {
            Ok(()) => {
                self.counts.queued.fetch_add(1, Ordering::Release);
            }
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.counts.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// Lines dropped so far.
    pub fn dropped(&self) -> u64 {
        self.counts.dropped.load(Ordering::Relaxed)
    }

    /// Waits up to `limit` for every queued line to be written; returns whether they
    /// were.
    pub fn drain(&self, limit: Duration) -> bool {
        let started = Instant::now();
        loop {
            let queued = self.counts.queued.load(Ordering::Acquire);
            if self.counts.written.load(Ordering::Acquire) >= queued {
                return true;
            }
            if started.elapsed() >= limit {
                return false;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

/// One log event's bytes, queued whole when the formatter is done with it.
pub struct QueuedLine {
    queue: LogQueue,
    buf: Vec<u8>,
}

impl Write for QueuedLine {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.buf.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Drop for QueuedLine {
    fn drop(&mut self) {
        if !self.buf.is_empty() {
            self.queue.push(std::mem::take(&mut self.buf));
        }
    }
}

impl<'a> tracing_subscriber::fmt::MakeWriter<'a> for LogQueue {
    type Writer = QueuedLine;

    fn make_writer(&'a self) -> QueuedLine {
        QueuedLine {
            queue: self.clone(),
            buf: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;
    use std::sync::Mutex;

    /// A writer the tests can stall.
    struct Gate {
        open: Arc<Mutex<bool>>,
        got: Arc<Mutex<Vec<u8>>>,
    }

    impl Write for Gate {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            while !*self.open.lock().unwrap_or_else(|p| p.into_inner()) {
                std::thread::sleep(Duration::from_millis(1));
            }
            self.got
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .extend_from_slice(buf);
            Ok(buf.len())
        }

        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_stalled_stderr_drops_lines_instead_of_blocking_and_drains_after() {
        let open = Arc::new(Mutex::new(false));
        let got = Arc::new(Mutex::new(Vec::new()));
        let queue = LogQueue::start(Gate {
            open: Arc::clone(&open),
            got: Arc::clone(&got),
        })
        .unwrap();
        let started = Instant::now();
        for k in 0..CAPACITY + 100 {
            let mut line = tracing_subscriber::fmt::MakeWriter::make_writer(&queue);
            writeln!(line, "line {k}").unwrap();
        }
        assert!(
            started.elapsed() < Duration::from_secs(1),
            "a log line waited"
        );
        // The writer holds one line, the queue the next CAPACITY.
        assert!(queue.dropped() >= 99, "{}", queue.dropped());
        assert!(!queue.drain(Duration::from_millis(50)));
        *open.lock().unwrap() = true;
        assert!(queue.drain(Duration::from_secs(5)));
        let text = String::from_utf8(got.lock().unwrap().clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.first(), Some(&"line 0"));
        assert_eq!(
            lines.len() as u64 + queue.dropped(),
            (CAPACITY + 100) as u64
        );
    }
}
