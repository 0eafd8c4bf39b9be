//! Bilinear down-scaling of an 8-bit grey image, bit for bit as OpenCV 4.x's
//! `cv::resize(src, dst, dsize, 0, 0, INTER_LINEAR_EXACT)` (module imgproc, `resize.cpp`,
//! `resize_bitExact` with `interpolationLinear`). The cascade detector scales the image,
//! not the features, with this interpolation; its pyramid must be exactly OpenCV's to find
//! exactly OpenCV's windows. (Plain `INTER_LINEAR`, with 11-bit weights, differs from it
//! by one grey level on a few percent of the pixels.)
//!
//! OpenCV's recipe for `CV_8U`, in fixed point with 8 fractional bits:
//!
//! - `inv_scale = dst / src`, `scale = 1 / inv_scale` (double precision);
//! - destination index `d` samples `f = scale (d + 0.5) - 0.5`, `i = floor(f)`; when
//!   `0 <= i < src - 1` the taps are `i` and `i + 1` with weights
//!   `c1 = round_half_even((f - i) 256)` and `c0 = 256 - c1`; destination indices with
//!   `i < 0` copy the first source sample and those with `i >= src - 1` the last one;
//! - horizontal pass: `H = c0 S[i] + c1 S[i + 1]` (source value times 256);
//! - vertical pass: `D = (c0 H[i] + c1 H[i + 1] + 2^15) >> 16`, and rows that copy a
//!   source row give `D = (H + 128) >> 8`;
//! - an exact 2x reduction is done by `INTER_AREA` instead,
//!   `D = (S00 + S01 + S10 + S11 + 2) >> 2`; equal sizes are copied.

/// One in `ufixedpoint16`, OpenCV's fixed-point type for 8-bit resizing.
const ONE: u32 = 1 << 8;

/// Taps and weights along one axis (`interpolationLinear::getCoeffs`).
struct AxisTaps {
    /// First source index of each destination index.
    offset: Vec<usize>,
    /// Weights of `offset` and `offset + 1`, in 1/256.
    coeff: Vec<[u32; 2]>,
    /// Destination indices below this copy the first source sample.
    min: usize,
    /// Destination indices from this on copy the last source sample.
    max: usize,
}

fn axis_taps(src_len: usize, dst_len: usize) -> AxisTaps {
    let inv_scale = dst_len as f64 / src_len as f64;
    let scale = 1.0 / inv_scale;
    let mut offset = vec![0usize; dst_len];
    let mut coeff = vec![[ONE, 0]; dst_len];
    let (mut min, mut max) = (0usize, dst_len);
    for d in 0..dst_len {
        let f = scale * (d as f64 + 0.5) - 0.5;
        let i = f.floor();
        if i >= 0.0 && src_len > 1 {
            if i < (src_len - 1) as f64 {
                offset[d] = i as usize;
                let c1 = ((f - i) * f64::from(ONE)).round_ties_even() as u32;
                coeff[d] = [ONE.saturating_sub(c1), c1];
            } else {
                offset[d] = src_len - 1;
                max = max.min(d);
            }
        } else {
            min = min.max(d + 1);
        }
    }
    AxisTaps {
        offset,
        coeff,
        min,
        max,
    }
}

/// Resizes a row-major `src_w x src_h` image to `dst_w x dst_h` into `dst` (row-major,
/// `dst_w` per row), exactly as OpenCV's `INTER_LINEAR_EXACT` for 8-bit single-channel
/// images.
///
/// # Panics
/// If a size is zero or a slice is shorter than its size says.
pub fn resize_linear_into(
    src: &[u8],
    src_w: usize,
    src_h: usize,
    dst: &mut [u8],
    dst_w: usize,
    dst_h: usize,
) {
    assert!(src_w > 0 && src_h > 0 && dst_w > 0 && dst_h > 0);
    assert!(src.len() >= src_w * src_h && dst.len() >= dst_w * dst_h);
    if src_w == dst_w && src_h == dst_h {
        dst[..dst_w * dst_h].copy_from_slice(&src[..src_w * src_h]);
        return;
    }
    if src_w == 2 * dst_w && src_h == 2 * dst_h {
        // OpenCV switches to its fast INTER_AREA path for an exact halving.
        for y in 0..dst_h {
            let r0 = &src[2 * y * src_w..(2 * y + 1) * src_w];
            let r1 = &src[(2 * y + 1) * src_w..(2 * y + 2) * src_w];
            for (x, d) in dst[y * dst_w..(y + 1) * dst_w].iter_mut().enumerate() {
                let s = u32::from(r0[2 * x])
                    + u32::from(r0[2 * x + 1])
                    + u32::from(r1[2 * x])
                    + u32::from(r1[2 * x + 1]);
                *d = ((s + 2) >> 2) as u8;
            }
        }
        return;
    }
    let xt = axis_taps(src_w, dst_w);
    let yt = axis_taps(src_h, dst_h);
    let (x_min, x_max) = (xt.min.min(dst_w), xt.max.max(xt.min.min(dst_w)));
    let last_col = xt.offset[dst_w - 1];

    // `hlineResizeCn`: one source row to `dst_w` values in 1/256.
    let hresize = |sy: usize, out: &mut [u32]| {
        let row = &src[sy * src_w..(sy + 1) * src_w];
        out[..x_min].fill(u32::from(row[0]) * ONE);
        for ((o, &i), &[c0, c1]) in out[x_min..x_max]
            .iter_mut()
            .zip(&xt.offset[x_min..x_max])
            .zip(&xt.coeff[x_min..x_max])
        {
            *o = c0 * u32::from(row[i]) + c1 * u32::from(row[i + 1]);
        }
        out[x_max..].fill(u32::from(row[last_col]) * ONE);
    };

    let mut rows = [vec![0u32; dst_w], vec![0u32; dst_w]];
    let mut cached = [usize::MAX; 2];
    for dy in 0..dst_h {
        let out = &mut dst[dy * dst_w..(dy + 1) * dst_w];
        if dy < yt.min || dy >= yt.max {
            // `vlineSet`: a copy of the first or last source row.
            let sy = if dy < yt.min { 0 } else { src_h - 1 };
            hresize(sy, &mut rows[0]);
            cached[0] = sy;
            for (o, &h) in out.iter_mut().zip(&rows[0]) {
                *o = ((h + (ONE >> 1)) >> 8).min(255) as u8;
            }
            continue;
        }
        let iy = yt.offset[dy];
        // Keep the row the other tap needs when one is already computed.
        let need = [iy, iy + 1];
        let mut slot = [0usize; 2];
        for k in 0..2 {
            slot[k] = match cached.iter().position(|&c| c == need[k]) {
                Some(s) => s,
                None => {
                    let victim = if k == 1 {
                        1 - slot[0]
                    } else {
                        usize::from(cached[0] == need[1])
                    };
                    hresize(need[k], &mut rows[victim]);
                    cached[victim] = need[k];
                    victim
                }
            };
        }
        let [c0, c1] = yt.coeff[dy];
        let (h0, h1) = (&rows[slot[0]], &rows[slot[1]]);
        for ((o, &a), &b) in out.iter_mut().zip(h0).zip(h1) {
            *o = ((a * c0 + b * c1 + (1 << 15)) >> 16).min(255) as u8;
        }
    }
}

/// [`resize_linear_into`] into a new buffer.
pub fn resize_linear(
    src: &[u8],
    src_w: usize,
    src_h: usize,
    dst_w: usize,
    dst_h: usize,
) -> Vec<u8> {
    let mut dst = vec![0u8; dst_w * dst_h];
    resize_linear_into(src, src_w, src_h, &mut dst, dst_w, dst_h);
    dst
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The same recipe written the plain way: weights recomputed per output pixel, no row
    /// cache, clamping by explicit cases.
    fn slow_reference(src: &[u8], sw: usize, sh: usize, dw: usize, dh: usize) -> Vec<u8> {
        // (first tap, second tap, weight of the second in 1/256) or a copy of one sample.
        let taps = |d: usize, sl: usize, dl: usize| -> (usize, usize, u32) {
            let scale = 1.0 / (dl as f64 / sl as f64);
            let f = scale * (d as f64 + 0.5) - 0.5;
            let i = f.floor();
            if i < 0.0 || sl == 1 {
                (0, 0, 0)
            } else if i >= (sl - 1) as f64 {
                (sl - 1, sl - 1, 0)
            } else {
                let c1 = ((f - i) * 256.0).round_ties_even() as u32;
                (i as usize, i as usize + 1, c1)
            }
        };
        let h = |r: usize, x: usize| -> u32 {
            let (a, b, c1) = taps(x, sw, dw);
            (256 - c1) * u32::from(src[r * sw + a]) + c1 * u32::from(src[r * sw + b])
        };
        let mut out = vec![0u8; dw * dh];
        for y in 0..dh {
            let (a, b, c1) = taps(y, sh, dh);
            for x in 0..dw {
                out[y * dw + x] = if a == b {
                    ((h(a, x) + 128) >> 8) as u8
                } else {
                    (((256 - c1) * h(a, x) + c1 * h(b, x) + 32768) >> 16) as u8
                };
            }
        }
        out
    }

    proptest! {
        #[test]
        fn fast_path_matches_the_plain_recipe(sw in 1usize..60, sh in 1usize..60, fx in 0.2f64..1.0, fy in 0.2f64..1.0, seed in any::<u64>()) {
            let dw = ((sw as f64 * fx) as usize).max(1);
            let dh = ((sh as f64 * fy) as usize).max(1);
            let special = (sw == 2 * dw && sh == 2 * dh) || (sw == dw && sh == dh);
            prop_assume!(!special);
            let mut state = seed | 1;
            let src: Vec<u8> = (0..sw * sh).map(|_| {
                state ^= state << 13; state ^= state >> 7; state ^= state << 17;
                (state >> 32) as u8
            }).collect();
            prop_assert_eq!(resize_linear(&src, sw, sh, dw, dh), slow_reference(&src, sw, sh, dw, dh));
        }
    }

    #[test]
    fn constant_images_stay_constant() {
        for level in [0u8, 1, 127, 254, 255] {
            let src = vec![level; 37 * 23];
            for (dw, dh) in [(33, 21), (20, 12), (5, 3), (1, 1), (37, 23)] {
                assert!(
                    resize_linear(&src, 37, 23, dw, dh)
                        .iter()
                        .all(|&p| p == level)
                );
            }
        }
    }

    #[test]
    fn exact_halving_averages_blocks_rounding_half_up() {
        let src = [0u8, 1, 2, 3, 1, 0, 3, 3];
        // Blocks {0,1,1,0} -> (2 + 2) >> 2 = 1; {2,3,3,3} -> (11 + 2) >> 2 = 3.
        assert_eq!(resize_linear(&src, 4, 2, 2, 1), vec![1, 3]);
    }

    #[test]
    fn midpoint_weights() {
        // 4 -> 3 columns: f = 4/3 (d + 0.5) - 0.5 = 1/6, 3/2, 17/6: weights 43, 128, and
        // the last copies column 3 (floor(17/6) = 2 < 3: taps 2, 3 with c1 = 213).
        let src = [0u8, 100, 200, 250];
        let expect =
            |a: u32, b: u32, c1: u32| ((((256 - c1) * a + c1 * b) * 256 + 32768) >> 16) as u8;
        assert_eq!(
            resize_linear(&src, 4, 1, 3, 1),
            vec![
                expect(0, 100, 43),
                expect(100, 200, 128),
                expect(200, 250, 213)
            ]
        );
    }
}
