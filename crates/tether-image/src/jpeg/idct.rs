//! Dequantisation and inverse DCT exactly as OpenCV's libjpeg-turbo computes them.
//!
//! The algorithm is libjpeg's "slow integer" IDCT (`JDCT_ISLOW`, `jidctint.c`): the
//! Loeffler-Ligtenberg-Moschytz factorisation with 12 multiplications, constants scaled
//! by 2^13 (`CONST_BITS`), the first pass's outputs scaled up by 2^2 (`PASS1_BITS`), both
//! passes rounding by adding half before the arithmetic shift, and the +128 level shift
//! at the end.
//!
//! libjpeg-turbo on x86-64 (OpenCV's wheels, this machine) runs its SSE2/AVX2 version of
//! that routine, which keeps dequantised coefficients and the first pass's outputs in
//! 16-bit lanes. For every block a real encoder produces it gives the same result as
//! `jidctint.c`; they part only on extreme coefficients (corrupt or crafted data), where
//! the C code wraps around (`& RANGE_MASK`) and the SIMD code saturates. tether follows
//! the SIMD arithmetic, because that is what `cv2.imread` returns:
//! - dequantisation keeps the low 16 bits of `coefficient * quantiser` (the quantiser
//!   itself read as a signed 16-bit value);
//! - the sums `in0 + in4`, `in0 - in4`, `in3 + in7`, `in1 + in5` wrap at 16 bits;
//!   products are summed exactly in 32 bits;
//! - each pass's outputs saturate to 16 bits, and the final samples to -128..=127
//!   before the +128 shift;
//! - a block whose coefficient rows 1-7 are all zero takes a shortcut in the first pass:
//!   `(dequantised DC of each column) << 2`, wrapping at 16 bits.

use wide::{i16x8, i32x8};

const F_0_298: i32 = 2446;
const F_0_390: i32 = 3196;
const F_0_541: i32 = 4433;
const F_0_765: i32 = 6270;
const F_0_899: i32 = 7373;
const F_1_175: i32 = 9633;
const F_1_501: i32 = 12299;
const F_1_847: i32 = 15137;
const F_1_961: i32 = 16069;
const F_2_053: i32 = 16819;
const F_2_562: i32 = 20995;
const F_3_072: i32 = 25172;

/// The first pass's outputs are scaled down by 2^(13 - 2), the second's by 2^(13 + 2 + 3).
const SHIFT_PASS1: u32 = 11;
const SHIFT_PASS2: u32 = 18;

#[inline(always)]
fn wrap16(x: i32) -> i32 {
    x as i16 as i32
}

#[inline(always)]
fn sat16(x: i32) -> i32 {
    x.clamp(-32768, 32767)
}

/// One 1-D IDCT of 8 values held as 16-bit numbers; returns the 8 outputs descaled by
/// `shift` and saturated to 16 bits.
#[inline(always)]
fn idct_1d(v: [i32; 8], shift: u32) -> [i32; 8] {
    let [i0, i1, i2, i3, i4, i5, i6, i7] = v;
    // Even part.
    let tmp3 = i2 * (F_0_541 + F_0_765) + i6 * F_0_541;
    let tmp2 = i2 * F_0_541 + i6 * (F_0_541 - F_1_847);
    let tmp0 = wrap16(i0 + i4) << 13;
    let tmp1 = wrap16(i0 - i4) << 13;
    let tmp10 = tmp0.wrapping_add(tmp3);
    let tmp13 = tmp0.wrapping_sub(tmp3);
    let tmp11 = tmp1.wrapping_add(tmp2);
    let tmp12 = tmp1.wrapping_sub(tmp2);
    // Odd part.
    let z3 = wrap16(i7 + i3);
    let z4 = wrap16(i5 + i1);
    let z3r = z3 * (F_1_175 - F_1_961) + z4 * F_1_175;
    let z4r = z3 * F_1_175 + z4 * (F_1_175 - F_0_390);
    let o0 = (i7 * (F_0_298 - F_0_899) + i1 * -F_0_899).wrapping_add(z3r);
    let o1 = (i5 * (F_2_053 - F_2_562) + i3 * -F_2_562).wrapping_add(z4r);
    let o2 = (i5 * -F_2_562 + i3 * (F_3_072 - F_2_562)).wrapping_add(z3r);
    let o3 = (i7 * -F_0_899 + i1 * (F_1_501 - F_0_899)).wrapping_add(z4r);
    let round = 1i32 << (shift - 1);
    let d = |x: i32| sat16(x.wrapping_add(round) >> shift);
    [
        d(tmp10.wrapping_add(o3)),
        d(tmp11.wrapping_add(o2)),
        d(tmp12.wrapping_add(o1)),
        d(tmp13.wrapping_add(o0)),
        d(tmp13.wrapping_sub(o0)),
        d(tmp12.wrapping_sub(o1)),
        d(tmp11.wrapping_sub(o2)),
        d(tmp10.wrapping_sub(o3)),
    ]
}

/// Dequantises and inverse-transforms one block into 8 rows of 8 samples:
/// `out[offset + row * stride + col]`. `quant` is the component's table in natural order,
/// each entry as libjpeg-turbo's SIMD code reads it (`u16` reinterpreted as `i16`).
///
/// Eight columns (then eight rows) at a time in 16-bit lanes, like libjpeg-turbo;
/// [`idct_block_scalar`] is the same arithmetic one value at a time.
#[inline]
pub(crate) fn idct_block(
    coefs: &[i16; 64],
    quant: &[i16; 64],
    out: &mut [u8],
    offset: usize,
    stride: usize,
) {
    let Some(dst) = out.get_mut(offset..offset + 7 * stride + 8) else {
        return;
    };
    let row = |a: &[i16; 64], r: usize| {
        let mut v = [0i16; 8];
        v.copy_from_slice(&a[r * 8..r * 8 + 8]);
        i16x8::new(v)
    };
    let c: [i16x8; 8] = std::array::from_fn(|r| row(coefs, r));
    let ac_rows = c[1] | c[2] | c[3] | c[4] | c[5] | c[6] | c[7];
    let ws: [i16x8; 8] = if ac_rows == i16x8::ZERO {
        let dc: i16x8 = (c[0] * row(quant, 0)) << 2u32;
        if (dc.to_array()[1..]).iter().all(|&v| v == 0) {
            // Only the DC term: a flat block.
            let v = (i32::from(dc.to_array()[0]) + 16) >> 5;
            let sample = (v.clamp(-128, 127) + 128) as u8;
            for r in 0..8 {
                dst[r * stride..r * stride + 8].fill(sample);
            }
            return;
        }
        [dc; 8]
    } else {
        let dq: [i16x8; 8] = std::array::from_fn(|r| c[r] * row(quant, r));
        idct_1d_x8(dq, SHIFT_PASS1)
    };
    // Second pass along the rows: transpose so that lanes hold rows.
    let t = transpose(ws);
    let cols = idct_1d_x8(t, SHIFT_PASS2);
    let cols = cols.map(|v| v.to_array());
    for r in 0..8 {
        let line = &mut dst[r * stride..r * stride + 8];
        for (x, d) in line.iter_mut().enumerate() {
            *d = (i32::from(cols[x][r]).clamp(-128, 127) + 128) as u8;
        }
    }
}

fn transpose(m: [i16x8; 8]) -> [i16x8; 8] {
    let a = m.map(|v| v.to_array());
    std::array::from_fn(|c| i16x8::new(std::array::from_fn(|r| a[r][c])))
}

/// [`idct_1d`] on eight vectors of 16-bit lanes.
#[inline(always)]
fn idct_1d_x8(v: [i16x8; 8], shift: u32) -> [i16x8; 8] {
    let k = |x: i32| i16x8::splat(x as i16);
    let [i0, i1, i2, i3, i4, i5, i6, i7] = v;
    let tmp3 = i2.widening_mul(k(F_0_541 + F_0_765)) + i6.widening_mul(k(F_0_541));
    let tmp2 = i2.widening_mul(k(F_0_541)) + i6.widening_mul(k(F_0_541 - F_1_847));
    let tmp0 = i32x8::from_i16x8(i0 + i4) << 13;
    let tmp1 = i32x8::from_i16x8(i0 - i4) << 13;
    let tmp10 = tmp0 + tmp3;
    let tmp13 = tmp0 - tmp3;
    let tmp11 = tmp1 + tmp2;
    let tmp12 = tmp1 - tmp2;
    let z3 = i7 + i3;
    let z4 = i5 + i1;
    let z3r = z3.widening_mul(k(F_1_175 - F_1_961)) + z4.widening_mul(k(F_1_175));
    let z4r = z3.widening_mul(k(F_1_175)) + z4.widening_mul(k(F_1_175 - F_0_390));
    let o0 = i7.widening_mul(k(F_0_298 - F_0_899)) + i1.widening_mul(k(-F_0_899)) + z3r;
    let o1 = i5.widening_mul(k(F_2_053 - F_2_562)) + i3.widening_mul(k(-F_2_562)) + z4r;
    let o2 = i5.widening_mul(k(-F_2_562)) + i3.widening_mul(k(F_3_072 - F_2_562)) + z3r;
    let o3 = i7.widening_mul(k(-F_0_899)) + i1.widening_mul(k(F_1_501 - F_0_899)) + z4r;
    let round = i32x8::splat(1 << (shift - 1));
    let d = |x: i32x8| i16x8::from_i32x8_saturate((x + round) >> shift);
    [
        d(tmp10 + o3),
        d(tmp11 + o2),
        d(tmp12 + o1),
        d(tmp13 + o0),
        d(tmp13 - o0),
        d(tmp12 - o1),
        d(tmp11 - o2),
        d(tmp10 - o3),
    ]
}

/// [`idct_block`] one value at a time (the reference the tests compare it with).
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn idct_block_scalar(
    coefs: &[i16; 64],
    quant: &[i16; 64],
    out: &mut [u8],
    offset: usize,
    stride: usize,
) {
    let mut ws = [[0i32; 8]; 8];
    if coefs[8..].iter().all(|&c| c == 0) {
        // First-pass shortcut of the SIMD code: every column is its DC term.
        for c in 0..8 {
            let v = wrap16(wrap16(i32::from(coefs[c]) * i32::from(quant[c])) << 2);
            for row in &mut ws {
                row[c] = v;
            }
        }
    } else {
        for c in 0..8 {
            let mut col = [0i32; 8];
            for (r, v) in col.iter_mut().enumerate() {
                *v = wrap16(i32::from(coefs[r * 8 + c]) * i32::from(quant[r * 8 + c]));
            }
            let res = if col[1..].iter().all(|&v| v == 0) {
                // Same result as the full transform, without the multiplications.
                [sat16(col[0] << 2); 8]
            } else {
                idct_1d(col, SHIFT_PASS1)
            };
            for (r, v) in res.into_iter().enumerate() {
                ws[r][c] = v;
            }
        }
    }
    for (r, row) in ws.iter().enumerate() {
        let res = if row[1..].iter().all(|&v| v == 0) {
            [(row[0] + 16) >> 5; 8]
        } else {
            idct_1d(*row, SHIFT_PASS2)
        };
        let start = offset + r * stride;
        if let Some(dst) = out.get_mut(start..start + 8) {
            for (d, v) in dst.iter_mut().zip(res) {
                *d = (v.clamp(-128, 127) + 128) as u8;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(coefs: &[i16; 64], quant: &[i16; 64]) -> [u8; 64] {
        let mut out = [0u8; 64];
        idct_block(coefs, quant, &mut out, 0, 8);
        let mut scalar = [0u8; 64];
        idct_block_scalar(coefs, quant, &mut scalar, 0, 8);
        assert_eq!(
            out, scalar,
            "vector and scalar IDCT differ on {coefs:?} q {quant:?}"
        );
        out
    }

    #[test]
    fn vector_and_scalar_agree_on_random_blocks() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for i in 0..20_000 {
            let mut c = [0i16; 64];
            let mut q = [0i16; 64];
            let nonzero = 1 + (next() % 64) as usize;
            for _ in 0..nonzero {
                let k = (next() % 64) as usize;
                c[k] = match i % 3 {
                    0 => (next() % 2048) as i16 - 1024,
                    1 => next() as i16,
                    _ => (next() % 64) as i16 - 32,
                };
            }
            if i % 5 == 0 {
                c[8..].fill(0);
            }
            for v in &mut q {
                *v = if i % 2 == 0 {
                    (next() % 255 + 1) as i16
                } else {
                    next() as i16
                };
            }
            run(&c, &q);
        }
    }

    #[test]
    fn dc_only_block_is_flat() {
        let q = [1i16; 64];
        let mut c = [0i16; 64];
        // DC 80 * q 2 = 160: first pass 640, second (640 + 16) >> 5 = 20, plus 128.
        c[0] = 80;
        let mut q2 = q;
        q2[0] = 2;
        assert_eq!(run(&c, &q2), [148; 64]);
        // Negative values round down after the half is added: -9 -> -36, and
        // (-36 + 16) >> 5 = -1 (floor of -0.625), so 127.
        c[0] = -9;
        assert_eq!(run(&c, &q), [127; 64]);
        // Zero block: mid-grey.
        assert_eq!(run(&[0; 64], &q), [128; 64]);
        // Out of range, checked against cv2.imread on files with these blocks: 840 * 5
        // = 4200 -> 525 after both passes, which saturates to 255 (jidctint.c's range
        // table would wrap it to 0); 1800 * 5 = 9000 overflows the 16-bit DC shortcut
        // (9000 << 2 wraps to -29536): black; -1800 * 5 wraps the other way: white.
        let q5 = [5i16; 64];
        c[0] = 840;
        assert_eq!(run(&c, &q5), [255; 64]);
        c[0] = 1800;
        assert_eq!(run(&c, &q5), [0; 64]);
        c[0] = -1800;
        assert_eq!(run(&c, &q5), [255; 64]);
    }

    #[test]
    fn first_horizontal_frequency_by_hand() {
        // Coefficient (0, 1) = 100, quantiser 1, everything else zero: the first pass
        // copies 400 down column 1 (rows 1-7 of coefficients are zero); the second pass
        // is a 1-D IDCT of [0, 400, 0, ...] per row. By hand, with the constants above:
        // z4 = 400, z3r = 400 * 9633, z4r = 400 * (9633 - 3196),
        // o0 = -7373 * 400 + z3r, o1 = z4r, o2 = z3r, o3 = (12299 - 7373) * 400 + z4r.
        let mut c = [0i16; 64];
        c[1] = 100;
        let o0 = -7373 * 400 + 400 * 9633;
        let o1 = 400 * (9633 - 3196);
        let o2 = 400 * 9633;
        let o3 = (12299 - 7373) * 400 + 400 * (9633 - 3196);
        let d = |x: i32| ((x + (1 << 17)) >> 18).clamp(-128, 127) + 128;
        let expect = [d(o3), d(o2), d(o1), d(o0), d(-o0), d(-o1), d(-o2), d(-o3)];
        let out = run(&c, &[1; 64]);
        for r in 0..8 {
            for (x, e) in expect.iter().enumerate() {
                assert_eq!(i32::from(out[r * 8 + x]), *e, "row {r} col {x}");
            }
        }
        // Symmetric: a cosine, so sample 7 - x mirrors sample x about 128.
        assert_eq!(i32::from(out[0]) + i32::from(out[7]), 256);
    }
}
