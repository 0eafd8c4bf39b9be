//! Which kind of recording a file is, from its first bytes (never its name): the one
//! place that tells a ROS 1 bag from an MCAP file, and says what any other file looks
//! like (an image, a SQLite `.db3` bag, compressed data, text...) so that a refusal
//! names it. `tether info` and every command that reads a recording ([`crate::samples`])
//! ask here.

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The first line of a ROS 1 bag of format 2.0.
pub const BAG_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// How many first bytes are read to tell a file's kind and to show it.
const HEAD_BYTES: u64 = 64;

/// The kind of recording a file is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A ROS 1 bag, format 2.0.
    Ros1Bag,
    /// An MCAP file.
    Mcap,
}

/// Why a path is not a recording tether reads.
#[derive(Debug)]
pub enum SniffError {
    /// The file cannot be opened or read.
    Io {
        /// The path given.
        path: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// A folder (a ROS 2 bag folder, often): [`folder_refusal`] says what it holds.
    Folder(String),
    /// A file of another kind: the path and what its first bytes look like
    /// ([`describe`]).
    Other {
        /// The path given.
        path: PathBuf,
        /// What the file starts with and may be.
        looks_like: String,
    },
}

impl fmt::Display for SniffError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SniffError::Io { path, source } => {
                write!(f, "cannot open {}: {source}", path.display())
            }
            SniffError::Folder(why) => f.write_str(why),
            SniffError::Other { path, looks_like } => write!(
                f,
                "{} is not a ROS 1 bag or MCAP file: {looks_like}",
                path.display()
            ),
        }
    }
}

impl std::error::Error for SniffError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SniffError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// The kind of recording at `path`, from its first bytes.
pub fn sniff(path: &Path) -> Result<Kind, SniffError> {
    let io = |source| SniffError::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.is_dir() {
        return Err(SniffError::Folder(folder_refusal(path)));
    }
    let mut head = Vec::with_capacity(HEAD_BYTES as usize);
    std::fs::File::open(path)
        .and_then(|f| f.take(HEAD_BYTES).read_to_end(&mut head))
        .map_err(io)?;
    kind_of(&head).ok_or_else(|| SniffError::Other {
        path: path.to_path_buf(),
        looks_like: describe(&head, meta.len()),
    })
}

/// The kind of recording that starts with `head`, if any.
pub fn kind_of(head: &[u8]) -> Option<Kind> {
    if head.starts_with(crate::mcap::MAGIC) {
        Some(Kind::Mcap)
    } else if head.starts_with(BAG_MAGIC) {
        Some(Kind::Ros1Bag)
    } else {
        None
    }
}

/// Why a folder is refused, with the recordings it may hold (a ROS 2 bag folder holds an
/// `.mcap` or a `.db3` file and its `metadata.yaml`).
pub fn folder_refusal(path: &Path) -> String {
    let mut inside: Vec<String> = std::fs::read_dir(path)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".mcap") || n.ends_with(".bag") || n.ends_with(".db3"))
                .collect()
        })
        .unwrap_or_default();
    inside.sort();
    let db3 = if inside.iter().any(|n| n.ends_with(".db3")) {
        " (SQLite .db3 bags are not read: `ros2 bag convert` writes MCAP)"
    } else {
        ""
    };
    if inside.is_empty() {
        format!("{} is a folder, not a recording file", path.display())
    } else {
        format!(
            "{} is a folder, not a recording file; it holds {}: give one of them{db3}",
            path.display(),
            inside.join(", ")
        )
    }
}

/// What a file that is neither kind starts with (`head`, its first bytes), what it may
/// be, and how long it is (`len` bytes).
pub fn describe(head: &[u8], len: u64) -> String {
    if head.is_empty() {
        return "it is empty (0 bytes; an interrupted copy or recording?)".to_owned();
    }
    let known: &[(&[u8], &str)] = &[
        (
            b"#ROSBAG V",
            "a ROS bag of another format version; tether reads 2.0",
        ),
        (
            b"SQLite format 3\0",
            "a SQLite database (a ROS 2 .db3 bag? convert it to MCAP: \
             `ros2 bag convert` or `rosbags-convert`)",
        ),
        (&crate::mcap::MAGIC[..5], "an MCAP magic of another version"),
        (b"\x89PNG\r\n\x1a\n", "a PNG image"),
        (b"\xff\xd8\xff", "a JPEG image"),
        (b"\x1f\x8b", "gzip data (decompress it first)"),
        (b"BZh", "bzip2 data (decompress it first)"),
        (b"\x28\xb5\x2f\xfd", "zstd data (decompress it first)"),
        (b"\x04\x22\x4d\x18", "LZ4 frame data (decompress it first)"),
        (b"PK\x03\x04", "a zip archive (unpack it first)"),
        (b"\x7fELF", "an ELF executable"),
        (b"%PDF", "a PDF document"),
    ];
    let what = known
        .iter()
        .find(|(magic, _)| head.starts_with(magic))
        .map(|(_, what)| *what);
    let shown = &head[..head.len().min(16)];
    let text = std::str::from_utf8(shown).ok().filter(|s| {
        s.chars()
            .all(|c| !c.is_control() || c == '\n' || c == '\r' || c == '\t')
    });
    let bytes = match text {
        Some(t) => format!("{t:?}"),
        None => {
            let hex: Vec<String> = shown.iter().map(|b| format!("{b:02x}")).collect();
            format!("the bytes {}", hex.join(" "))
        }
    };
    let what = what.unwrap_or(if text.is_some() {
        "text"
    } else {
        "no format tether knows"
    });
    format!(
        "it starts with {bytes} ({what}; {len} bytes); a ROS 1 bag starts with \
         \"#ROSBAG V2.0\\n\", an MCAP file with \"\\x89MCAP0\\r\\n\""
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn other_files_are_named() {
        assert!(describe(b"", 0).contains("empty"));
        assert!(describe(b"SQLite format 3\0xyz", 100).contains("SQLite"));
        assert!(describe(b"hello world\n", 12).contains("\"hello world\\n\" (text"));
        assert!(describe(&[0, 1, 2, 250], 4).contains("00 01 02 fa"));
    }

    #[test]
    fn the_two_kinds_are_told_by_their_first_bytes() {
        assert_eq!(kind_of(b"#ROSBAG V2.0\nrest"), Some(Kind::Ros1Bag));
        assert_eq!(kind_of(b"\x89MCAP0\r\nrest"), Some(Kind::Mcap));
        assert_eq!(kind_of(b"#ROSBAG V1.2\n"), None);
        assert_eq!(kind_of(b""), None);
    }
}
