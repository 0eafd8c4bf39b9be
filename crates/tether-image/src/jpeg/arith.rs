//! Arithmetic-coded scans (SOF9 sequential, SOF10 progressive): the binary arithmetic
//! decoder of ITU-T T.81 Annex D and the coefficient procedures of Annexes F and G, in
//! the form libjpeg-turbo's `jdarith.c` gives them (so that damaged data decodes as
//! `cv2.imread` decodes it).
//!
//! The decoder keeps the code register `C` and a bit counter `CT` whose cut point between
//! the interval base and the unread bits floats, and one byte per statistics bin: the
//! more probable symbol in bit 7 and the state of Table D.2 in bits 0-6. A marker met in
//! the data is legal here: zeros are fed from then on. A magnitude or spectral overflow
//! (damaged data) stops the decoding of the scan until the next restart marker, with a
//! warning.

use super::huffman::NATURAL_ORDER;
use super::scan::ScanState;
use super::source::Source;
use super::{Decoder, Warning};

/// T.81 Table D.2, packed: `Qe << 16 | Next_Index_MPS << 8 | Switch_MPS << 7 |
/// Next_Index_LPS`; entry 113 is a fixed probability of one half (T.851).
const QE_TABLE: [u32; 114] = {
    // (Qe, Next_Index_LPS, Next_Index_MPS, Switch_MPS) for each state.
    const STATES: [(u32, u32, u32, u32); 114] = [
        (0x5a1d, 1, 1, 1),
        (0x2586, 14, 2, 0),
        (0x1114, 16, 3, 0),
        (0x080b, 18, 4, 0),
        (0x03d8, 20, 5, 0),
        (0x01da, 23, 6, 0),
        (0x00e5, 25, 7, 0),
        (0x006f, 28, 8, 0),
        (0x0036, 30, 9, 0),
        (0x001a, 33, 10, 0),
        (0x000d, 35, 11, 0),
        (0x0006, 9, 12, 0),
        (0x0003, 10, 13, 0),
        (0x0001, 12, 13, 0),
        (0x5a7f, 15, 15, 1),
        (0x3f25, 36, 16, 0),
        (0x2cf2, 38, 17, 0),
        (0x207c, 39, 18, 0),
        (0x17b9, 40, 19, 0),
        (0x1182, 42, 20, 0),
        (0x0cef, 43, 21, 0),
        (0x09a1, 45, 22, 0),
        (0x072f, 46, 23, 0),
        (0x055c, 48, 24, 0),
        (0x0406, 49, 25, 0),
        (0x0303, 51, 26, 0),
        (0x0240, 52, 27, 0),
        (0x01b1, 54, 28, 0),
        (0x0144, 56, 29, 0),
        (0x00f5, 57, 30, 0),
        (0x00b7, 59, 31, 0),
        (0x008a, 60, 32, 0),
        (0x0068, 62, 33, 0),
        (0x004e, 63, 34, 0),
        (0x003b, 32, 35, 0),
        (0x002c, 33, 9, 0),
        (0x5ae1, 37, 37, 1),
        (0x484c, 64, 38, 0),
        (0x3a0d, 65, 39, 0),
        (0x2ef1, 67, 40, 0),
        (0x261f, 68, 41, 0),
        (0x1f33, 69, 42, 0),
        (0x19a8, 70, 43, 0),
        (0x1518, 72, 44, 0),
        (0x1177, 73, 45, 0),
        (0x0e74, 74, 46, 0),
        (0x0bfb, 75, 47, 0),
        (0x09f8, 77, 48, 0),
        (0x0861, 78, 49, 0),
        (0x0706, 79, 50, 0),
        (0x05cd, 48, 51, 0),
        (0x04de, 50, 52, 0),
        (0x040f, 50, 53, 0),
        (0x0363, 51, 54, 0),
        (0x02d4, 52, 55, 0),
        (0x025c, 53, 56, 0),
        (0x01f8, 54, 57, 0),
        (0x01a4, 55, 58, 0),
        (0x0160, 56, 59, 0),
        (0x0125, 57, 60, 0),
        (0x00f6, 58, 61, 0),
        (0x00cb, 59, 62, 0),
        (0x00ab, 61, 63, 0),
        (0x008f, 61, 32, 0),
        (0x5b12, 65, 65, 1),
        (0x4d04, 80, 66, 0),
        (0x412c, 81, 67, 0),
        (0x37d8, 82, 68, 0),
        (0x2fe8, 83, 69, 0),
        (0x293c, 84, 70, 0),
        (0x2379, 86, 71, 0),
        (0x1edf, 87, 72, 0),
        (0x1aa9, 87, 73, 0),
        (0x174e, 72, 74, 0),
        (0x1424, 72, 75, 0),
        (0x119c, 74, 76, 0),
        (0x0f6b, 74, 77, 0),
        (0x0d51, 75, 78, 0),
        (0x0bb6, 77, 79, 0),
        (0x0a40, 77, 48, 0),
        (0x5832, 80, 81, 1),
        (0x4d1c, 88, 82, 0),
        (0x438e, 89, 83, 0),
        (0x3bdd, 90, 84, 0),
        (0x34ee, 91, 85, 0),
        (0x2eae, 92, 86, 0),
        (0x299a, 93, 87, 0),
        (0x2516, 86, 71, 0),
        (0x5570, 88, 89, 1),
        (0x4ca9, 95, 90, 0),
        (0x44d9, 96, 91, 0),
        (0x3e22, 97, 92, 0),
        (0x3824, 99, 93, 0),
        (0x32b4, 99, 94, 0),
        (0x2e17, 93, 86, 0),
        (0x56a8, 95, 96, 1),
        (0x4f46, 101, 97, 0),
        (0x47e5, 102, 98, 0),
        (0x41cf, 103, 99, 0),
        (0x3c3d, 104, 100, 0),
        (0x375e, 99, 93, 0),
        (0x5231, 105, 102, 0),
        (0x4c0f, 106, 103, 0),
        (0x4639, 107, 104, 0),
        (0x415e, 103, 99, 0),
        (0x5627, 105, 106, 1),
        (0x50e7, 108, 107, 0),
        (0x4b85, 109, 103, 0),
        (0x5597, 110, 109, 0),
        (0x504f, 111, 107, 0),
        (0x5a10, 110, 111, 1),
        (0x5522, 112, 109, 0),
        (0x59eb, 112, 111, 1),
        (0x5a1d, 113, 113, 0),
    ];
    let mut packed = [0u32; 114];
    let mut i = 0;
    while i < 114 {
        let (qe, lps, mps, switch) = STATES[i];
        packed[i] = (qe << 16) | (mps << 8) | (switch << 7) | lps;
        i += 1;
    }
    packed
};

/// Statistics bins per DC and AC table (T.81 F.1.4.4 needs 49 and 245).
const DC_BINS: usize = 64;
const AC_BINS: usize = 256;
/// Arithmetic-coding tables (`NUM_ARITH_TBLS`).
pub(crate) const TABLES: usize = 16;

/// The conditioning of the tables (DAC marker): DC bounds `L` and `U`, AC `Kx`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Conditioning {
    pub dc_l: [u8; TABLES],
    pub dc_u: [u8; TABLES],
    pub ac_k: [u8; TABLES],
}

impl Default for Conditioning {
    /// The values T.81 prescribes without a DAC marker (set again at SOI).
    fn default() -> Self {
        Conditioning {
            dc_l: [0; TABLES],
            dc_u: [1; TABLES],
            ac_k: [5; TABLES],
        }
    }
}

/// What the MCU decoders of one scan need to know about it.
#[derive(Debug, Clone)]
pub(crate) struct ArithScan {
    pub progressive: bool,
    pub ss: usize,
    pub se: usize,
    pub ah: u32,
    pub al: u32,
    /// DC and AC table of each component of the scan.
    pub dc_tbl: Vec<usize>,
    pub ac_tbl: Vec<usize>,
    pub conditioning: Conditioning,
}

/// The arithmetic decoder's registers and statistics for one scan.
pub(crate) struct ArithDecoder {
    coder: Coder,
    last_dc: [i32; 4],
    dc_context: [usize; 4],
    dc_stats: Vec<[u8; DC_BINS]>,
    ac_stats: Vec<[u8; AC_BINS]>,
    fixed_bin: u8,
    scan: ArithScan,
}

/// The decoder's registers (T.81 D.2, as `jdarith.c` keeps them).
#[derive(Debug, Clone, Copy)]
struct Coder {
    /// Code register: interval base and input bits.
    c: i64,
    /// Interval size.
    a: i64,
    /// Input bits left in `c` (-16 before the first two bytes, -1 after an error).
    ct: i32,
}

impl Coder {
    /// Registers that read two bytes before the first decision.
    fn new() -> Coder {
        Coder {
            c: 0,
            a: 0,
            ct: -16,
        }
    }

    /// `arith_decode`: one binary decision with the statistics bin `bin`.
    fn decode(&mut self, src: &mut Source<'_>, bin: &mut u8) -> bool {
        // Renormalisation and data input (D.2.6).
        while self.a < 0x8000 {
            self.ct -= 1;
            if self.ct < 0 {
                let data = if src.unread_marker.is_some() {
                    0
                } else {
                    let mut d = src.byte();
                    if d == 0xff {
                        while d == 0xff {
                            d = src.byte();
                        }
                        if d == 0 {
                            d = 0xff;
                        } else {
                            // A marker inside the data: zeros from here on.
                            src.unread_marker = Some(d);
                            d = 0;
                        }
                    }
                    d
                };
                self.c = (self.c << 8) | i64::from(data);
                self.ct += 8;
                if self.ct < 0 {
                    self.ct += 1;
                    if self.ct == 0 {
                        // Two initial bytes read: A becomes 0x10000 below.
                        self.a = 0x8000;
                    }
                }
            }
            self.a <<= 1;
        }
        let sv = *bin;
        let entry = QE_TABLE[usize::from(sv & 0x7f)];
        let next_lps = (entry & 0xff) as u8;
        let next_mps = ((entry >> 8) & 0xff) as u8;
        let qe = i64::from(entry >> 16);
        // Decoding and estimation (D.2.4, D.2.5).
        self.a -= qe;
        // A negative count only follows an error; x86 masks the shift count.
        let temp = self.a.wrapping_shl(self.ct as u32);
        let mut symbol = sv;
        if self.c >= temp {
            self.c -= temp;
            if self.a < qe {
                self.a = qe;
                *bin = (sv & 0x80) ^ next_mps;
            } else {
                self.a = qe;
                *bin = (sv & 0x80) ^ next_lps;
                symbol ^= 0x80;
            }
        } else if self.a < 0x8000 {
            if self.a < qe {
                *bin = (sv & 0x80) ^ next_lps;
                symbol ^= 0x80;
            } else {
                *bin = (sv & 0x80) ^ next_mps;
            }
        }
        symbol >> 7 != 0
    }
}

/// Which statistics bins a decision uses: a DC or an AC table's.
#[derive(Debug, Clone, Copy)]
enum Bins {
    Dc(usize),
    Ac(usize),
}

impl ArithDecoder {
    /// `start_pass`: statistics of the scan's tables cleared, registers reset.
    pub(crate) fn new(scan: ArithScan) -> ArithDecoder {
        let mut d = ArithDecoder {
            coder: Coder::new(),
            last_dc: [0; 4],
            dc_context: [0; 4],
            dc_stats: vec![[0; DC_BINS]; TABLES],
            ac_stats: vec![[0; AC_BINS]; TABLES],
            fixed_bin: 113,
            scan,
        };
        d.reset_statistics();
        d
    }

    fn reset_statistics(&mut self) {
        let s = &self.scan;
        for ci in 0..s.dc_tbl.len() {
            if !s.progressive || (s.ss == 0 && s.ah == 0) {
                if let Some(bins) = self.dc_stats.get_mut(s.dc_tbl[ci]) {
                    *bins = [0; DC_BINS];
                }
                self.last_dc[ci] = 0;
                self.dc_context[ci] = 0;
            }
            if (!s.progressive || s.ss != 0)
                && let Some(bins) = self.ac_stats.get_mut(s.ac_tbl[ci])
            {
                *bins = [0; AC_BINS];
            }
        }
    }

    /// `process_restart` after the restart marker was read: statistics and registers
    /// start again.
    pub(crate) fn restart(&mut self) {
        self.reset_statistics();
        self.coder = Coder::new();
    }

    /// The fixed one-half bin.
    fn decode_fixed(&mut self, src: &mut Source<'_>) -> bool {
        self.coder.decode(src, &mut self.fixed_bin)
    }

    /// A decision with bin `i` of a table's statistics.
    fn bin(&mut self, src: &mut Source<'_>, bins: Bins, i: usize) -> bool {
        let stat = match bins {
            Bins::Dc(t) => &mut self.dc_stats[t][i],
            Bins::Ac(t) => &mut self.ac_stats[t][i],
        };
        self.coder.decode(src, stat)
    }

    /// Figure F.23's loop: doubles the magnitude category bound `m` while the bins from
    /// `st` on say so; `None` (and the error state) past 15 bits. Returns `m` and the bin
    /// after the last one read.
    fn widen(
        &mut self,
        src: &mut Source<'_>,
        bins: Bins,
        mut m: i32,
        mut st: usize,
    ) -> Option<(i32, usize)> {
        while self.bin(src, bins, st) {
            m <<= 1;
            if m == 0x8000 {
                self.overflow(src);
                return None;
            }
            st += 1;
        }
        Some((m, st))
    }

    /// Figure F.24: the bits of the magnitude below `m`, from bin `st`, plus one.
    fn magnitude(&mut self, src: &mut Source<'_>, bins: Bins, mut m: i32, st: usize) -> i32 {
        let mut v = m;
        while {
            m >>= 1;
            m != 0
        } {
            if self.bin(src, bins, st) {
                v |= m;
            }
        }
        v + 1
    }

    /// Marks the scan broken after damaged data (`ct = -1`) and warns.
    fn overflow(&mut self, src: &mut Source<'_>) {
        src.warnings
            .push(Warning::BadArithmeticCode { offset: src.pos() });
        self.coder.ct = -1;
    }

    /// Component `ci`'s next DC value: the previous one plus [`Self::dc_diff`], kept to
    /// 16 bits as libjpeg-turbo keeps it; `None` after a magnitude overflow.
    fn next_dc(&mut self, src: &mut Source<'_>, ci: usize) -> Option<i32> {
        let diff = self.dc_diff(src, ci)?;
        self.last_dc[ci] = (self.last_dc[ci] + diff) & 0xffff;
        Some(self.last_dc[ci])
    }

    /// A DC difference (F.1.4.4.1, Figures F.19-F.24) of scan component `ci`; `None` after
    /// a magnitude overflow.
    fn dc_diff(&mut self, src: &mut Source<'_>, ci: usize) -> Option<i32> {
        let tbl = self.scan.dc_tbl[ci] % TABLES;
        let bins = Bins::Dc(tbl);
        let mut st = self.dc_context[ci];
        if !self.bin(src, bins, st) {
            self.dc_context[ci] = 0;
            return Some(0);
        }
        let sign = usize::from(self.bin(src, bins, st + 1));
        st += 2 + sign;
        let mut m = i32::from(self.bin(src, bins, st));
        if m != 0 {
            (m, st) = self.widen(src, bins, m, 20)?;
        }
        let cond = &self.scan.conditioning;
        let (l, u) = (cond.dc_l[tbl], cond.dc_u[tbl]);
        self.dc_context[ci] = if m < ((1i64 << l) >> 1) as i32 {
            0
        } else if m > ((1i64 << u) >> 1) as i32 {
            12 + sign * 4
        } else {
            4 + sign * 4
        };
        let v = self.magnitude(src, bins, m, st + 14);
        Some(if sign != 0 { -v } else { v })
    }

    /// An AC coefficient's value after its "nonzero" decision at band position `k`
    /// (Figures F.21-F.24); `None` after a magnitude overflow.
    fn ac_value(
        &mut self,
        src: &mut Source<'_>,
        tbl: usize,
        k: usize,
        mut st: usize,
    ) -> Option<i32> {
        let bins = Bins::Ac(tbl);
        let sign = self.decode_fixed(src);
        st += 2;
        let mut m = i32::from(self.bin(src, bins, st));
        if m != 0 && self.bin(src, bins, st) {
            let first = if k <= usize::from(self.scan.conditioning.ac_k[tbl]) {
                189
            } else {
                217
            };
            (m, st) = self.widen(src, bins, 2, first)?;
        }
        let v = self.magnitude(src, bins, m, st + 14);
        Some(if sign { -v } else { v })
    }

    /// AC coefficients `first..=last` of one block (Figure F.20); `false` after an
    /// overflow. Each value goes through `store(k, v)`.
    fn ac_band(
        &mut self,
        src: &mut Source<'_>,
        tbl: usize,
        first: usize,
        last: usize,
        mut store: impl FnMut(usize, i32),
    ) -> bool {
        let mut k = first;
        while k <= last {
            let mut st = 3 * (k - 1);
            if self.bin(src, Bins::Ac(tbl), st) {
                break; // end of block
            }
            while !self.bin(src, Bins::Ac(tbl), st + 1) {
                st += 3;
                k += 1;
                if k > last {
                    self.overflow(src);
                    return false;
                }
            }
            let Some(v) = self.ac_value(src, tbl, k, st) else {
                return false;
            };
            store(k, v);
            k += 1;
        }
        true
    }

    /// `decode_mcu` (sequential): every block of the MCU, zeroed by the caller;
    /// `membership` gives each block's component in the scan.
    fn mcu_sequential(
        &mut self,
        src: &mut Source<'_>,
        membership: &[usize],
        blocks: &mut [[i16; 64]],
    ) {
        for (b, block) in blocks.iter_mut().enumerate() {
            let Some(&ci) = membership.get(b) else {
                return;
            };
            let Some(dc) = self.next_dc(src, ci) else {
                return;
            };
            block[0] = dc as u16 as i16;
            let tbl = self.scan.ac_tbl[ci] % TABLES;
            let ok = self.ac_band(src, tbl, 1, 63, |k, v| {
                block[NATURAL_ORDER[k]] = v as i16;
            });
            if !ok {
                return;
            }
        }
    }

    /// `decode_mcu_DC_first`.
    fn mcu_dc_first(
        &mut self,
        src: &mut Source<'_>,
        membership: &[usize],
        blocks: &mut [[i16; 64]],
    ) {
        let al = self.scan.al;
        for (b, block) in blocks.iter_mut().enumerate() {
            let Some(&ci) = membership.get(b) else {
                return;
            };
            let Some(dc) = self.next_dc(src, ci) else {
                return;
            };
            block[0] = (dc as u32).wrapping_shl(al) as i16;
        }
    }

    /// `decode_mcu_DC_refine`: the next bit of each block's DC value (decoded even after
    /// an error, as libjpeg does).
    fn mcu_dc_refine(&mut self, src: &mut Source<'_>, blocks: &mut [[i16; 64]]) {
        let p1 = 1i16 << self.scan.al;
        for block in blocks.iter_mut() {
            if self.decode_fixed(src) {
                block[0] |= p1;
            }
        }
    }

    /// `decode_mcu_AC_first`.
    fn mcu_ac_first(&mut self, src: &mut Source<'_>, blocks: &mut [[i16; 64]]) {
        let (ss, se, al) = (self.scan.ss, self.scan.se, self.scan.al);
        let Some(block) = blocks.first_mut() else {
            return;
        };
        let tbl = self.scan.ac_tbl[0] % TABLES;
        self.ac_band(src, tbl, ss, se, |k, v| {
            block[NATURAL_ORDER[k]] = (v as u32).wrapping_shl(al) as i16;
        });
    }

    /// `decode_mcu_AC_refine`.
    fn mcu_ac_refine(&mut self, src: &mut Source<'_>, blocks: &mut [[i16; 64]]) {
        let (ss, se, al) = (self.scan.ss, self.scan.se, self.scan.al);
        let Some(block) = blocks.first_mut() else {
            return;
        };
        let tbl = self.scan.ac_tbl[0] % TABLES;
        let p1 = 1i16 << al;
        let m1 = (-1i16).wrapping_shl(al);
        // The end of block of the previous stages.
        let kex = (1..=se)
            .rev()
            .find(|&k| block[NATURAL_ORDER[k]] != 0)
            .unwrap_or(0);
        let mut k = ss;
        while k <= se {
            let mut st = 3 * (k - 1);
            if k > kex && self.bin(src, Bins::Ac(tbl), st) {
                break; // end of block
            }
            loop {
                let coef = &mut block[NATURAL_ORDER[k]];
                if *coef != 0 {
                    if self.bin(src, Bins::Ac(tbl), st + 2) {
                        *coef = coef.wrapping_add(if *coef < 0 { m1 } else { p1 });
                    }
                    break;
                }
                if self.bin(src, Bins::Ac(tbl), st + 1) {
                    *coef = if self.decode_fixed(src) { m1 } else { p1 };
                    break;
                }
                st += 3;
                k += 1;
                if k > se {
                    self.overflow(src);
                    return;
                }
            }
            k += 1;
        }
    }
}

impl Decoder<'_> {
    /// One MCU of an arithmetic-coded scan (`st.arith`), restart marker first when one
    /// is due.
    pub(crate) fn decode_mcu_arith(&mut self, st: &mut ScanState, blocks: &mut [[i16; 64]]) {
        let Some(d) = st.arith.as_mut() else {
            return;
        };
        if self.restart_interval != 0 {
            if st.restarts_to_go == 0 {
                self.read_restart_marker();
                d.restart();
                st.restarts_to_go = self.restart_interval;
            }
            st.restarts_to_go = st.restarts_to_go.wrapping_sub(1);
        }
        let membership = &st.membership;
        let s = &d.scan;
        let (progressive, ss, ah) = (s.progressive, s.ss, s.ah);
        // The DC refinement decodes even in the error state; the others stop.
        if progressive && ss == 0 && ah != 0 {
            d.mcu_dc_refine(&mut self.src, blocks);
            return;
        }
        if d.coder.ct == -1 {
            return;
        }
        let src = &mut self.src;
        match (progressive, ss == 0, ah == 0) {
            (false, _, _) => d.mcu_sequential(src, membership, blocks),
            (true, true, _) => d.mcu_dc_first(src, membership, blocks),
            (true, false, true) => d.mcu_ac_first(src, blocks),
            (true, false, false) => d.mcu_ac_refine(src, blocks),
        }
    }
}
