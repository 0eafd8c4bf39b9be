//! Integral images as OpenCV's `cv::integral(src, sum, sqsum, tilted, CV_32S, CV_32S)`
//! computes them for the cascade detector (design 3.1).
//!
//! For a `W x H` image `I` each output has `(W + 1) x (H + 1)` entries (a zero first row
//! and column), row-major with a caller-chosen stride:
//!
//! ```text
//! sum(X, Y)    = sum over x < X, y < Y of I(x, y)
//! sqsum(X, Y)  = sum over x < X, y < Y of I(x, y)^2
//! tilted(X, Y) = sum over y < Y, |x - X + 1| <= Y - 1 - y of I(x, y)
//! ```
//!
//! `tilted` is the 45-degree rotated integral (Lienhart and Maydt, ICIP 2002): the sum
//! over the upward-widening triangle whose apex is pixel `(X - 1, Y - 1)`; pixels outside
//! the image count 0. The sum of an upright rectangle is four reads,
//! `sum(x, y) - sum(x + w, y) - sum(x, y + h) + sum(x + w, y + h)`, and so is the sum of
//! a rectangle rotated by 45 degrees about its top corner,
//! `tilted(x, y) - tilted(x - h, y + h) - tilted(x + w, y + w) + tilted(x + w - h, y + w + h)`.
//!
//! Everything is 32-bit with wrap-around, like OpenCV's `CV_32S` outputs (the squared
//! sums of a large image overflow 32 bits): the difference of four wrapped values is the
//! true window sum whenever that sum fits, which it always does for a detection window.

/// Computes `sum` and `sqsum` (each `(h + 1)` rows of `stride >= w + 1` entries).
///
/// # Panics
/// If the slices are too small for the given sizes (a programming error; the detector
/// sizes its buffers from the image).
pub fn integral_sum_sqsum(
    image: &[u8],
    width: usize,
    height: usize,
    stride: usize,
    sum: &mut [i32],
    sqsum: &mut [i32],
) {
    assert!(stride > width && image.len() >= width * height);
    assert!(sum.len() >= (height + 1) * stride && sqsum.len() >= (height + 1) * stride);
    sum[..=width].fill(0);
    sqsum[..=width].fill(0);
    for y in 0..height {
        let row = &image[y * width..(y + 1) * width];
        let (above, below) = sum.split_at_mut((y + 1) * stride);
        let prev = &above[y * stride..y * stride + width + 1];
        let cur = &mut below[..width + 1];
        let (qa, qb) = sqsum.split_at_mut((y + 1) * stride);
        let qprev = &qa[y * stride..y * stride + width + 1];
        let qcur = &mut qb[..width + 1];
        cur[0] = 0;
        qcur[0] = 0;
        let mut s = 0i32;
        let mut q = 0i32;
        for x in 0..width {
            let p = i32::from(row[x]);
            s = s.wrapping_add(p);
            q = q.wrapping_add(p * p);
            cur[x + 1] = prev[x + 1].wrapping_add(s);
            qcur[x + 1] = qprev[x + 1].wrapping_add(q);
        }
    }
}

/// Computes the tilted integral (`(h + 1)` rows of `stride >= w + 1` entries).
///
/// Row by row with the recurrence, for `Y >= 2`,
///
/// ```text
/// tilted(X, Y) = tilted(X - 1, Y - 1) + tilted(X + 1, Y - 1) - tilted(X, Y - 2)
///              + I(X - 1, Y - 1) + I(X - 1, Y - 2)
/// ```
///
/// (inclusion-exclusion in the rotated coordinates `u = x - y`, `v = x + y`, where
/// `tilted(X, Y)` sums `u >= X - Y, v <= X + Y - 2`). It reaches one column beyond each
/// side of the output; there the triangle is cut by only one of its edges:
/// `tilted(-1, Y) = D(Y - 3)` with `D(b)` the sum over `x + y <= b`, and
/// `tilted(W + 1, Y) = E(W + 1 - Y)` with `E(a)` the sum over `x - y >= a`.
///
/// # Panics
/// If the slices are too small for the given sizes.
pub fn integral_tilted(
    image: &[u8],
    width: usize,
    height: usize,
    stride: usize,
    tilted: &mut [i32],
) {
    assert!(stride > width && image.len() >= width * height);
    assert!(tilted.len() >= (height + 1) * stride);
    let (w, h) = (width as i64, height as i64);
    let px = |x: i64, y: i64| -> i32 {
        if x >= 0 && y >= 0 && x < w && y < h {
            i32::from(image[(y * w + x) as usize])
        } else {
            0
        }
    };
    // Anti-diagonal (x + y = k) and diagonal (x - y = d) sums, then D as a prefix sum
    // over k and E as a suffix sum over d.
    let ndiag = (width + height).max(1);
    let mut anti = vec![0i32; ndiag];
    let mut diag = vec![0i32; ndiag];
    for y in 0..height {
        for x in 0..width {
            let p = i32::from(image[y * width + x]);
            anti[x + y] = anti[x + y].wrapping_add(p);
            let d = x + height - 1 - y;
            diag[d] = diag[d].wrapping_add(p);
        }
    }
    let mut prefix = vec![0i32; ndiag + 1]; // prefix[k + 1] = D(k)
    for k in 0..ndiag {
        prefix[k + 1] = prefix[k].wrapping_add(anti[k]);
    }
    let mut suffix = vec![0i32; ndiag + 1]; // suffix[i] = sum of diag[i..]
    for i in (0..ndiag).rev() {
        suffix[i] = suffix[i + 1].wrapping_add(diag[i]);
    }
    let d_of = |b: i64| -> i32 {
        if b < 0 {
            0
        } else {
            prefix[(b as usize + 1).min(ndiag)]
        }
    };
    let e_of = |a: i64| -> i32 {
        // x - y >= a  <=>  diag index >= a + h - 1.
        let i = a + h - 1;
        if i <= 0 {
            suffix[0]
        } else if i as usize >= ndiag {
            0
        } else {
            suffix[i as usize]
        }
    };

    tilted[..=width].fill(0);
    if height == 0 {
        return;
    }
    for x in 0..=width {
        tilted[stride + x] = px(x as i64 - 1, 0);
    }
    for yy in 2..=height {
        let y = yy as i64;
        let (done, rest) = tilted.split_at_mut(yy * stride);
        let prev = &done[(yy - 1) * stride..(yy - 1) * stride + width + 1];
        let prev2 = &done[(yy - 2) * stride..(yy - 2) * stride + width + 1];
        let cur = &mut rest[..width + 1];
        let left_outside = d_of(y - 4); // tilted(-1, Y - 1)
        let right_outside = e_of(w + 2 - y); // tilted(W + 1, Y - 1)
        // Column 0: the pixel terms are outside the image.
        let right_of_0 = if width == 0 { right_outside } else { prev[1] };
        cur[0] = left_outside.wrapping_add(right_of_0).wrapping_sub(prev2[0]);
        if width == 0 {
            continue;
        }
        let row1 = &image[(yy - 1) * width..yy * width]; // I(., Y - 1)
        let row2 = &image[(yy - 2) * width..(yy - 1) * width]; // I(., Y - 2)
        // Columns 1..width - 1 read tilted(X - 1) and tilted(X + 1) of the row above.
        for x in 1..width {
            cur[x] = prev[x - 1]
                .wrapping_add(prev[x + 1])
                .wrapping_sub(prev2[x])
                .wrapping_add(i32::from(row1[x - 1]) + i32::from(row2[x - 1]));
        }
        cur[width] = prev[width - 1]
            .wrapping_add(right_outside)
            .wrapping_sub(prev2[width])
            .wrapping_add(i32::from(row1[width - 1]) + i32::from(row2[width - 1]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The definitions, summed pixel by pixel.
    fn slow_reference(image: &[u8], w: usize, h: usize) -> (Vec<i64>, Vec<i64>, Vec<i64>) {
        let s = w + 1;
        let mut sum = vec![0i64; (h + 1) * s];
        let mut sq = vec![0i64; (h + 1) * s];
        let mut tilted = vec![0i64; (h + 1) * s];
        for yy in 0..=h {
            for xx in 0..=w {
                for y in 0..h {
                    for x in 0..w {
                        let p = i64::from(image[y * w + x]);
                        if x < xx && y < yy {
                            sum[yy * s + xx] += p;
                            sq[yy * s + xx] += p * p;
                        }
                        if y < yy && (x as i64 - xx as i64 + 1).abs() <= yy as i64 - 1 - y as i64 {
                            tilted[yy * s + xx] += p;
                        }
                    }
                }
            }
        }
        (sum, sq, tilted)
    }

    proptest! {
        /// Fast integrals equal the pixel-by-pixel definitions, with a stride wider than
        /// the image.
        #[test]
        fn match_the_definitions(w in 1usize..14, h in 1usize..14, pad in 0usize..3, seed in any::<u64>()) {
            let mut state = seed | 1;
            let image: Vec<u8> = (0..w * h).map(|_| {
                state ^= state << 13; state ^= state >> 7; state ^= state << 17;
                (state >> 24) as u8
            }).collect();
            let stride = w + 1 + pad;
            let mut sum = vec![7; (h + 1) * stride];
            let mut sq = vec![7; (h + 1) * stride];
            let mut tilted = vec![7; (h + 1) * stride];
            integral_sum_sqsum(&image, w, h, stride, &mut sum, &mut sq);
            integral_tilted(&image, w, h, stride, &mut tilted);
            let (rs, rq, rt) = slow_reference(&image, w, h);
            for y in 0..=h {
                for x in 0..=w {
                    prop_assert_eq!(i64::from(sum[y * stride + x]), rs[y * (w + 1) + x]);
                    prop_assert_eq!(i64::from(sq[y * stride + x]), rq[y * (w + 1) + x]);
                    prop_assert_eq!(i64::from(tilted[y * stride + x]), rt[y * (w + 1) + x], "tilted at ({}, {})", x, y);
                }
            }
        }
    }

    #[test]
    fn tilted_rectangle_sum_is_four_reads() {
        // A rectangle rotated by 45 degrees about its top corner (x0, y0), with sides of
        // w and h diagonal steps, covers the 2 w h pixels whose diagonal coordinates
        // u = x - y and v = x + y satisfy x0 - y0 - 2h <= u < x0 - y0 and
        // x0 + y0 - 1 <= v <= x0 + y0 + 2w - 2 (a diamond band in each direction).
        let (w, h) = (12usize, 11usize);
        let image: Vec<u8> = (0..w * h).map(|i| (i * 7 % 251) as u8).collect();
        let s = w + 1;
        let mut t = vec![0; (h + 1) * s];
        integral_tilted(&image, w, h, s, &mut t);
        let at = |x: i32, y: i32| i64::from(t[y as usize * s + x as usize]);
        for (x0, y0, rw, rh) in [
            (4i32, 1i32, 3i32, 2i32),
            (2, 0, 1, 1),
            (5, 2, 4, 3),
            (6, 0, 5, 6),
        ] {
            let four = at(x0, y0) - at(x0 - rh, y0 + rh) - at(x0 + rw, y0 + rw)
                + at(x0 + rw - rh, y0 + rw + rh);
            let (mut explicit, mut count) = (0i64, 0);
            for y in 0..h as i32 {
                for x in 0..w as i32 {
                    let (u, v) = (x - y, x + y);
                    if (x0 - y0 - 2 * rh..x0 - y0).contains(&u)
                        && (x0 + y0 - 1..=x0 + y0 + 2 * rw - 2).contains(&v)
                    {
                        explicit += i64::from(image[y as usize * w + x as usize]);
                        count += 1;
                    }
                }
            }
            assert_eq!(count, 2 * rw * rh, "rectangle inside the image");
            assert_eq!(four, explicit);
        }
    }

    #[test]
    fn wraps_like_32_bit_opencv() {
        // 300 x 300 of 255: the squared total (5.85e9) overflows i32, window sums stay exact.
        let (w, h) = (300usize, 300usize);
        let image = vec![255u8; w * h];
        let s = w + 1;
        let mut sum = vec![0; (h + 1) * s];
        let mut sq = vec![0; (h + 1) * s];
        integral_sum_sqsum(&image, w, h, s, &mut sum, &mut sq);
        let win = |a: &[i32], x: usize, y: usize, d: usize| {
            a[y * s + x]
                .wrapping_sub(a[y * s + x + d])
                .wrapping_sub(a[(y + d) * s + x])
                .wrapping_add(a[(y + d) * s + x + d]) as u32
        };
        assert_eq!(win(&sq, 250, 250, 40), 40 * 40 * 255 * 255);
        assert_eq!(win(&sum, 250, 250, 40), 40 * 40 * 255);
    }
}
