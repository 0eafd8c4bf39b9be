//! Block smoothing of an incomplete progressive image (libjpeg-turbo's
//! `decompress_smooth_data`, `jdcoefct.c`).
//!
//! When a progressive file ends before all of its scans (or never sends some low
//! coefficients), libjpeg-turbo estimates each missing low-frequency AC coefficient from
//! the DC values of the 5x5 neighbouring blocks; when no AC data at all has arrived it
//! also re-estimates the DC. OpenCV returns that estimate, so tether computes it the
//! same way, with the same integer formulas and the same treatment of the image edges.

use super::idct::idct_block;
use super::{Component, Frame, Process};

/// How many coefficients (zigzag order) the smoothing looks at.
const SAVED_COEFS: usize = 10;

/// Natural-order positions of zigzag coefficients 0-9.
const Q00: usize = 0;
const Q01: usize = 1;
const Q10: usize = 8;
const Q20: usize = 16;
const Q11: usize = 9;
const Q02: usize = 2;
const Q03: usize = 3;
const Q12: usize = 10;
const Q21: usize = 17;
const Q30: usize = 24;

/// Per component, the coefficient precision known at the end of input
/// (`coef_bits_latch`) and before the component's last scan.
pub(crate) struct Latch {
    cur: [i32; SAVED_COEFS],
    prev: [i32; SAVED_COEFS],
}

/// libjpeg-turbo's `smoothing_ok`: the latches when smoothing applies, else `None`.
pub(crate) fn smoothing_latches(frame: &Frame, input_scan_number: u32) -> Option<Vec<Latch>> {
    if frame.process != Process::Progressive {
        return None;
    }
    let mut useful = false;
    let mut latches = Vec::with_capacity(frame.comps.len());
    for c in &frame.comps {
        let q = c.quant.as_ref()?;
        if [Q00, Q01, Q10, Q20, Q11, Q02, Q03, Q12, Q21, Q30]
            .iter()
            .any(|&p| q[p] == 0)
        {
            return None;
        }
        if c.coef_bits[0] < 0 {
            return None;
        }
        let mut latch = Latch {
            cur: [0; SAVED_COEFS],
            prev: [0; SAVED_COEFS],
        };
        latch.cur[0] = c.coef_bits[0];
        for k in 1..SAVED_COEFS {
            latch.prev[k] = if input_scan_number > 1 {
                c.prev_coef_bits[k]
            } else {
                -1
            };
            latch.cur[k] = c.coef_bits[k];
            if c.coef_bits[k] != 0 {
                useful = true;
            }
        }
        latches.push(latch);
    }
    useful.then_some(latches)
}

/// Rounded estimate of a coefficient: `num / (Q << 8)` rounded to nearest, limited to
/// what the missing bits could hold when `al > 0`.
fn predict(num: i64, q: i64, al: i32) -> i16 {
    let limit = |p: i64| {
        if al > 0 && p >= 1 << al {
            (1 << al) - 1
        } else {
            p
        }
    };
    let pred = if num >= 0 {
        limit(((q << 7) + num) / (q << 8))
    } else {
        -limit(((q << 7) - num) / (q << 8))
    };
    pred as i16
}

/// Estimates the missing low coefficients of one block in `ws` (and, when `change_dc`,
/// its DC) from the DC values `dc` of its 5x5 neighbourhood (rows top to bottom, columns
/// left to right), with the precision `bits` known of each coefficient and the
/// component's quantisation table `qt`: libjpeg-turbo's integer formulas, as they are.
fn estimate_block(
    ws: &mut [i16; 64],
    dc: &[[i64; 5]; 5],
    bits: &[i32; SAVED_COEFS],
    change_dc: bool,
    qt: &[u16; 64],
) {
    // libjpeg-turbo's DC01..DC25, row by row.
    let d = |n: usize| dc[(n - 1) / 5][(n - 1) % 5];
    let q = |p: usize| i64::from(qt[p]);
    let q00 = q(Q00);
    let estimate = |ws: &mut [i16; 64], pos: usize, k: usize, num: i64| {
        let al = bits[k];
        if al != 0 && ws[pos] == 0 {
            ws[pos] = predict(q00 * num, q(pos), al);
        }
    };
    // AC01
    let num = if change_dc {
        -d(1) - d(2) + d(4) + d(5) - 3 * d(6) + 13 * d(7) - 13 * d(9) + 3 * d(10) - 3 * d(11)
            + 38 * d(12)
            - 38 * d(14)
            + 3 * d(15)
            - 3 * d(16)
            + 13 * d(17)
            - 13 * d(19)
            + 3 * d(20)
            - d(21)
            - d(22)
            + d(24)
            + d(25)
    } else {
        -7 * d(11) + 50 * d(12) - 50 * d(14) + 7 * d(15)
    };
    estimate(ws, Q01, 1, num);
    // AC10
    let num = if change_dc {
        -d(1) - 3 * d(2) - 3 * d(3) - 3 * d(4) - d(5) - d(6) + 13 * d(7) + 38 * d(8) + 13 * d(9)
            - d(10)
            + d(16)
            - 13 * d(17)
            - 38 * d(18)
            - 13 * d(19)
            + d(20)
            + d(21)
            + 3 * d(22)
            + 3 * d(23)
            + 3 * d(24)
            + d(25)
    } else {
        -7 * d(3) + 50 * d(8) - 50 * d(18) + 7 * d(23)
    };
    estimate(ws, Q10, 2, num);
    // AC20
    let num = if change_dc {
        d(3) + 2 * d(7) + 7 * d(8) + 2 * d(9) - 5 * d(12) - 14 * d(13) - 5 * d(14)
            + 2 * d(17)
            + 7 * d(18)
            + 2 * d(19)
            + d(23)
    } else {
        -d(3) + 13 * d(8) - 24 * d(13) + 13 * d(18) - d(23)
    };
    estimate(ws, Q20, 3, num);
    // AC11
    let num = if change_dc {
        -d(1) + d(5) + 9 * d(7) - 9 * d(9) - 9 * d(17) + 9 * d(19) + d(21) - d(25)
    } else {
        d(10) + d(16) - 10 * d(17) + 10 * d(19) - d(2) - d(20) + d(22) - d(24) + d(4) - d(6)
            + 10 * d(7)
            - 10 * d(9)
    };
    estimate(ws, Q11, 4, num);
    // AC02
    let num = if change_dc {
        2 * d(7) - 5 * d(8) + 2 * d(9) + d(11) + 7 * d(12) - 14 * d(13)
            + 7 * d(14)
            + d(15)
            + 2 * d(17)
            - 5 * d(18)
            + 2 * d(19)
    } else {
        -d(11) + 13 * d(12) - 24 * d(13) + 13 * d(14) - d(15)
    };
    estimate(ws, Q02, 5, num);
    if change_dc {
        // AC03, AC12, AC21, AC30
        let num = d(7) - d(9) + 2 * d(12) - 2 * d(14) + d(17) - d(19);
        estimate(ws, Q03, 6, num);
        let num = d(7) - 3 * d(8) + d(9) - d(17) + 3 * d(18) - d(19);
        estimate(ws, Q12, 7, num);
        let num = d(7) - d(9) - 3 * d(12) + 3 * d(14) + d(17) - d(19);
        estimate(ws, Q21, 8, num);
        let num = d(7) + 2 * d(8) + d(9) - d(17) - 2 * d(18) - d(19);
        estimate(ws, Q30, 9, num);
        // The DC itself, from a Gaussian-like kernel.
        let num = -2 * d(1) - 6 * d(2) - 8 * d(3) - 6 * d(4) - 2 * d(5) - 6 * d(6)
            + 6 * d(7)
            + 42 * d(8)
            + 6 * d(9)
            - 6 * d(10)
            - 8 * d(11)
            + 42 * d(12)
            + 152 * d(13)
            + 42 * d(14)
            - 8 * d(15)
            - 6 * d(16)
            + 6 * d(17)
            + 42 * d(18)
            + 6 * d(19)
            - 6 * d(20)
            - 2 * d(21)
            - 6 * d(22)
            - 8 * d(23)
            - 6 * d(24)
            - 2 * d(25);
        ws[0] = predict(q00 * num, q00, 0);
    }
}

/// The IDCT of one component with block smoothing, into its sample plane.
pub(crate) fn smooth_component(
    c: &mut Component,
    latch: &Latch,
    total_imcu_rows: usize,
    last_good_imcu_row: usize,
) {
    let quant = c.idct_quant();
    let Some(qt) = c.quant else { return };
    let stride = c.plane_stride();
    let wib = c.width_in_blocks;
    let last_col = wib.saturating_sub(1);
    let bw = c.blocks_w;
    let v = c.v;
    let dc_at = |coefs: &[[i16; 64]], row: usize, col: usize| -> i64 {
        i64::from(coefs.get(row * bw + col).map_or(0, |b| b[0]))
    };
    for imcu in 0..total_imcu_rows {
        let block_rows = if imcu + 1 < total_imcu_rows {
            v
        } else {
            match c.height_in_blocks % v {
                0 => v,
                n => n,
            }
        };
        let bits = if imcu > last_good_imcu_row {
            &latch.prev
        } else {
            &latch.cur
        };
        let change_dc = bits[1..=9].iter().all(|&b| b == -1);
        // libjpeg-turbo counts rows with this iMCU row's block_rows; reproduced as is.
        let image_block_rows = block_rows * total_imcu_rows;
        for block_row in 0..block_rows {
            let image_block_row = imcu * block_rows + block_row;
            let row = imcu * v + block_row;
            let prev = if image_block_row > 0 { row - 1 } else { row };
            let prev_prev = if image_block_row > 1 { row - 2 } else { prev };
            let next = if image_block_row + 1 < image_block_rows {
                row + 1
            } else {
                row
            };
            let next_next = if image_block_row + 2 < image_block_rows {
                row + 2
            } else {
                next
            };
            let rows = [prev_prev, prev, row, next, next_next];
            // dc[r][k]: DC of rows[r], at the column k - 2 relative to the block, held
            // in a sliding window as libjpeg-turbo does (edges replicate).
            let mut dc = [[0i64; 5]; 5];
            for (r, &rr) in rows.iter().enumerate() {
                dc[r] = [dc_at(&c.coefs, rr, 0); 5];
            }
            for col in 0..wib {
                let mut ws = c.coefs.get(row * bw + col).copied().unwrap_or([0; 64]);
                if col == 0 && col < last_col {
                    for (r, &rr) in rows.iter().enumerate() {
                        let d = dc_at(&c.coefs, rr, 1);
                        dc[r][3] = d;
                        dc[r][4] = d;
                    }
                }
                if col + 1 < last_col {
                    for (r, &rr) in rows.iter().enumerate() {
                        dc[r][4] = dc_at(&c.coefs, rr, col + 2);
                    }
                }
                estimate_block(&mut ws, &dc, bits, change_dc, &qt);
                idct_block(
                    &ws,
                    &quant,
                    &mut c.plane,
                    row * 8 * stride + col * 8,
                    stride,
                );
                // Slide the window one block to the right.
                for r in &mut dc {
                    r.copy_within(1..5, 0);
                }
            }
        }
    }
}
