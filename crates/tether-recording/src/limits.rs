//! Caps on what a file can make a reader allocate: sizes read from a file are checked
//! against them (and against the bytes actually there) before anything is allocated
//! or decompressed, so that a damaged file or a decompression bomb is refused with an
//! error instead of exhausting memory.
//!
//! The caps come from what real recordings do:
//!
//! - `rosbag record` closes a chunk once it holds more than 768 KiB (its default
//!   `--chunksize`); the chunks of leg_tracker's bags hold 309 to 789 KB. `ros2 bag` and
//!   the `mcap` writers use chunks of about 1 MiB (tether's writer too). A chunk is
//!   bigger than that only when one message is (an uncompressed HD image is 6 MB), so
//!   [`MAX_CHUNK_BYTES`] = 256 MiB leaves room for 40 such images in one chunk.
//! - Laser data compress about 11:1 with bz2 and 4.4:1 with lz4 (a 787 KB chunk of the
//!   demo bag); lz4 cannot exceed about 255:1. Only degenerate data go further: 768 KiB
//!   of zeros is 17 000:1 in bz2, and a bz2 bomb reaches 1 000 000:1 (a 7.4 KB chunk
//!   that inflates to 4 GiB). A chunk may therefore inflate [`MAX_CHUNK_RATIO`] = 1000
//!   times its stored size, and any chunk may inflate to [`RATIO_FREE_BYTES`] = 4 MiB
//!   (a small chunk of zeros is legitimate and cheap).

/// Largest uncompressed chunk a reader accepts, bytes (both ROS 1 bags and MCAP).
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

/// Largest ratio of a chunk's uncompressed size to its stored (compressed) size, for
/// chunks above [`RATIO_FREE_BYTES`].
pub const MAX_CHUNK_RATIO: u64 = 1000;

/// A chunk may claim this many uncompressed bytes whatever its stored size.
pub const RATIO_FREE_BYTES: u64 = 4 << 20;

/// Checks a compressed chunk's claimed uncompressed size against the caps; the error
/// says which cap and by how much, for the caller to put in its own error.
pub fn check_chunk_size(uncompressed: u64, stored: u64) -> Result<(), String> {
    if uncompressed > MAX_CHUNK_BYTES {
        return Err(format!(
            "it claims {uncompressed} bytes uncompressed, more than the {MAX_CHUNK_BYTES} \
             (256 MiB) a chunk may hold; refused as corrupt or a decompression bomb"
        ));
    }
    if uncompressed > RATIO_FREE_BYTES && uncompressed / stored.max(1) >= MAX_CHUNK_RATIO {
        return Err(format!(
            "it claims {uncompressed} bytes uncompressed from {stored} stored, a ratio over \
             {MAX_CHUNK_RATIO}:1 (real recordings compress about 11:1); refused as a \
             decompression bomb"
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn real_chunks_pass_and_bombs_do_not() {
        // The demo bag's biggest chunk, stored plain, bz2 and lz4.
        for stored in [787_393, 71_786, 177_316] {
            assert!(check_chunk_size(787_393, stored).is_ok());
        }
        // 768 KiB of zeros in bz2: 46 bytes stored, small enough to allow.
        assert!(check_chunk_size(768 << 10, 46).is_ok());
        // The 7.4 KB bag whose chunk claims 4 GiB.
        let e = check_chunk_size(u64::from(u32::MAX), 7400).unwrap_err();
        assert!(e.contains("256 MiB"), "{e}");
        // 100 MiB from 50 KB: refused by the ratio.
        let e = check_chunk_size(100 << 20, 50_000).unwrap_err();
        assert!(e.contains("1000:1"), "{e}");
        assert!(check_chunk_size(100 << 20, 200_000).is_ok());
        assert!(check_chunk_size(MAX_CHUNK_BYTES, MAX_CHUNK_BYTES).is_ok());
        assert!(check_chunk_size(5 << 20, 0).is_err());
    }
}
