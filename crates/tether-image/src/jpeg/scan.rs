//! Scans: setup (`jdinput.c`'s `per_scan_setup`, `latch_quant_tables`), the Huffman
//! MCU decoders of `jdhuff.c` (sequential) and `jdphuff.c` (progressive), restart
//! markers (`jdmarker.c`'s `read_restart_marker`, `jpeg_resync_to_restart`), and the two
//! ways libjpeg's coefficient controller drives them (`jdcoefct.c`): straight to the
//! IDCT for a single-scan file, into whole-image coefficient buffers otherwise.

use super::arith::{ArithDecoder, ArithScan};
use super::huffman::{BitReader, HuffTable, NATURAL_ORDER, table_error};
use super::idct::idct_block;
use super::source::{Source, marker};
use super::{Decoder, JpegError, Process, Warning};

/// The most blocks an MCU may have (libjpeg's `D_MAX_BLOCKS_IN_MCU`).
const MAX_BLOCKS_IN_MCU: usize = 10;

/// Geometry and decoding state of the current scan.
pub(crate) struct ScanState {
    pub bits: BitReader,
    /// Per block of an MCU: index into the scan's components.
    pub membership: Vec<usize>,
    pub mcus_per_row: usize,
    /// For a single-component scan, the component's block rows; for an interleaved one,
    /// MCU rows.
    pub mcu_rows: usize,
    /// Block rows per iMCU row for a single-component scan (its v factor), else 1.
    pub rows_per_imcu: usize,
    pub restarts_to_go: u32,
    pub last_dc: [i32; 4],
    pub eobrun: u32,
    dc: Vec<Option<HuffTable>>,
    ac: Vec<Option<HuffTable>>,
    /// The arithmetic decoder of an arithmetic-coded scan (then `dc` and `ac` are empty).
    pub arith: Option<ArithDecoder>,
}

impl Decoder<'_> {
    /// Starts the scan whose SOS was just read.
    pub(crate) fn start_scan(&mut self) -> Result<(), JpegError> {
        let at = self.scan.data_offset;
        let frame = self
            .frame
            .as_mut()
            .ok_or_else(|| JpegError::corrupt(at, None, "no frame header"))?;
        let scan = &self.scan;
        // Quantisation tables are copied at the component's first scan.
        for &ci in &scan.comps {
            let c = &mut frame.comps[ci];
            if c.quant.is_none() {
                let table = self.quant.get(usize::from(c.tq)).copied().flatten();
                match table {
                    Some(t) => c.quant = Some(t),
                    None => {
                        return Err(JpegError::corrupt(
                            at,
                            Some(marker::SOS),
                            format!("quantization table 0x{:02X} was not defined", c.tq),
                        ));
                    }
                }
            }
        }
        if scan.comps.len() > 1 {
            let blocks: usize = scan
                .comps
                .iter()
                .map(|&ci| frame.comps[ci].h * frame.comps[ci].v)
                .sum();
            if blocks > MAX_BLOCKS_IN_MCU {
                return Err(JpegError::corrupt(
                    at,
                    Some(marker::SOS),
                    "sampling factors too large for interleaved scan",
                ));
            }
        }
        match frame.process {
            Process::Sequential => {
                if scan.ss != 0 || scan.se != 63 || scan.ah != 0 || scan.al != 0 {
                    self.src.warnings.push(Warning::BogusScan { offset: at });
                }
            }
            Process::Progressive => {
                let dc_band = scan.ss == 0;
                let mut bad = if dc_band {
                    scan.se != 0
                } else {
                    scan.ss > scan.se || scan.se >= 64 || scan.comps.len() != 1
                };
                if scan.ah != 0 && scan.al + 1 != scan.ah {
                    bad = true;
                }
                if scan.al > 13 {
                    bad = true;
                }
                if bad {
                    return Err(JpegError::corrupt(
                        at,
                        Some(marker::SOS),
                        format!(
                            "invalid progressive parameters Ss={} Se={} Ah={} Al={}",
                            scan.ss, scan.se, scan.ah, scan.al
                        ),
                    ));
                }
                let mut bogus = false;
                for &ci in &scan.comps {
                    let c = &mut frame.comps[ci];
                    if !dc_band && c.coef_bits[0] < 0 {
                        bogus = true;
                    }
                    for k in scan.ss.min(1)..=scan.se.max(9) {
                        c.prev_coef_bits[k] = if self.input_scan_number > 1 {
                            c.coef_bits[k]
                        } else {
                            0
                        };
                    }
                    for k in scan.ss..=scan.se {
                        let expected = c.coef_bits[k].max(0);
                        if scan.ah as i32 != expected {
                            bogus = true;
                        }
                        c.coef_bits[k] = scan.al as i32;
                    }
                }
                if bogus {
                    self.src.warnings.push(Warning::BogusScan { offset: at });
                }
            }
        }
        Ok(())
    }

    /// Builds the scan's MCU geometry and Huffman tables.
    fn scan_state(&self) -> Result<ScanState, JpegError> {
        let at = self.scan.data_offset;
        let frame = self.frame_ref()?;
        let scan = &self.scan;
        let mut membership = Vec::new();
        let (mcus_per_row, mcu_rows, rows_per_imcu) = if scan.comps.len() == 1 {
            let c = &frame.comps[scan.comps[0]];
            membership.push(0);
            (c.width_in_blocks, c.height_in_blocks, c.v)
        } else {
            for (i, &ci) in scan.comps.iter().enumerate() {
                let c = &frame.comps[ci];
                membership.extend(std::iter::repeat_n(i, c.h * c.v));
            }
            (
                frame.width.div_ceil(frame.hmax * 8),
                frame.height.div_ceil(frame.vmax * 8),
                1,
            )
        };
        let progressive = frame.process == Process::Progressive;
        let (mut dc, mut ac, mut arith) = (Vec::new(), Vec::new(), None);
        if frame.arithmetic {
            let tables = |pick: fn(&super::Component) -> usize| {
                scan.comps
                    .iter()
                    .map(|&ci| pick(&frame.comps[ci]))
                    .collect()
            };
            arith = Some(ArithDecoder::new(ArithScan {
                progressive,
                ss: scan.ss,
                se: scan.se,
                ah: scan.ah,
                al: scan.al,
                dc_tbl: tables(|c| c.dc_tbl),
                ac_tbl: tables(|c| c.ac_tbl),
                conditioning: self.conditioning,
            }));
        } else {
            // Huffman tables: which ones a scan of this kind uses.
            let (want_dc, want_ac) = if progressive {
                (scan.ss == 0 && scan.ah == 0, scan.ss != 0)
            } else {
                (true, true)
            };
            for &ci in &scan.comps {
                let c = &frame.comps[ci];
                dc.push(if want_dc {
                    Some(self.table(true, c.dc_tbl, at)?)
                } else {
                    None
                });
                ac.push(if want_ac {
                    Some(self.table(false, c.ac_tbl, at)?)
                } else {
                    None
                });
            }
        }
        Ok(ScanState {
            bits: BitReader::new(),
            membership,
            mcus_per_row,
            mcu_rows,
            rows_per_imcu,
            restarts_to_go: self.restart_interval,
            last_dc: [0; 4],
            eobrun: 0,
            dc,
            ac,
            arith,
        })
    }

    fn table(&self, is_dc: bool, index: usize, at: usize) -> Result<HuffTable, JpegError> {
        let specs = if is_dc {
            &self.dc_tables
        } else {
            &self.ac_tables
        };
        let spec = specs.get(index).and_then(Option::as_ref).ok_or_else(|| {
            JpegError::corrupt(
                at,
                Some(marker::SOS),
                format!(
                    "Huffman table 0x{:02X} was not defined",
                    if is_dc { index } else { index + 0x10 }
                ),
            )
        })?;
        HuffTable::new(spec, is_dc).map_err(|why| table_error(at, is_dc, index, why))
    }

    /// libjpeg's `process_restart` (Huffman).
    fn process_restart(&mut self, st: &mut ScanState) {
        st.bits.reset(&mut self.src);
        self.read_restart_marker();
        st.last_dc = [0; 4];
        st.eobrun = 0;
        st.restarts_to_go = self.restart_interval;
        if self.src.unread_marker.is_none() {
            st.bits.insufficient = false;
        }
    }

    /// libjpeg's `read_restart_marker`: the expected RSTn, or resynchronisation.
    pub(crate) fn read_restart_marker(&mut self) {
        let m = self.src.take_marker();
        let expected = self.next_restart_num;
        if m != marker::RST0 + expected {
            self.src.warnings.push(Warning::RestartResync {
                offset: self.src.pos(),
                expected,
            });
            self.resync_to_restart(m, expected);
        }
        self.next_restart_num = (expected + 1) & 7;
    }

    /// libjpeg's `jpeg_resync_to_restart`: decides whether to discard the marker found,
    /// look further, or leave it for later (the entropy decoder then sees no data).
    fn resync_to_restart(&mut self, mut m: u8, desired: u8) {
        let rst = |n: u8| marker::RST0 + (n & 7);
        loop {
            // 1: drop the marker and go on; 2: look for the next marker; 3: leave the
            // marker for later (the entropy decoder then sees no data).
            let next_two = m == rst(desired.wrapping_add(1)) || m == rst(desired.wrapping_add(2));
            let prior_two = m == rst(desired.wrapping_sub(1)) || m == rst(desired.wrapping_sub(2));
            let action = if m < marker::SOF0 {
                2
            } else if !(marker::RST0..=marker::RST7).contains(&m) || next_two {
                3
            } else if prior_two {
                2
            } else {
                1
            };
            match action {
                1 => {
                    self.src.unread_marker = None;
                    return;
                }
                2 => m = self.src.next_marker(),
                _ => {
                    self.src.unread_marker = Some(m);
                    return;
                }
            }
        }
    }

    /// A single-scan file: each MCU goes straight to the IDCT (`decompress_onepass`).
    pub(crate) fn decode_scan_streaming(&mut self) -> Result<(), JpegError> {
        let mut st = self.scan_state()?;
        let mut frame = self
            .frame
            .take()
            .ok_or_else(|| JpegError::corrupt(0, None, "no frame header"))?;
        let comps = self.scan.comps.clone();
        let quants: Vec<[i16; 64]> = comps
            .iter()
            .map(|&ci| frame.comps[ci].idct_quant())
            .collect();
        let needed: Vec<bool> = comps.iter().map(|&ci| frame.comps[ci].needed).collect();
        let mut blocks = [[0i16; 64]; MAX_BLOCKS_IN_MCU];
        let n_blocks = st.membership.len();
        for mcu_row in 0..st.mcu_rows {
            for mcu_col in 0..st.mcus_per_row {
                blocks[..n_blocks].fill([0; 64]);
                if st.arith.is_some() {
                    self.decode_mcu_arith(&mut st, &mut blocks[..n_blocks]);
                } else {
                    self.decode_mcu_sequential(&mut st, &mut blocks[..n_blocks], &needed);
                }
                // IDCT the blocks inside the component (not the MCU padding).
                let mut b = 0;
                for (i, &ci) in comps.iter().enumerate() {
                    let c = &mut frame.comps[ci];
                    let (mw, mh) = if comps.len() == 1 { (1, 1) } else { (c.h, c.v) };
                    for yy in 0..mh {
                        for xx in 0..mw {
                            let (by, bx) = (mcu_row * mh + yy, mcu_col * mw + xx);
                            if needed[i] && by < c.height_in_blocks && bx < c.width_in_blocks {
                                let stride = c.plane_stride();
                                idct_block(
                                    &blocks[b],
                                    &quants[i],
                                    &mut c.plane,
                                    by * 8 * stride + bx * 8,
                                    stride,
                                );
                            }
                            b += 1;
                        }
                    }
                }
            }
        }
        self.frame = Some(frame);
        self.finish_scan(&mut st);
        Ok(())
    }

    /// A multi-scan file: MCUs go into the coefficient buffers (`consume_data`).
    // Parallel to decode_scan_streaming on purpose: the two are libjpeg's two decoding
    // paths, each a hot loop of its own over the MCUs.
    pub(crate) fn decode_scan_buffered(&mut self) -> Result<(), JpegError> {
        let mut st = self.scan_state()?;
        let mut frame = self
            .frame
            .take()
            .ok_or_else(|| JpegError::corrupt(0, None, "no frame header"))?;
        let comps = self.scan.comps.clone();
        let needed: Vec<bool> = comps.iter().map(|&ci| frame.comps[ci].needed).collect();
        let progressive = frame.process == Process::Progressive;
        let mut result = Ok(());
        let mut positions: Vec<(usize, usize)> = Vec::with_capacity(MAX_BLOCKS_IN_MCU);
        'rows: for mcu_row in 0..st.mcu_rows {
            let imcu_row = mcu_row / st.rows_per_imcu;
            for mcu_col in 0..st.mcus_per_row {
                positions.clear();
                for &ci in &comps {
                    let c = &frame.comps[ci];
                    if comps.len() == 1 {
                        positions.push((ci, mcu_row * c.blocks_w + mcu_col));
                    } else {
                        for yy in 0..c.v {
                            for xx in 0..c.h {
                                let (by, bx) = (mcu_row * c.v + yy, mcu_col * c.h + xx);
                                positions.push((ci, by * c.blocks_w + bx));
                            }
                        }
                    }
                }
                if !st.bits.insufficient {
                    self.last_good_imcu_row = imcu_row;
                }
                let mut mcu = [[0i16; 64]; MAX_BLOCKS_IN_MCU];
                for (slot, &(ci, idx)) in mcu.iter_mut().zip(&positions) {
                    *slot = frame.comps[ci].coefs[idx];
                }
                let n = positions.len();
                if st.arith.is_some() {
                    self.decode_mcu_arith(&mut st, &mut mcu[..n]);
                } else if progressive {
                    if let Err(e) = self.decode_mcu_progressive(&mut st, &mut mcu[..n]) {
                        result = Err(e);
                        break 'rows;
                    }
                } else {
                    self.decode_mcu_sequential(&mut st, &mut mcu[..n], &needed);
                }
                for (slot, &(ci, idx)) in mcu.iter().zip(&positions) {
                    frame.comps[ci].coefs[idx] = *slot;
                }
            }
        }
        self.frame = Some(frame);
        result?;
        self.finish_scan(&mut st);
        Ok(())
    }

    fn finish_scan(&mut self, st: &mut ScanState) {
        let end = self.src.pos();
        if let Some(w) = st.bits.take_warning(end) {
            self.src.warnings.push(w);
        }
        if st.bits.insufficient {
            self.src.warnings.push(Warning::CorruptData { offset: end });
        }
    }

    /// `jdhuff.c`'s `decode_mcu`: the blocks of one MCU, zeroed by the caller in the
    /// single-scan case. Components whose samples are not needed are decoded and dropped.
    fn decode_mcu_sequential(
        &mut self,
        st: &mut ScanState,
        blocks: &mut [[i16; 64]],
        needed: &[bool],
    ) {
        if self.restart_interval != 0 && st.restarts_to_go == 0 {
            self.process_restart(st);
        }
        if !st.bits.insufficient {
            let src = &mut self.src;
            // A local copy of the bit buffer stays in registers.
            let mut bits = st.bits;
            for (block, &i) in blocks.iter_mut().zip(&st.membership) {
                let (Some(dc), Some(ac)) = (&st.dc[i], &st.ac[i]) else {
                    continue;
                };
                let s = u32::from(bits.decode(dc, src));
                let diff = if s != 0 {
                    bits.receive_extend(s, src)
                } else {
                    0
                };
                if needed[i] {
                    st.last_dc[i] = st.last_dc[i].wrapping_add(diff);
                    block[0] = st.last_dc[i] as i16;
                    let mut k = 1;
                    while k < 64 {
                        if let Some((run, v)) = bits.fast_ac(ac, src) {
                            k += run;
                            block[NATURAL_ORDER[k]] = v;
                            k += 1;
                            continue;
                        }
                        let rs = bits.decode(ac, src);
                        let r = usize::from(rs >> 4);
                        let s = u32::from(rs & 15);
                        if s != 0 {
                            k += r;
                            let v = bits.receive_extend(s, src);
                            block[NATURAL_ORDER[k]] = v as i16;
                        } else if r == 15 {
                            k += 15;
                        } else {
                            break;
                        }
                        k += 1;
                    }
                } else {
                    let mut k = 1;
                    while k < 64 {
                        if let Some((run, _)) = bits.fast_ac(ac, src) {
                            k += run + 1;
                            continue;
                        }
                        let rs = bits.decode(ac, src);
                        let r = usize::from(rs >> 4);
                        let s = u32::from(rs & 15);
                        if s != 0 {
                            k += r;
                            bits.bits(s, src);
                        } else if r == 15 {
                            k += 15;
                        } else {
                            break;
                        }
                        k += 1;
                    }
                }
            }
            bits.end_mcu();
            st.bits = bits;
        }
        if self.restart_interval != 0 {
            st.restarts_to_go = st.restarts_to_go.wrapping_sub(1);
        }
    }

    /// `jdphuff.c`'s four MCU decoders.
    fn decode_mcu_progressive(
        &mut self,
        st: &mut ScanState,
        blocks: &mut [[i16; 64]],
    ) -> Result<(), JpegError> {
        if self.restart_interval != 0 && st.restarts_to_go == 0 {
            self.process_restart(st);
        }
        let (ss, se, ah, al) = (self.scan.ss, self.scan.se, self.scan.ah, self.scan.al);
        let src = &mut self.src;
        if ss == 0 {
            if ah == 0 {
                if !st.bits.insufficient {
                    for (block, &i) in blocks.iter_mut().zip(&st.membership) {
                        let Some(dc) = &st.dc[i] else { continue };
                        let s = u32::from(st.bits.decode(dc, src));
                        let diff = if s != 0 {
                            st.bits.receive_extend(s, src)
                        } else {
                            0
                        };
                        let Some(v) = st.last_dc[i].checked_add(diff) else {
                            return Err(JpegError::corrupt(
                                src.pos(),
                                Some(marker::SOS),
                                "DCT coefficient out of range",
                            ));
                        };
                        st.last_dc[i] = v;
                        block[0] = (i64::from(v) << al) as i16;
                    }
                    st.bits.end_mcu();
                }
            } else {
                // DC refinement: one bit per block, even after the data ran out (zeros
                // change nothing).
                let p1 = 1i16 << al;
                for block in blocks.iter_mut() {
                    if st.bits.bit(src) {
                        block[0] |= p1;
                    }
                }
                st.bits.end_mcu();
            }
        } else if !st.bits.insufficient {
            let Some(ac) = &st.ac[0] else {
                return Ok(());
            };
            let Some(block) = blocks.first_mut() else {
                return Ok(());
            };
            if ah == 0 {
                if st.eobrun > 0 {
                    st.eobrun -= 1;
                } else {
                    let mut k = ss;
                    while k <= se {
                        let rs = st.bits.decode(ac, src);
                        let r = usize::from(rs >> 4);
                        let s = u32::from(rs & 15);
                        if s != 0 {
                            k += r;
                            let v = st.bits.receive_extend(s, src);
                            block[NATURAL_ORDER[k]] = (v << al) as i16;
                        } else if r == 15 {
                            k += 15;
                        } else {
                            let mut run = 1u32 << r;
                            if r != 0 {
                                run += st.bits.bits(r as u32, src);
                            }
                            st.eobrun = run - 1;
                            break;
                        }
                        k += 1;
                    }
                    st.bits.end_mcu();
                }
            } else {
                refine_ac(st, block, src, ss, se, al);
                st.bits.end_mcu();
            }
        }
        if self.restart_interval != 0 {
            st.restarts_to_go = st.restarts_to_go.wrapping_sub(1);
        }
        Ok(())
    }
}

/// `decode_mcu_AC_refine`: a refinement bit for each nonzero coefficient in the band,
/// and new coefficients of +-1 at this bit position.
fn refine_ac(
    st: &mut ScanState,
    block: &mut [i16; 64],
    src: &mut Source<'_>,
    ss: usize,
    se: usize,
    al: u32,
) {
    let Some(ac) = &st.ac[0] else { return };
    let p1 = 1i16 << al;
    let m1 = (-1i16).wrapping_shl(al);
    let mut k = ss;
    let refine = |coef: &mut i16, bits: &mut BitReader, src: &mut Source<'_>| {
        if bits.bit(src) && (*coef & p1) == 0 {
            *coef = coef.wrapping_add(if *coef >= 0 { p1 } else { m1 });
        }
    };
    if st.eobrun == 0 {
        while k <= se {
            let rs = st.bits.decode(ac, src);
            let mut r = i32::from(rs >> 4);
            let s = rs & 15;
            let mut value = 0i16;
            if s != 0 {
                if s != 1 {
                    st.bits.bad_code = true;
                }
                value = if st.bits.bit(src) { p1 } else { m1 };
            } else if r != 15 {
                st.eobrun = 1 << r;
                if r != 0 {
                    st.eobrun += st.bits.bits(r as u32, src);
                }
                break;
            }
            // Skip r zero coefficients (refining the nonzero ones on the way), then
            // stop on the next zero one.
            loop {
                let coef = &mut block[NATURAL_ORDER[k]];
                if *coef != 0 {
                    refine(coef, &mut st.bits, src);
                } else {
                    r -= 1;
                    if r < 0 {
                        break;
                    }
                }
                k += 1;
                if k > se {
                    break;
                }
            }
            if s != 0 {
                block[NATURAL_ORDER[k]] = value;
            }
            k += 1;
        }
    }
    if st.eobrun > 0 {
        while k <= se {
            let coef = &mut block[NATURAL_ORDER[k]];
            if *coef != 0 {
                refine(coef, &mut st.bits, src);
            }
            k += 1;
        }
        st.eobrun -= 1;
    }
}
