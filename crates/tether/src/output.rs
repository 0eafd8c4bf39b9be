//! Output files that appear only when the command that writes them succeeds: the data
//! go to a temporary file beside the target (same folder, so the rename cannot cross
//! file systems), which replaces the target on [`AtomicFile::commit`]. A command that
//! fails (a missing topic, a damaged recording, Ctrl-C) leaves an earlier result as it
//! was and no partial file behind.

use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// A file written in full, then renamed onto its path.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    partial: PathBuf,
    file: Option<File>,
}

impl AtomicFile {
    /// Starts `path`: creates its temporary file (`.NAME.partial-PID` in the same
    /// folder). The target itself is not touched until [`AtomicFile::commit`].
    pub fn create(path: impl AsRef<Path>) -> io::Result<AtomicFile> {
        let path = path.as_ref().to_path_buf();
        let name = path
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "not a file name"))?
            .to_string_lossy()
            .into_owned();
        let partial = path.with_file_name(format!(".{name}.partial-{}", std::process::id()));
        let file = File::create(&partial)?;
        Ok(AtomicFile {
            path,
            partial,
            file: Some(file),
        })
    }

    /// The path the file will have.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes everything out and puts the file in its place.
    pub fn commit(mut self) -> io::Result<()> {
        if let Some(mut file) = self.file.take() {
            file.flush()?;
            file.sync_all()?;
            drop(file);
            std::fs::rename(&self.partial, &self.path)?;
        }
        Ok(())
    }

    fn file(&mut self) -> io::Result<&mut File> {
        self.file
            .as_mut()
            .ok_or_else(|| io::Error::other("the file was already committed"))
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file()?.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file()?.flush()
    }
}

impl Seek for AtomicFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.file()?.seek(pos)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        // Not committed: the command failed, and its partial output goes.
        if self.file.take().is_some() {
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

/// Standard output was closed by its reader (`tether demo | head -1`): the command ends
/// there, cleanly. `main` exits with status 0 and prints nothing more.
#[derive(Debug, thiserror::Error)]
#[error("standard output was closed by its reader")]
pub struct StdoutClosed;

/// True when `err` (or one of its causes) is [`StdoutClosed`], itself or inside an
/// `io::Error` (as [`Output`] reports it), or inside a `serde_json::Error` of a JSON
/// writer on an [`Output`] (which keeps only the `io::Error`'s kind, `BrokenPipe`: only
/// standard output, a pipe, has that kind; an [`Output`] file never does).
pub fn is_stdout_closed(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause.is::<StdoutClosed>()
            || cause
                .downcast_ref::<io::Error>()
                .and_then(io::Error::get_ref)
                .is_some_and(|inner| inner.is::<StdoutClosed>())
            || cause
                .downcast_ref::<serde_json::Error>()
                .and_then(serde_json::Error::io_error_kind)
                == Some(io::ErrorKind::BrokenPipe)
    })
}

/// Where a command writes its one stream of results: a file written atomically
/// ([`AtomicFile`]), or standard output when the path is `-`.
pub enum Output {
    /// A file, renamed into place by [`Output::commit`].
    File(io::BufWriter<AtomicFile>),
    /// Standard output (`--out -`).
    Stdout(io::BufWriter<io::Stdout>),
}

impl Output {
    /// `-` is standard output; anything else a file created by [`AtomicFile::create`].
    pub fn create(path: &Path) -> io::Result<Output> {
        if path.as_os_str() == "-" {
            Ok(Output::Stdout(io::BufWriter::new(io::stdout())))
        } else {
            Ok(Output::File(io::BufWriter::new(AtomicFile::create(path)?)))
        }
    }

    /// True for standard output: the command's own messages then go to stderr.
    pub fn is_stdout(&self) -> bool {
        matches!(self, Output::Stdout(_))
    }

    /// Flushes, and puts a file in its place.
    pub fn commit(self) -> io::Result<()> {
        match self {
            Output::File(w) => w
                .into_inner()
                .map_err(io::IntoInnerError::into_error)
                .and_then(AtomicFile::commit),
            Output::Stdout(mut w) => w.flush().map_err(closed),
        }
    }
}

/// A broken pipe on stdout becomes [`StdoutClosed`] (inside the `io::Error`).
fn closed(e: io::Error) -> io::Error {
    if e.kind() == io::ErrorKind::BrokenPipe {
        io::Error::new(io::ErrorKind::BrokenPipe, StdoutClosed)
    } else {
        e
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Output::File(w) => w.write(buf),
            Output::Stdout(w) => w.write(buf).map_err(closed),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Output::File(w) => w.flush(),
            Output::Stdout(w) => w.flush().map_err(closed),
        }
    }
}

/// Writes `args` and a newline to standard output. A pipe closed by its reader is
/// [`StdoutClosed`] (where `println!` would panic); any other failure names stdout.
pub fn print_line(args: std::fmt::Arguments<'_>) -> anyhow::Result<()> {
    let mut out = io::stdout().lock();
    let written = out
        .write_fmt(args)
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
    match written {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Err(StdoutClosed.into()),
        Err(e) => Err(anyhow::Error::new(e).context("cannot write to standard output")),
    }
}

/// `println!` that returns an error instead of panicking when stdout is closed: see
/// [`print_line`]. Use as `tether::outln!("{x}")?;`.
#[macro_export]
macro_rules! outln {
    () => {
        $crate::output::print_line(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::output::print_line(format_args!($($arg)*))
    };
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("tether-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_result_replaces_the_old_one_only_when_committed() {
        let d = dir("commit");
        let path = d.join("t.jsonl");
        std::fs::write(&path, "earlier result\n").unwrap();
        {
            let mut f = AtomicFile::create(&path).unwrap();
            f.write_all(b"half a resu").unwrap();
            // Dropped: the command failed.
        }
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "earlier result\n");
        assert_eq!(
            std::fs::read_dir(&d).unwrap().count(),
            1,
            "no partial file left"
        );
        let mut f = AtomicFile::create(&path).unwrap();
        f.write_all(b"new result\n").unwrap();
        f.seek(SeekFrom::Start(0)).unwrap();
        f.write_all(b"N").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "New result\n");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_folder_that_does_not_exist_fails_at_once() {
        let d = dir("missing");
        assert!(AtomicFile::create(d.join("nope/t.jsonl")).is_err());
        assert!(AtomicFile::create("/").is_err());
        let _ = std::fs::remove_dir_all(&d);
    }
}
