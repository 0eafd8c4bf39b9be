//! Crafted files: a minimal baseline writer, then cases whose expected pixels are worked
//! out by hand or were taken from `cv2.imread(..., cv2.IMREAD_GRAYSCALE)` (OpenCV 4.14)
//! on the same bytes (`cargo test -p tether-image jpeg::tests::dump -- --ignored`
//! writes them to `$TETHER_JPEG_DUMP`).

use super::huffman::NATURAL_ORDER;
use super::*;

const DC_COUNTS: [u8; 16] = [0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0];
const AC_COUNTS: [u8; 16] = [0, 2, 1, 3, 3, 2, 4, 3, 5, 5, 4, 4, 0, 0, 1, 0x7d];

fn std_ac_symbols() -> Vec<u8> {
    let spec = HuffSpec::std_ac_luminance();
    spec.symbols[..162].to_vec()
}

/// Canonical codes of a table: symbol -> (code, length).
fn codes(counts: &[u8; 16], symbols: &[u8]) -> Vec<Option<(u32, u32)>> {
    let mut out = vec![None; 256];
    let (mut code, mut k) = (0u32, 0usize);
    for (l, &n) in counts.iter().enumerate() {
        for _ in 0..n {
            out[usize::from(symbols[k])] = Some((code, l as u32 + 1));
            code += 1;
            k += 1;
        }
        code <<= 1;
    }
    out
}

fn segment(marker: u8, payload: &[u8]) -> Vec<u8> {
    let mut s = vec![0xff, marker];
    s.extend_from_slice(&((payload.len() + 2) as u16).to_be_bytes());
    s.extend_from_slice(payload);
    s
}

/// A grey baseline file of `blocks` (natural-order quantised coefficients, raster
/// order) with one quantisation table.
struct Grey {
    width: u16,
    height: u16,
    blocks: Vec<[i16; 64]>,
    quant: [u16; 64],
    restart: u16,
    /// Write the Huffman tables (false: rely on the standard ones, as MJPEG does).
    dht: bool,
    sof: u8,
    extra_headers: Vec<u8>,
}

impl Grey {
    fn new(width: u16, height: u16, blocks: Vec<[i16; 64]>, q: u16) -> Self {
        Grey {
            width,
            height,
            blocks,
            quant: [q; 64],
            restart: 0,
            dht: true,
            sof: 0xc0,
            extra_headers: Vec::new(),
        }
    }

    fn encode(&self) -> Vec<u8> {
        let mut out = vec![0xff, 0xd8];
        out.extend_from_slice(&self.extra_headers);
        if self.quant.iter().any(|&q| q > 255) {
            let mut p = vec![0x10];
            for &pos in &NATURAL_ORDER[..64] {
                p.extend_from_slice(&self.quant[pos].to_be_bytes());
            }
            out.extend(segment(0xdb, &p));
        } else {
            let mut p = vec![0x00];
            p.extend((0..64).map(|k| self.quant[NATURAL_ORDER[k]] as u8));
            out.extend(segment(0xdb, &p));
        }
        let mut sof = vec![8];
        sof.extend_from_slice(&self.height.to_be_bytes());
        sof.extend_from_slice(&self.width.to_be_bytes());
        sof.extend_from_slice(&[1, 1, 0x11, 0]);
        out.extend(segment(self.sof, &sof));
        let ac_symbols = std_ac_symbols();
        if self.dht {
            let mut p = vec![0x00];
            p.extend_from_slice(&DC_COUNTS);
            p.extend(0..12u8);
            out.extend(segment(0xc4, &p));
            let mut p = vec![0x10];
            p.extend_from_slice(&AC_COUNTS);
            p.extend_from_slice(&ac_symbols);
            out.extend(segment(0xc4, &p));
        }
        if self.restart > 0 {
            out.extend(segment(0xdd, &self.restart.to_be_bytes()));
        }
        out.extend(segment(0xda, &[1, 1, 0x00, 0, 63, 0]));
        let dc = codes(&DC_COUNTS, &(0..12).collect::<Vec<u8>>());
        let ac = codes(&AC_COUNTS, &ac_symbols);
        let mut bits = BitWriter::default();
        let mut pred = 0i32;
        for (n, b) in self.blocks.iter().enumerate() {
            if self.restart > 0 && n > 0 && n % usize::from(self.restart) == 0 {
                bits.flush(&mut out);
                out.extend_from_slice(&[
                    0xff,
                    0xd0 + ((n / usize::from(self.restart) - 1) % 8) as u8,
                ]);
                pred = 0;
            }
            let d = i32::from(b[0]) - pred;
            pred = i32::from(b[0]);
            let (cat, v) = magnitude(d);
            bits.put(dc[cat as usize].expect("DC code"), &mut out);
            bits.put((v, cat), &mut out);
            let mut run = 0;
            for k in 1..64 {
                let c = i32::from(b[NATURAL_ORDER[k]]);
                if c == 0 {
                    run += 1;
                    continue;
                }
                while run > 15 {
                    bits.put(ac[0xf0].expect("ZRL"), &mut out);
                    run -= 16;
                }
                let (cat, v) = magnitude(c);
                bits.put(ac[(run << 4) | cat as usize].expect("AC code"), &mut out);
                bits.put((v, cat), &mut out);
                run = 0;
            }
            if run > 0 {
                bits.put(ac[0].expect("EOB"), &mut out);
            }
        }
        bits.flush(&mut out);
        out.extend_from_slice(&[0xff, 0xd9]);
        out
    }
}

/// JPEG magnitude category and its bits.
fn magnitude(v: i32) -> (u32, u32) {
    let cat = 32 - v.unsigned_abs().leading_zeros();
    let bits = if v >= 0 { v } else { v + (1 << cat) - 1 } as u32;
    (cat, bits)
}

#[derive(Default)]
struct BitWriter {
    acc: u32,
    n: u32,
}

impl BitWriter {
    fn put(&mut self, (code, len): (u32, u32), out: &mut Vec<u8>) {
        for i in (0..len).rev() {
            self.acc = (self.acc << 1) | ((code >> i) & 1);
            self.n += 1;
            if self.n == 8 {
                out.push(self.acc as u8);
                if self.acc == 0xff {
                    out.push(0);
                }
                self.acc = 0;
                self.n = 0;
            }
        }
    }

    fn flush(&mut self, out: &mut Vec<u8>) {
        while self.n != 0 {
            self.put((1, 1), out);
        }
    }
}

fn dc_block(dc: i16) -> [i16; 64] {
    let mut b = [0; 64];
    b[0] = dc;
    b
}

fn decode(data: &[u8]) -> JpegGray {
    decode_gray(data).unwrap_or_else(|e| panic!("{e}"))
}

/// Columns `0..8` and `8..16` of a 16x8 image are flat `a` and `b`.
fn assert_two_flat_blocks(g: &JpegGray, a: u8, b: u8) {
    assert_eq!((g.width, g.height), (16, 8));
    for row in g.pixels.chunks(16) {
        assert_eq!(row[..8], [a; 8], "{:?}", g.pixels);
        assert_eq!(row[8..], [b; 8], "{:?}", g.pixels);
    }
}

/// The crafted cases whose expectations come from OpenCV, by name.
fn crafted() -> Vec<(&'static str, Vec<u8>)> {
    let two = || Grey::new(16, 8, vec![dc_block(40), dc_block(-25)], 2);
    let mut out = Vec::new();
    // A block where jidctint.c (wrap-around) and libjpeg-turbo's SIMD IDCT (saturation)
    // disagree.
    let mut extreme = [0i16; 64];
    extreme[0] = 1000;
    extreme[8] = 1000;
    extreme[1] = 900;
    out.push(("extreme", Grey::new(8, 8, vec![extreme], 30).encode()));
    // Restart interval 1 with the first RST marker removed.
    let mut g = two();
    g.restart = 1;
    let data = g.encode();
    let at = data
        .windows(2)
        .position(|w| w == [0xff, 0xd0])
        .expect("RST0");
    let mut missing = data.clone();
    missing.drain(at..at + 2);
    out.push(("restart_missing", missing));
    // Truncated in the second block: it is decoded from zero bits.
    let mut g = two();
    g.blocks[1][1] = 5;
    g.blocks[1][8] = -3;
    let data = g.encode();
    out.push(("truncated", data[..data.len() - 4].to_vec()));
    out
}

/// OpenCV's pixels for the [`crafted`] cases, row-major.
fn opencv_expectation(name: &str) -> Vec<u8> {
    match name {
        "extreme" => vec![
            255, 255, 255, 255, 255, 255, 0, 0, 255, 255, 255, 255, 255, 255, 0, 0, 255, 255, 255,
            255, 255, 255, 0, 0, 255, 255, 255, 255, 255, 255, 0, 0, 255, 255, 255, 255, 255, 255,
            0, 0, 255, 255, 255, 255, 255, 127, 0, 0, 255, 255, 255, 0, 0, 0, 0, 0, 255, 255, 0, 0,
            0, 0, 0, 0,
        ],
        "restart_missing" => vec![
            138, 138, 138, 138, 138, 138, 138, 138, 114, 132, 125, 129, 127, 128, 127, 128, 138,
            138, 138, 138, 138, 138, 138, 138, 132, 127, 129, 128, 129, 128, 129, 128, 138, 138,
            138, 138, 138, 138, 138, 138, 125, 129, 128, 128, 128, 128, 128, 128, 138, 138, 138,
            138, 138, 138, 138, 138, 129, 128, 129, 128, 128, 128, 128, 128, 138, 138, 138, 138,
            138, 138, 138, 138, 127, 129, 128, 128, 128, 128, 128, 128, 138, 138, 138, 138, 138,
            138, 138, 138, 128, 128, 128, 128, 128, 128, 128, 128, 138, 138, 138, 138, 138, 138,
            138, 138, 127, 129, 128, 128, 128, 128, 128, 128, 138, 138, 138, 138, 138, 138, 138,
            138, 128, 128, 128, 128, 128, 128, 128, 128,
        ],
        "truncated" => vec![
            138, 138, 138, 138, 138, 138, 138, 138, 107, 125, 118, 123, 120, 122, 121, 121, 138,
            138, 138, 138, 138, 138, 138, 138, 125, 120, 122, 121, 122, 121, 122, 122, 138, 138,
            138, 138, 138, 138, 138, 138, 118, 122, 121, 122, 121, 122, 121, 121, 138, 138, 138,
            138, 138, 138, 138, 138, 123, 121, 122, 121, 122, 121, 122, 122, 138, 138, 138, 138,
            138, 138, 138, 138, 120, 122, 121, 122, 121, 122, 121, 121, 138, 138, 138, 138, 138,
            138, 138, 138, 122, 121, 122, 121, 122, 121, 122, 122, 138, 138, 138, 138, 138, 138,
            138, 138, 121, 122, 121, 122, 121, 122, 121, 121, 138, 138, 138, 138, 138, 138, 138,
            138, 121, 122, 121, 122, 121, 122, 121, 121,
        ],
        _ => Vec::new(),
    }
}

/// The crafted files written as files (into `$TETHER_JPEG_DUMP` when set, to check them
/// against OpenCV by hand: that is where the expectations below came from) and read
/// back through [`crate::imread_gray`] decode as from memory.
#[test]
fn crafted_files_read_from_disk_as_from_memory() {
    let dir = match std::env::var_os("TETHER_JPEG_DUMP") {
        Some(dir) => std::path::PathBuf::from(dir),
        None => std::env::temp_dir().join(format!("tether-jpeg-crafted-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).expect("a writable folder");
    for (name, data) in crafted() {
        let path = dir.join(format!("{name}.jpg"));
        std::fs::write(&path, &data).expect("write");
        let expected = opencv_expectation(name);
        if expected.is_empty() {
            continue;
        }
        let read = crate::imread_gray(&path).expect("a crafted file with an expectation reads");
        assert_eq!(read.pixels(), expected.as_slice(), "{name}");
    }
    if std::env::var_os("TETHER_JPEG_DUMP").is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn crafted_files_match_opencv() {
    for (name, data) in crafted() {
        let expected = opencv_expectation(name);
        if expected.is_empty() {
            continue;
        }
        assert_eq!(decode(&data).pixels, expected, "{name}");
    }
}

#[test]
fn dc_only_blocks_by_hand() {
    // DC 40 * q 2 = 80: first pass 320, second (320 + 16) >> 5 = 10, + 128 = 138.
    // DC -25 * 2 = -50: -200, (-200 + 16) >> 5 = -6 (arithmetic shift), + 128 = 122.
    let g = decode(&Grey::new(16, 8, vec![dc_block(40), dc_block(-25)], 2).encode());
    assert_two_flat_blocks(&g, 138, 122);
    assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    // A 16-bit quantisation table: 1 * 1000 -> 4000 -> (4000 + 16) >> 5 = 125 -> 253.
    let mut one = Grey::new(8, 8, vec![dc_block(1)], 1);
    one.quant[0] = 1000;
    assert_eq!(decode(&one.encode()).pixels, vec![253; 64]);
}

#[test]
fn restart_markers() {
    let mut g = Grey::new(16, 8, vec![dc_block(40), dc_block(-25)], 2);
    g.restart = 1;
    let data = g.encode();
    assert!(data.windows(2).any(|w| w == [0xff, 0xd0]));
    assert_two_flat_blocks(&decode(&data), 138, 122);
    // RST3 where RST0 is expected: too far from 0 to be a neighbour, so libjpeg drops
    // it and carries on; the picture is unchanged.
    let at = data
        .windows(2)
        .position(|w| w == [0xff, 0xd0])
        .expect("RST0");
    let mut wrong = data.clone();
    wrong[at + 1] = 0xd3;
    let d = decode(&wrong);
    assert_two_flat_blocks(&d, 138, 122);
    assert!(matches!(
        d.warnings.as_slice(),
        [Warning::RestartResync { expected: 0, .. }]
    ));
}

#[test]
fn missing_tables_markers_and_fill_bytes() {
    let base = Grey::new(16, 8, vec![dc_block(40), dc_block(-25)], 2);
    // No DHT: libjpeg-turbo uses the standard tables (Motion-JPEG frames).
    let mut g = Grey::new(16, 8, base.blocks.clone(), 2);
    g.dht = false;
    assert_two_flat_blocks(&decode(&g.encode()), 138, 122);
    // COM, APP5 and DNL segments are skipped; fill bytes before a marker are allowed.
    let mut g = Grey::new(16, 8, base.blocks.clone(), 2);
    g.extra_headers.extend(segment(0xfe, b"a comment"));
    g.extra_headers.extend(segment(0xe5, &[1, 2, 3, 4]));
    g.extra_headers.extend_from_slice(&[0xff, 0xff, 0xff]);
    g.extra_headers.extend(segment(0xdc, &[0, 8]));
    let d = decode(&g.encode());
    assert_two_flat_blocks(&d, 138, 122);
    assert!(d.warnings.is_empty(), "{:?}", d.warnings);
    // Garbage between segments: skipped with a warning.
    let mut g = Grey::new(16, 8, base.blocks.clone(), 2);
    g.extra_headers.extend_from_slice(b"junk");
    let d = decode(&g.encode());
    assert_two_flat_blocks(&d, 138, 122);
    assert!(matches!(
        d.warnings.as_slice(),
        [Warning::ExtraneousBytes { count: 4, .. }]
    ));
    // SOF1 (extended sequential) decodes like SOF0.
    let mut g = Grey::new(16, 8, base.blocks.clone(), 2);
    g.sof = 0xc1;
    assert_two_flat_blocks(&decode(&g.encode()), 138, 122);
}

#[test]
fn truncated_data_is_grey() {
    // Sixteen blocks; the file stops a few bytes into the data. libjpeg decodes the
    // MCU in which the data runs out from zero bits and leaves the rest zero: 128.
    let blocks: Vec<[i16; 64]> = (0..16).map(|i| dc_block(30 + i)).collect();
    let data = Grey::new(128, 8, blocks, 1).encode();
    let sos = data
        .windows(2)
        .position(|w| w == [0xff, 0xda])
        .expect("SOS");
    let cut = &data[..sos + 2 + 8 + 3];
    let g = decode(cut);
    assert!(
        matches!(g.warnings[0], Warning::PrematureEnd { .. }),
        "{:?}",
        g.warnings
    );
    let last = &g.pixels[120..128];
    assert_eq!(last, [128; 8]);
    assert_ne!(g.pixels[0], 128);
}

#[test]
fn errors_name_the_marker_and_offset() {
    let ok = Grey::new(8, 8, vec![dc_block(3)], 1).encode();
    let err = |data: &[u8]| decode_gray(data).expect_err("must fail");

    let e = err(b"GIF89a");
    assert_eq!(e.kind, JpegErrorKind::Corrupt);
    assert!(e.to_string().contains("not a JPEG file"), "{e}");

    // SOS before SOF.
    let sof = ok.windows(2).position(|w| w == [0xff, 0xc0]).expect("SOF");
    let mut no_sof = ok.clone();
    no_sof[sof + 1] = 0xfe; // the SOF becomes a comment
    let e = err(&no_sof);
    assert!(e.to_string().contains("SOS before SOF"), "{e}");
    assert_eq!(e.marker, Some(0xda));

    let kind_of = |sof_code: u8, precision: u8| {
        let mut d = ok.clone();
        d[sof + 1] = sof_code;
        d[sof + 4] = precision;
        err(&d)
    };
    let e = kind_of(0xc3, 8);
    assert_eq!(e.kind, JpegErrorKind::Unsupported);
    assert!(e.to_string().contains("lossless"), "{e}");
    let e = kind_of(0xcb, 8);
    assert_eq!(e.kind, JpegErrorKind::Unsupported);
    assert!(e.to_string().contains("lossless arithmetic"), "{e}");
    let e = kind_of(0xc0, 12);
    assert!(e.to_string().contains("12-bit"), "{e}");
    assert!(
        e.to_string().contains(&format!("at byte {}", sof + 2)),
        "{e}"
    );

    // A quantisation table that was never defined.
    let mut d = ok.clone();
    d[sof + 12] = 1;
    let e = err(&d);
    assert!(e.to_string().contains("quantization table 0x01"), "{e}");

    // A DHT with a bogus index.
    let dht = ok.windows(2).position(|w| w == [0xff, 0xc4]).expect("DHT");
    let mut d = ok.clone();
    d[dht + 4] = 0x07;
    let e = err(&d);
    assert!(e.to_string().contains("DHT"), "{e}");

    // Truncated before the image data.
    let e = err(&ok[..sof + 5]);
    assert!(e.to_string().contains("truncated"), "{e}");
    assert_eq!(e.offset, sof + 5);

    // A progressive file needs its Huffman tables (no standard ones there).
    let mut g = Grey::new(8, 8, vec![dc_block(3)], 1);
    g.dht = false;
    g.sof = 0xc2;
    let mut d = g.encode();
    let sos = d.windows(2).position(|w| w == [0xff, 0xda]).expect("SOS");
    // A DC-first scan: Ss = Se = 0.
    d[sos + 8] = 0;
    let e = err(&d);
    assert!(
        e.to_string().contains("Huffman table 0x00 was not defined"),
        "{e}"
    );
}

#[test]
fn two_components_are_refused_like_opencv() {
    let ok = Grey::new(8, 8, vec![dc_block(3)], 1).encode();
    let sof = ok.windows(2).position(|w| w == [0xff, 0xc0]).expect("SOF");
    // Rewrite the SOF with two components (the scan still names one).
    let mut d = ok[..sof].to_vec();
    d.extend(segment(0xc0, &[8, 0, 8, 0, 8, 2, 1, 0x11, 0, 2, 0x11, 0]));
    d.extend_from_slice(&ok[sof + 2 + 11..]);
    let e = decode_gray(&d).expect_err("2 components");
    assert_eq!(e.kind, JpegErrorKind::Unsupported);
    assert!(e.to_string().contains("2-component"), "{e}");
}
