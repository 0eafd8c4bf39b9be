//! From decoded component planes to the grey image: the output pass of a multi-scan
//! file (`decompress_data` / `decompress_smooth_data`), upsampling (`jdsample.c`) and
//! colour conversion (`jdcolor.c`, and OpenCV's CMYK to grey).

use super::idct::idct_block;
use super::smooth::{smooth_component, smoothing_latches};
use super::{ColorModel, Component, Decoder, Frame, JpegError};

impl Decoder<'_> {
    /// IDCT of the buffered coefficients of every needed component.
    pub(crate) fn output_pass(&mut self) -> Result<(), JpegError> {
        let input_scan_number = self.input_scan_number;
        let last_good = self.last_good_imcu_row;
        let frame = self
            .frame
            .as_mut()
            .ok_or_else(|| JpegError::corrupt(0, None, "no frame header"))?;
        let latches = smoothing_latches(frame, input_scan_number);
        let total = frame.total_imcu_rows;
        for (ci, c) in frame.comps.iter_mut().enumerate() {
            if !c.needed {
                continue;
            }
            match latches.as_ref().and_then(|l| l.get(ci)) {
                Some(latch) => smooth_component(c, latch, total, last_good),
                None => {
                    let quant = c.idct_quant();
                    let stride = c.plane_stride();
                    for by in 0..c.height_in_blocks {
                        for bx in 0..c.width_in_blocks {
                            if let Some(block) = c.coefs.get(by * c.blocks_w + bx) {
                                idct_block(
                                    block,
                                    &quant,
                                    &mut c.plane,
                                    by * 8 * stride + bx * 8,
                                    stride,
                                );
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// The grey image from the component planes.
pub(crate) fn to_gray(frame: &mut Frame, model: ColorModel) -> Vec<u8> {
    let (w, h) = (frame.width, frame.height);
    if model == ColorModel::Luma
        && let Some(c) = frame.comps.first_mut()
        && c.h == frame.hmax
        && c.v == frame.vmax
        && c.plane_stride() == w
    {
        // The plane is the image, with whole blocks of rows: drop the extra rows.
        let mut plane = std::mem::take(&mut c.plane);
        plane.truncate(w * h);
        return plane;
    }
    let frame = &*frame;
    let full = |c: &Component| upsample(c, frame.hmax, frame.vmax, w, h);
    match model {
        ColorModel::Luma => frame.comps.first().map(full).unwrap_or_default(),
        ColorModel::Rgb => {
            let planes: Vec<Vec<u8>> = frame.comps.iter().map(full).collect();
            let [r, g, b] = [&planes[0], &planes[1], &planes[2]];
            r.iter()
                .zip(g)
                .zip(b)
                .map(|((&r, &g), &b)| {
                    ((19595 * u32::from(r) + 38470 * u32::from(g) + 7471 * u32::from(b) + 32768)
                        >> 16) as u8
                })
                .collect()
        }
        ColorModel::Cmyk | ColorModel::Ycck => {
            let planes: Vec<Vec<u8>> = frame.comps.iter().map(full).collect();
            let mut out = vec![0u8; w * h];
            for (i, o) in out.iter_mut().enumerate() {
                let [c0, c1, c2, k] = [planes[0][i], planes[1][i], planes[2][i], planes[3][i]];
                let (c, m, y) = if model == ColorModel::Ycck {
                    ycc_to_cmy(c0, c1, c2)
                } else {
                    (c0, c1, c2)
                };
                *o = opencv_cmyk_to_gray(c, m, y, k);
            }
            out
        }
    }
}

/// libjpeg's YCCK to CMYK for the first three channels: YCbCr to RGB with its 16-bit
/// fixed-point tables, then inverted (`ycck_cmyk_convert`).
fn ycc_to_cmy(y: u8, cb: u8, cr: u8) -> (u8, u8, u8) {
    const ONE_HALF: i64 = 1 << 15;
    let (y, cb, cr) = (i64::from(y), i64::from(cb) - 128, i64::from(cr) - 128);
    let cr_r = (91881 * cr + ONE_HALF) >> 16;
    let cb_b = (116130 * cb + ONE_HALF) >> 16;
    let g = (-22554 * cb + ONE_HALF + -46802 * cr) >> 16;
    let limit = |x: i64| x.clamp(0, 255) as u8;
    (
        limit(255 - (y + cr_r)),
        limit(255 - (y + g)),
        limit(255 - (y + cb_b)),
    )
}

/// OpenCV's `icvCvt_CMYK2Gray_8u_C4C1R` (imgcodecs `utils.cpp`).
fn opencv_cmyk_to_gray(c: u8, m: u8, y: u8, k: u8) -> u8 {
    let (c, m, y, k) = (i32::from(c), i32::from(m), i32::from(y), i32::from(k));
    let c = k - (((255 - c) * k) >> 8);
    let m = k - (((255 - m) * k) >> 8);
    let y = k - (((255 - y) * k) >> 8);
    // 14-bit coefficients: R 4899, G 9617, B 1868 (C, M, Y play R, G, B).
    ((y * 1868 + m * 9617 + c * 4899 + (1 << 13)) >> 14) as u8
}

/// One component's samples at the image size (`jdsample.c`'s method selection).
pub(crate) fn upsample(c: &Component, hmax: usize, vmax: usize, w: usize, h: usize) -> Vec<u8> {
    let stride = c.plane_stride();
    let plane = &c.plane;
    let (dw, dh) = (c.downsampled_width, c.downsampled_height);
    let row = |y: usize| -> &[u8] { plane.get(y * stride..y * stride + stride).unwrap_or(&[]) };
    let mut out = vec![0u8; w * h];
    if c.h == hmax && c.v == vmax {
        for (y, o) in out.chunks_exact_mut(w).enumerate() {
            if let Some(src) = row(y).get(..w) {
                o.copy_from_slice(src);
            }
        }
    } else if c.h * 2 == hmax && c.v == vmax && dw > 2 {
        for (y, o) in out.chunks_exact_mut(w).enumerate() {
            h2v1_fancy(row(y), dw, o);
        }
    } else if c.h == hmax && c.v * 2 == vmax {
        // h1v2 fancy (always used): 3/4 nearer row + 1/4 further row.
        let mut tmp = vec![0u8; w];
        for (y, o) in out.chunks_exact_mut(w).enumerate() {
            let (near, far, bias) = vertical_pair(y, dh);
            let (near, far) = (row(near), row(far));
            for (x, t) in tmp.iter_mut().enumerate().take(dw.min(w)) {
                let s = 3 * u32::from(near.get(x).copied().unwrap_or(0))
                    + u32::from(far.get(x).copied().unwrap_or(0));
                *t = ((s + bias) >> 2) as u8;
            }
            o.copy_from_slice(&tmp);
        }
    } else if c.h * 2 == hmax && c.v * 2 == vmax && dw > 2 {
        let mut sums = vec![0u32; dw];
        let mut wide = vec![0u8; 2 * dw];
        for (y, o) in out.chunks_exact_mut(w).enumerate() {
            let (near, far, _) = vertical_pair(y, dh);
            let (near, far) = (row(near), row(far));
            for (x, s) in sums.iter_mut().enumerate() {
                *s = 3 * u32::from(near.get(x).copied().unwrap_or(0))
                    + u32::from(far.get(x).copied().unwrap_or(0));
            }
            h2v2_fancy_row(&sums, &mut wide);
            o.copy_from_slice(&wide[..w]);
        }
    } else {
        // Replication: int_upsample, and h2v1/h2v2 when the row is too narrow to filter.
        let (he, ve) = (hmax / c.h, vmax / c.v);
        for (y, o) in out.chunks_exact_mut(w).enumerate() {
            let src = row(y / ve);
            for (x, p) in o.iter_mut().enumerate() {
                *p = src.get(x / he).copied().unwrap_or(0);
            }
        }
    }
    out
}

/// For output row `y` of a 2:1 vertical upsampling: the nearer input row, the further
/// one (above for even rows, below for odd ones, clamped to the real rows), and the
/// rounding bias libjpeg uses for that parity.
fn vertical_pair(y: usize, dh: usize) -> (usize, usize, u32) {
    let near = (y / 2).min(dh.saturating_sub(1));
    if y.is_multiple_of(2) {
        (near, near.saturating_sub(1), 1)
    } else {
        (near, (near + 1).min(dh.saturating_sub(1)), 2)
    }
}

/// `h2v1_fancy_upsample` of one row of `dw` (> 2) samples into `out`.
fn h2v1_fancy(src: &[u8], dw: usize, out: &mut [u8]) {
    let s = |x: usize| u32::from(src.get(x).copied().unwrap_or(0));
    let mut wide = vec![0u8; 2 * dw];
    wide[0] = s(0) as u8;
    wide[1] = ((3 * s(0) + s(1) + 2) >> 2) as u8;
    for x in 1..dw - 1 {
        let v = 3 * s(x);
        wide[2 * x] = ((v + s(x - 1) + 1) >> 2) as u8;
        wide[2 * x + 1] = ((v + s(x + 1) + 2) >> 2) as u8;
    }
    wide[2 * dw - 2] = ((3 * s(dw - 1) + s(dw - 2) + 1) >> 2) as u8;
    wide[2 * dw - 1] = s(dw - 1) as u8;
    let n = out.len().min(wide.len());
    out[..n].copy_from_slice(&wide[..n]);
}

/// `h2v2_fancy_upsample`'s horizontal step on the column sums of one output row.
fn h2v2_fancy_row(sums: &[u32], out: &mut [u8]) {
    let dw = sums.len();
    out[0] = ((sums[0] * 4 + 8) >> 4) as u8;
    out[1] = ((sums[0] * 3 + sums[1] + 7) >> 4) as u8;
    for x in 1..dw - 1 {
        out[2 * x] = ((sums[x] * 3 + sums[x - 1] + 8) >> 4) as u8;
        out[2 * x + 1] = ((sums[x] * 3 + sums[x + 1] + 7) >> 4) as u8;
    }
    out[2 * dw - 2] = ((sums[dw - 1] * 3 + sums[dw - 2] + 8) >> 4) as u8;
    out[2 * dw - 1] = ((sums[dw - 1] * 4 + 7) >> 4) as u8;
}
