//! PNG and tether's own JPEG decoder (`tether_image::imread::decode_gray`, what
//! `tether detect`, the camera folder of `tether run` and CompressedImage frames go
//! through) on arbitrary bytes: never a panic, and never more memory than the picture
//! the header claims can justify. The header is capped before decoding
//! (`MAX_DECODE_PIXELS`; above `PLAUSIBILITY_FROM_PIXELS` the file must hold at least
//! `min_plausible_bytes`), so the peak of the heap while decoding, measured by a
//! counting allocator, must stay under a fixed slack plus a few bytes per claimed pixel
//! (a 1 KB progressive JPEG header once took 7.3 GB).

#![no_main]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use libfuzzer_sys::fuzz_target;
use tether_image::imread::{
    MAX_DECODE_PIXELS, PLAUSIBILITY_FROM_PIXELS, decode_gray_warned, dimensions,
    min_plausible_bytes,
};

/// The heap in use and its peak since the last reset.
struct Counting;

static IN_USE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grow(by: usize) {
    let now = IN_USE.fetch_add(by, Ordering::Relaxed) + by;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: every call is passed to `System` unchanged; only sizes are counted.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract is `System`'s.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as above.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) };
        IN_USE.fetch_sub(layout.size(), Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as above.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            IN_USE.fetch_sub(layout.size(), Ordering::Relaxed);
            grow(new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Heap a decode may take beyond its pixels (Huffman and quantisation tables, the png
/// crate's inflate window and row buffers, warnings).
const SLACK_BYTES: u64 = 16 << 20;
/// Heap per claimed pixel: a progressive 4-component JPEG keeps 2 bytes of
/// coefficients per sample of each component and the CMYK output; a 16-bit RGBA PNG
/// holds 8 bytes per pixel before turning grey.
const BYTES_PER_PIXEL: u64 = 24;

const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";
const JPEG: &[u8] = &[0xff, 0xd8];

fn check(bytes: &[u8]) {
    let claimed = dimensions(bytes);
    let base = IN_USE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let result = decode_gray_warned(bytes);
    let peak = (PEAK.load(Ordering::Relaxed) - base) as u64;
    let pixels = claimed.map_or(0, |(w, h)| u64::from(w) * u64::from(h));
    let bound = SLACK_BYTES.saturating_add(BYTES_PER_PIXEL.saturating_mul(pixels));
    assert!(
        peak <= bound,
        "decoding {} bytes claiming {claimed:?} took {peak} bytes of heap (bound {bound})",
        bytes.len()
    );
    if let Ok((image, _warnings)) = result {
        let (w, h) = (image.width() as u64, image.height() as u64);
        assert!(w * h <= MAX_DECODE_PIXELS, "{w}x{h} decoded");
        assert!(w > 0 && h > 0);
        // The header scan must see the frame the decoder decoded (or the cap is not
        // applied), at its size or swapped by an EXIF rotation.
        let (cw, ch) = claimed.expect("a decoded file has a size in its header");
        let (cw, ch) = (u64::from(cw), u64::from(ch));
        assert!(
            (w, h) == (cw, ch) || (w, h) == (ch, cw),
            "{w}x{h} from {cw}x{ch}"
        );
        if w * h > PLAUSIBILITY_FROM_PIXELS {
            assert!(bytes.len() as u64 >= min_plausible_bytes(bytes, cw as u32, ch as u32));
        }
    }
}

fuzz_target!(|data: &[u8]| {
    // Most mutations of random bytes would fail the signature: unless the input already
    // starts with one (the seeds do), put one in front of all but a few, chosen by the
    // first byte.
    let signed = data.starts_with(PNG) || data.starts_with(JPEG);
    let prefix: &[u8] = match data.first().map(|b| b % 4) {
        Some(0) if !signed => PNG,
        Some(1) if !signed => JPEG,
        _ => b"",
    };
    let mut bytes = Vec::with_capacity(data.len() + prefix.len());
    bytes.extend_from_slice(prefix);
    bytes.extend_from_slice(data);
    check(&bytes);
});
