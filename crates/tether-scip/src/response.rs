//! The sensor's replies: a parser that consumes bytes as they arrive and emits one
//! event per reply (manual C-42-03320B, section 7 and each command's section in 8).
//!
//! A reply is the command's echo and LF, a status line (2 status characters, their
//! check character, LF), the command's data lines, and an empty line: every reply ends
//! with LF LF. The parser cuts the byte stream at LF LF boundaries and checks each
//! reply on its own, so a damaged reply (wrong check character, truncated line,
//! garbage, unknown echo) costs that reply only: parsing re-synchronises at the next
//! LF LF. Nothing in here reads a clock or panics on any input.

use std::collections::VecDeque;

use thiserror::Error;

use crate::command::{Command, Request, ScanKind, ScanRequest, TimeMode, parse_request};
use crate::encoding::{DATA_LINE_CHARS, Encoding, checksum, decode, decode_values};

/// A reply longer than this without LF LF is taken as garbage and dropped (the longest
/// real reply, 1,081 steps with intensities, is about 13 KB).
pub const MAX_REPLY_BYTES: usize = 64 * 1024;

/// Longest echo line kept in a fault report.
const MAX_ECHO_IN_FAULT: usize = 40;

/// What a status means for the command it answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatusKind {
    /// `00`: command accepted.
    Ok,
    /// `99`: range data follows (`MD`/`MS` scans).
    Data,
    /// `01`..`0x` documented for this command: a parameter or state error (e.g. `02`
    /// for `BM`: laser already on; `10` for `GD`: laser off; `04` for `TM1`: not in
    /// adjust mode).
    Refused,
    /// `0E`: the sensor does not know the command (also what a SCIP 2.0 sensor answers
    /// to `SCIP2.0`).
    UnknownCommand,
    /// `21`..`49` for range commands: processing stopped to verify an error.
    Stopped,
    /// `50`..`97`: hardware trouble (laser, motor).
    Hardware,
    /// `98`: processing resumed after the laser was confirmed normal.
    Resumed,
    /// Anything the manual does not define for this command.
    Unknown,
}

/// A reply's status: two characters (a SCIP 1.1 reply to `SCIP2.0` has one, `0`, read
/// as `00`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status(pub [u8; 2]);

impl Status {
    /// `00`.
    pub const OK: Status = Status(*b"00");

    /// The status as text.
    pub fn as_str(&self) -> String {
        String::from_utf8_lossy(&self.0).into_owned()
    }

    /// What this status means as a reply to `command` (section 8 of the manual).
    pub fn kind(&self, command: &Command) -> StatusKind {
        let code = &self.0;
        if code == b"00" {
            return StatusKind::Ok;
        }
        if code == b"0E" {
            return StatusKind::UnknownCommand;
        }
        let n = (code[0].is_ascii_digit() && code[1].is_ascii_digit())
            .then(|| (code[0] - b'0') * 10 + (code[1] - b'0'));
        let Some(n) = n else {
            return StatusKind::Unknown;
        };
        match command {
            Command::Scan(r) => {
                let continuous = matches!(r.kind, ScanKind::Continuous { .. });
                match n {
                    99 if continuous => StatusKind::Data,
                    1..=5 => StatusKind::Refused,
                    6 | 7 if continuous => StatusKind::Refused,
                    10 if !continuous => StatusKind::Refused,
                    21..=49 => StatusKind::Stopped,
                    50..=97 => StatusKind::Hardware,
                    98 => StatusKind::Resumed,
                    _ => StatusKind::Unknown,
                }
            }
            Command::LaserOn if matches!(n, 1 | 2) => StatusKind::Refused,
            Command::Time(_) if (1..=4).contains(&n) => StatusKind::Refused,
            _ => StatusKind::Unknown,
        }
    }
}

/// Range data of one reply to `MD`/`MS`/`GD`/`GS`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScanReply {
    /// The request as echoed (for `MD`/`MS` the count is the scans still to come).
    pub request: ScanRequest,
    /// The echoed tag.
    pub tag: Option<String>,
    /// Sensor time of the scan, ms (24 bits, wraps every 4.66 h).
    pub timestamp_ms: u32,
    /// One value per step or cluster, mm; values below the sensor's `DMIN` (20 on the
    /// URG-04LX) are error codes, not distances.
    pub values_mm: Vec<u32>,
}

/// A reply that parsed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// A reply without data (`BM`, `QT`, `RS`, `TM0`, `TM2`, `SCIP2.0`, the `00`
    /// acknowledgement of `MD`/`MS`) or any reply whose status is not `00`/`99`.
    Status {
        /// The echoed request.
        request: Request,
        /// Its status.
        status: Status,
    },
    /// `VV`, `PP` or `II`: `KEY:value` lines in order.
    Fields {
        /// The echoed request.
        request: Request,
        /// The fields.
        fields: Vec<(String, String)>,
    },
    /// `TM1`: the sensor's clock.
    Time {
        /// The echoed tag.
        tag: Option<String>,
        /// Sensor time, ms (24 bits).
        sensor_ms: u32,
    },
    /// A scan.
    Scan(ScanReply),
}

/// Why a reply was dropped. Each names the line (0: echo, 1: status, 2...: data).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ReplyFault {
    /// A line's check character is wrong.
    #[error(
        "check character of line {line} of a {command} reply is {found:?}, expected {expected:?}"
    )]
    Checksum {
        /// Command symbol of the reply.
        command: &'static str,
        /// Line index within the reply.
        line: usize,
        /// Check character computed.
        expected: char,
        /// Check character received.
        found: char,
    },
    /// A line is too long, too short or holds characters outside the encoding.
    #[error("line {line} of a {command} reply is malformed: {problem}")]
    BadLine {
        /// Command symbol of the reply.
        command: &'static str,
        /// Line index within the reply.
        line: usize,
        /// What is wrong.
        problem: String,
    },
    /// The data block holds another number of values than the request asks for (a
    /// truncated or lost line).
    #[error("{command} reply carries {found} values, the request asks for {expected}")]
    ValueCount {
        /// Command symbol of the reply.
        command: &'static str,
        /// Values the echoed request implies.
        expected: usize,
        /// Values received.
        found: usize,
    },
    /// The first line is no echo of a SCIP 2.0 command (garbage, or a reply whose
    /// start was lost).
    #[error("reply starts with {echo:?}, which echoes no SCIP 2.0 command")]
    UnknownEcho {
        /// The first line (lossy, shortened).
        echo: String,
    },
    /// A reply has no status line.
    #[error("{command} reply has no status line")]
    NoStatus {
        /// Command symbol.
        command: &'static str,
    },
    /// More than [`MAX_REPLY_BYTES`] without LF LF: dropped up to the next LF LF.
    #[error("{bytes} bytes without the LF LF that ends a reply: dropped as garbage")]
    Oversized {
        /// Bytes dropped so far.
        bytes: usize,
    },
}

/// What the parser found: a reply or a dropped one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ParseEvent {
    /// A reply.
    Reply(Reply),
    /// A reply that was dropped.
    Fault(ReplyFault),
}

/// Consumes the sensor's bytes and emits [`ParseEvent`]s.
#[derive(Debug, Default)]
pub struct ReplyParser {
    /// The reply being collected (all its lines with their LFs).
    buf: Vec<u8>,
    /// Dropping bytes up to the next LF LF after an oversized reply.
    discarding: bool,
    /// The last byte seen was LF (so LF now ends a reply).
    after_lf: bool,
    events: VecDeque<ParseEvent>,
    scratch: Vec<u8>,
}

impl ReplyParser {
    /// A parser at a reply boundary.
    pub fn new() -> Self {
        Self::default()
    }

    /// Consumes bytes; complete replies become events (see [`ReplyParser::next_event`]).
    pub fn push(&mut self, bytes: &[u8]) {
        let mut rest = bytes;
        while !rest.is_empty() {
            let Some(lf) = rest.iter().position(|&b| b == b'\n') else {
                self.extend(rest);
                self.after_lf = false;
                return;
            };
            let (head, tail) = rest.split_at(lf);
            rest = &tail[1..];
            if head.is_empty() && self.after_lf {
                // LF LF: the reply is complete.
                self.finish_reply();
                continue;
            }
            if head.is_empty() && self.buf.is_empty() && !self.discarding {
                // A stray LF between replies: no reply starts with an empty line.
                continue;
            }
            self.extend(head);
            self.extend(b"\n");
            self.after_lf = true;
        }
    }

    fn extend(&mut self, bytes: &[u8]) {
        if self.discarding {
            return;
        }
        if self.buf.len() + bytes.len() > MAX_REPLY_BYTES {
            self.events
                .push_back(ParseEvent::Fault(ReplyFault::Oversized {
                    bytes: self.buf.len() + bytes.len(),
                }));
            self.buf.clear();
            self.discarding = true;
            return;
        }
        self.buf.extend_from_slice(bytes);
    }

    fn finish_reply(&mut self) {
        self.after_lf = false;
        if self.discarding {
            self.discarding = false;
            self.buf.clear();
            return;
        }
        if self.buf.is_empty() {
            return;
        }
        let buf = std::mem::take(&mut self.buf);
        let event = match self.parse(&buf) {
            Ok(reply) => ParseEvent::Reply(reply),
            Err(fault) => ParseEvent::Fault(fault),
        };
        self.buf = buf;
        self.buf.clear();
        self.events.push_back(event);
    }

    /// The next event, if a reply is complete.
    pub fn next_event(&mut self) -> Option<ParseEvent> {
        self.events.pop_front()
    }

    /// Whether part of a reply has been received and not yet ended.
    pub fn has_partial(&self) -> bool {
        !self.buf.is_empty() || self.discarding
    }

    /// Forgets any partial reply and pending events (after a timeout, before restarting
    /// the stream); returns whether a partial reply was dropped.
    pub fn reset(&mut self) -> bool {
        let had = self.has_partial();
        self.buf.clear();
        self.discarding = false;
        self.after_lf = false;
        self.events.clear();
        had
    }

    fn parse(&mut self, reply: &[u8]) -> Result<Reply, ReplyFault> {
        // The reply ends with LF; its lines are the pieces between LFs.
        let body = reply.strip_suffix(b"\n").unwrap_or(reply);
        let mut lines = body.split(|&b| b == b'\n');
        let echo = lines.next().unwrap_or_default();
        let request = parse_request(echo).map_err(|_| ReplyFault::UnknownEcho {
            echo: String::from_utf8_lossy(&echo[..echo.len().min(MAX_ECHO_IN_FAULT)]).into_owned(),
        })?;
        let symbol = request.command.symbol();
        let status_line = lines
            .next()
            .ok_or(ReplyFault::NoStatus { command: symbol })?;
        let status = match status_line {
            // A SCIP 1.1 sensor answers `SCIP2.0` with a bare `0`.
            [b'0'] if request.command == Command::Scip20 => Status::OK,
            [a, b, sum] => {
                check_line(symbol, 1, &[*a, *b], *sum)?;
                Status([*a, *b])
            }
            other => {
                return Err(ReplyFault::BadLine {
                    command: symbol,
                    line: 1,
                    problem: format!("status line has {} characters, expected 3", other.len()),
                });
            }
        };
        let kind = status.kind(&request.command);
        match (request.command, kind) {
            (Command::Version | Command::Parameters | Command::Info, StatusKind::Ok) => {
                let fields = parse_fields(symbol, lines)?;
                Ok(Reply::Fields { request, fields })
            }
            (Command::Time(TimeMode::Request), StatusKind::Ok) => {
                let sensor_ms = second_line_timestamp(symbol, lines.next(), "time line")?;
                Ok(Reply::Time {
                    tag: request.tag,
                    sensor_ms,
                })
            }
            (Command::Scan(scan), StatusKind::Data)
            | (
                Command::Scan(
                    scan @ ScanRequest {
                        kind: ScanKind::Single,
                        ..
                    },
                ),
                StatusKind::Ok,
            ) => {
                let reply = self.parse_scan(symbol, scan, request.tag, lines)?;
                Ok(Reply::Scan(reply))
            }
            _ => Ok(Reply::Status { request, status }),
        }
    }

    fn parse_scan<'a>(
        &mut self,
        symbol: &'static str,
        request: ScanRequest,
        tag: Option<String>,
        mut lines: impl Iterator<Item = &'a [u8]>,
    ) -> Result<ScanReply, ReplyFault> {
        let timestamp_ms = second_line_timestamp(symbol, lines.next(), "time stamp line")?;
        let block = &mut self.scratch;
        block.clear();
        for (i, line) in lines.enumerate() {
            let index = i + 3;
            let Some((&sum, data)) = line.split_last() else {
                return Err(ReplyFault::BadLine {
                    command: symbol,
                    line: index,
                    problem: "empty data line".into(),
                });
            };
            if data.len() > DATA_LINE_CHARS {
                return Err(ReplyFault::BadLine {
                    command: symbol,
                    line: index,
                    problem: format!(
                        "{} data characters, at most {DATA_LINE_CHARS} per line",
                        data.len()
                    ),
                });
            }
            check_line(symbol, index, data, sum)?;
            block.extend_from_slice(data);
        }
        let expected = request.value_count();
        let chars = request.encoding.chars();
        if block.len() != expected * chars {
            return Err(ReplyFault::ValueCount {
                command: symbol,
                expected,
                found: block.len() / chars,
            });
        }
        let mut values_mm = Vec::with_capacity(expected);
        decode_values(block, request.encoding, &mut values_mm).map_err(|at| {
            ReplyFault::BadLine {
                command: symbol,
                line: 3 + at / DATA_LINE_CHARS,
                problem: format!("character {} is outside the encoding", at % DATA_LINE_CHARS),
            }
        })?;
        Ok(ScanReply {
            request,
            tag,
            timestamp_ms,
            values_mm,
        })
    }
}

/// A 4-character time stamp line with its check character.
/// Line `index` of a reply: `data` must have the check character `sum`.
fn check_line(symbol: &'static str, index: usize, data: &[u8], sum: u8) -> Result<(), ReplyFault> {
    let expected = checksum(data);
    if expected == sum {
        Ok(())
    } else {
        Err(ReplyFault::Checksum {
            command: symbol,
            line: index,
            expected: char::from(expected),
            found: char::from(sum),
        })
    }
}

/// The time stamp on line 2 of a reply (`what` names the line when it is missing).
fn second_line_timestamp(
    symbol: &'static str,
    line: Option<&[u8]>,
    what: &str,
) -> Result<u32, ReplyFault> {
    let line = line.ok_or_else(|| ReplyFault::BadLine {
        command: symbol,
        line: 2,
        problem: format!("{what} missing"),
    })?;
    timestamp(symbol, 2, line)
}

fn timestamp(symbol: &'static str, index: usize, line: &[u8]) -> Result<u32, ReplyFault> {
    let [a, b, c, d, sum] = line else {
        return Err(ReplyFault::BadLine {
            command: symbol,
            line: index,
            problem: format!("time stamp line has {} characters, expected 5", line.len()),
        });
    };
    let chars = [*a, *b, *c, *d];
    check_line(symbol, index, &chars, *sum)?;
    decode(&chars).ok_or_else(|| ReplyFault::BadLine {
        command: symbol,
        line: index,
        problem: "time stamp outside the 4-character encoding".into(),
    })
}

/// `KEY:value;S` lines of `VV`/`PP`/`II`; the check character covers the bytes before
/// the `;` (checked against a URG-04LX's replies, e.g. `DMIN:20;4`).
fn parse_fields<'a>(
    symbol: &'static str,
    lines: impl Iterator<Item = &'a [u8]>,
) -> Result<Vec<(String, String)>, ReplyFault> {
    let mut fields = Vec::new();
    for (i, line) in lines.enumerate() {
        let index = i + 2;
        let bad = |problem: &str| ReplyFault::BadLine {
            command: symbol,
            line: index,
            problem: problem.into(),
        };
        let [text @ .., b';', sum] = line else {
            return Err(bad(
                "field line does not end with `;` and a check character",
            ));
        };
        check_line(symbol, index, text, *sum)?;
        let colon = text
            .iter()
            .position(|&b| b == b':')
            .ok_or_else(|| bad("field line has no `:`"))?;
        fields.push((
            String::from_utf8_lossy(&text[..colon]).into_owned(),
            String::from_utf8_lossy(&text[colon + 1..]).into_owned(),
        ));
    }
    Ok(fields)
}

/// Appends a reply's echo and status lines (what every reply starts with).
pub fn write_head(echo: &[u8], status: [u8; 2], out: &mut Vec<u8>) {
    out.extend_from_slice(echo);
    out.push(b'\n');
    out.extend_from_slice(&status);
    out.push(checksum(&status));
    out.push(b'\n');
}

/// Appends a 4-character time stamp line.
pub fn write_timestamp(sensor_ms: u32, out: &mut Vec<u8>) {
    let start = out.len();
    crate::encoding::encode(sensor_ms & Encoding::Four.max_value(), Encoding::Four, out);
    let sum = checksum(&out[start..]);
    out.push(sum);
    out.push(b'\n');
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::encoding::{encode, write_block};

    fn parse_all(bytes: &[u8]) -> Vec<ParseEvent> {
        let mut p = ReplyParser::new();
        p.push(bytes);
        std::iter::from_fn(|| p.next_event()).collect()
    }

    /// An MD reply of a URG-04LX's full scan (steps 44..=725) with the given values.
    fn md_reply(values: &[u32], stamp_ms: u32) -> Vec<u8> {
        let mut out = Vec::new();
        write_head(b"MD0044072501000", *b"99", &mut out);
        write_timestamp(stamp_ms, &mut out);
        let mut block = Vec::new();
        for &v in values {
            encode(v, Encoding::Three, &mut block);
        }
        write_block(&block, &mut out);
        out.push(b'\n');
        out
    }

    #[test]
    fn parses_a_urg_04lx_parameter_reply() {
        // PP reply of a URG-04LX (firmware 3.1.04), byte for byte.
        let pp = b"PP\n00P\nMODL:URG-04LX(Hokuyo Automatic Co.,Ltd.);N\nDMIN:20;4\n\
                   DMAX:5600;_\nARES:1024;\\\nAMIN:44;7\nAMAX:725;o\nAFRT:384;6\nSCAN:600;e\n\n";
        let events = parse_all(pp);
        let [ParseEvent::Reply(Reply::Fields { fields, .. })] = events.as_slice() else {
            panic!("{events:?}");
        };
        assert_eq!(fields.len(), 8);
        assert_eq!(fields[1], ("DMIN".into(), "20".into()));
        assert_eq!(fields[5], ("AMAX".into(), "725".into()));
    }

    #[test]
    fn parses_scans_split_anywhere() {
        let values: Vec<u32> = (0..682).map(|i| (i * 37 % 5600) as u32).collect();
        let reply = md_reply(&values, 0x00AB_CDEF);
        // Feed it in every split position of two pieces.
        for cut in [0, 1, 17, 100, reply.len() - 2, reply.len() - 1] {
            let mut p = ReplyParser::new();
            p.push(&reply[..cut]);
            assert!(p.next_event().is_none());
            p.push(&reply[cut..]);
            let Some(ParseEvent::Reply(Reply::Scan(scan))) = p.next_event() else {
                panic!("cut {cut}");
            };
            assert_eq!(scan.values_mm, values);
            assert_eq!(scan.timestamp_ms, 0x00AB_CDEF);
            assert!(!p.has_partial());
        }
    }

    #[test]
    fn drops_damaged_replies_and_resyncs() {
        let values = vec![1000u32; 682];
        let good = md_reply(&values, 5);
        let mut bad_sum = good.clone();
        // The check character of the first data line (after echo 16, status 4, stamp 6).
        let at = 16 + 4 + 6 + 64;
        bad_sum[at] = if bad_sum[at] == b'0' { b'1' } else { b'0' };
        let mut truncated = good.clone();
        truncated.drain(30..36);
        let mut stream = b"\x00\xffgarbage".to_vec();
        stream.extend_from_slice(&good);
        stream.extend_from_slice(&bad_sum);
        stream.extend_from_slice(&truncated);
        stream.extend_from_slice(&good);
        let events = parse_all(&stream);
        assert_eq!(events.len(), 4, "{events:?}");
        assert!(matches!(
            &events[0],
            ParseEvent::Fault(ReplyFault::UnknownEcho { .. })
        ));
        assert!(matches!(
            &events[1],
            ParseEvent::Fault(ReplyFault::Checksum { line: 3, .. })
        ));
        assert!(matches!(&events[2], ParseEvent::Fault(_)));
        assert!(matches!(&events[3], ParseEvent::Reply(Reply::Scan(_))));
    }

    #[test]
    fn classifies_statuses() {
        let mut bytes = Vec::new();
        write_head(b"BM", *b"02", &mut bytes);
        bytes.push(b'\n');
        write_head(b"MD0044072501000", *b"7Z", &mut bytes);
        bytes.push(b'\n');
        bytes.extend_from_slice(b"SCIP2.0\n0\n\n");
        assert!(bytes.starts_with(b"BM\n02R\n\n"));
        let events = parse_all(&bytes);
        let kinds: Vec<StatusKind> = events
            .iter()
            .map(|e| match e {
                ParseEvent::Reply(Reply::Status { request, status }) => {
                    status.kind(&request.command)
                }
                other => panic!("{other:?}"),
            })
            .collect();
        assert_eq!(
            kinds,
            [StatusKind::Refused, StatusKind::Unknown, StatusKind::Ok]
        );
    }

    #[test]
    fn stray_line_feeds_between_replies_are_ignored() {
        // Found by the fuzzer: a lone LF at a boundary used to start the next reply
        // with an empty line, and so lose it.
        let events = parse_all(b"\n\n\nQT\n00P\n\n\nBM\n00P\n\n");
        assert_eq!(events.len(), 2, "{events:?}");
        assert!(
            events
                .iter()
                .all(|e| matches!(e, ParseEvent::Reply(Reply::Status { .. })))
        );
    }

    #[test]
    fn drops_oversized_garbage() {
        let mut p = ReplyParser::new();
        p.push(&vec![b'x'; MAX_REPLY_BYTES + 10]);
        assert!(matches!(
            p.next_event(),
            Some(ParseEvent::Fault(ReplyFault::Oversized { .. }))
        ));
        p.push(b"more\n\nQT\n00P\n\n");
        assert!(matches!(
            p.next_event(),
            Some(ParseEvent::Reply(Reply::Status { .. }))
        ));
    }

    /// The parser's events for `bytes` fed in the pieces that `cuts` (sorted positions)
    /// make.
    fn parse_in_pieces(bytes: &[u8], cuts: &[usize]) -> Vec<ParseEvent> {
        let mut p = ReplyParser::new();
        let mut events = Vec::new();
        let mut from = 0;
        for &cut in cuts.iter().chain(std::iter::once(&bytes.len())) {
            let cut = cut.clamp(from, bytes.len());
            p.push(&bytes[from..cut]);
            events.extend(std::iter::from_fn(|| p.next_event()));
            from = cut;
        }
        events
    }

    /// Bytes that look like SCIP: its characters, line feeds, echoes, the
    /// encodings' alphabet.
    fn scip_like() -> impl Strategy<Value = Vec<u8>> {
        let pieces = prop_oneof![
            Just(b"\n".to_vec()),
            Just(b"\n\n".to_vec()),
            Just(b"MD0044072501000\n".to_vec()),
            Just(b"GS0044072501\n".to_vec()),
            Just(b"PP\n00P\n".to_vec()),
            Just(b"TM1\n00P\n".to_vec()),
            Just(b"99b\n".to_vec()),
            proptest::collection::vec(0x30u8..0x70, 1..80),
            proptest::collection::vec(any::<u8>(), 1..8),
        ];
        proptest::collection::vec(pieces, 0..60).prop_map(|v| v.concat())
    }

    use proptest::prelude::*;

    /// Parsing `bytes` cut at `cuts` gives what parsing them whole gives.
    fn splits_do_not_matter(bytes: &[u8], mut cuts: Vec<usize>) -> Result<(), TestCaseError> {
        cuts.sort_unstable();
        let whole = parse_all(bytes);
        prop_assert_eq!(parse_in_pieces(bytes, &cuts), whole);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        /// Random bytes never panic the parser, and how they are split into reads
        /// changes nothing.
        #[test]
        fn random_bytes_never_panic_and_splits_do_not_matter(
            bytes in proptest::collection::vec(any::<u8>(), 0..3000),
            cuts in proptest::collection::vec(0usize..3000, 0..6),
        ) {
            splits_do_not_matter(&bytes, cuts)?;
        }

        #[test]
        fn scip_like_bytes_never_panic_and_splits_do_not_matter(
            bytes in scip_like(),
            cuts in proptest::collection::vec(0usize..5000, 0..6),
        ) {
            splits_do_not_matter(&bytes, cuts)?;
        }

        /// A damaged scan is dropped or decoded, never a panic; the good scan after it
        /// always comes through (the parser re-synchronises at LF LF).
        #[test]
        fn a_good_scan_survives_a_damaged_one(
            edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..3), 1..8),
        ) {
            let values: Vec<u32> = (0..682).map(|i| (i * 13 % 4000) as u32 + 20).collect();
            let good = md_reply(&values, 77);
            let mut bad = good.clone();
            tether_testkit::damage(&mut bad, edits);
            // However the damage ends, a reply boundary follows before the good scan.
            bad.extend_from_slice(b"\n\n");
            bad.extend_from_slice(&good);
            let events = parse_all(&bad);
            let last = events.last();
            prop_assert!(
                matches!(last, Some(ParseEvent::Reply(Reply::Scan(scan))) if scan.values_mm == values),
                "{:?}", last
            );
        }
    }
}
