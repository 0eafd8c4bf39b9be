//! SCIP 2.0 commands: encoding them for the sensor and parsing them back (the sensor's
//! echo, the emulator's input). Manual C-42-03320B, sections 7 and 8.
//!
//! A command is a 2-letter symbol, fixed-width decimal parameters, optionally `;` and
//! up to 16 "string characters" (letters, digits, space, `.`, `_`, `+`, `@`) that the
//! sensor echoes so that a host can tell replies apart, and LF (CR or CR LF are also
//! accepted by the sensor). Every reply starts with this echo.

use thiserror::Error;

use crate::encoding::Encoding;

/// Longest string-characters tag (section 7).
pub const MAX_TAG_CHARS: usize = 16;

/// Which part of a `TM` exchange (section 8.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeMode {
    /// `TM0`: enter adjust mode (laser off, other commands refused).
    Start,
    /// `TM1`: read the sensor's clock (ms, 24 bits).
    Request,
    /// `TM2`: leave adjust mode.
    End,
}

/// How many scans an `MD`/`MS`/`GD`/`GS` asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanKind {
    /// `GD`/`GS`: the latest scan, once (laser must be on).
    Single,
    /// `MD`/`MS`: a stream of scans (section 8.1).
    Continuous {
        /// Scans skipped between two sent (`0..=9`).
        interval: u8,
        /// Scans to send, `0` for an endless stream (`0..=99`). In the sensor's echoes
        /// this is the number of scans still to come.
        count: u8,
    },
}

/// A request for range data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanRequest {
    /// `Two` (`MS`/`GS`) or `Three` (`MD`/`GD`) characters per value.
    pub encoding: Encoding,
    /// First step (`0..=9999`).
    pub start_step: u16,
    /// Last step, inclusive (`start_step..=9999`).
    pub end_step: u16,
    /// Neighbouring steps merged into one value (`0..=99`; 0 and 1 both mean none).
    pub cluster: u8,
    /// Single or continuous.
    pub kind: ScanKind,
}

impl ScanRequest {
    /// Steps merged into one value (at least 1).
    pub fn cluster_steps(&self) -> u16 {
        u16::from(self.cluster.max(1))
    }

    /// Number of values a reply carries: `ceil((end - start + 1) / cluster)`.
    pub fn value_count(&self) -> usize {
        let steps = self.end_step.saturating_sub(self.start_step) as usize + 1;
        steps.div_ceil(self.cluster_steps() as usize)
    }
}

/// A SCIP 2.0 command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// `SCIP2.0`: switch a SCIP 1.1 sensor (older URG-04LX firmware) to SCIP 2.0.
    Scip20,
    /// `VV`: vendor, product, firmware, protocol, serial number.
    Version,
    /// `PP`: model, range limits (`DMIN`, `DMAX`), steps (`ARES`, `AMIN`, `AMAX`,
    /// `AFRT`), motor speed (`SCAN`).
    Parameters,
    /// `II`: state (laser, speed, measurement mode, baud rate, time, status).
    Info,
    /// `BM`: laser on.
    LaserOn,
    /// `QT`: stop the stream, laser off.
    Quit,
    /// `RS`: reset to the power-on state.
    Reset,
    /// `TM0`/`TM1`/`TM2`: time adjustment.
    Time(TimeMode),
    /// `MD`/`MS`/`GD`/`GS`: range data.
    Scan(ScanRequest),
}

impl Command {
    /// The command symbol (`MD`, `VV`, `SCIP2.0`, ...).
    pub fn symbol(&self) -> &'static str {
        match self {
            Command::Scip20 => "SCIP2.0",
            Command::Version => "VV",
            Command::Parameters => "PP",
            Command::Info => "II",
            Command::LaserOn => "BM",
            Command::Quit => "QT",
            Command::Reset => "RS",
            Command::Time(_) => "TM",
            Command::Scan(r) => match (r.kind, r.encoding) {
                (ScanKind::Continuous { .. }, Encoding::Two) => "MS",
                (ScanKind::Continuous { .. }, _) => "MD",
                (ScanKind::Single, Encoding::Two) => "GS",
                (ScanKind::Single, _) => "GD",
            },
        }
    }
}

/// A command with its optional string-characters tag.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Request {
    /// The command.
    pub command: Command,
    /// String characters echoed by the sensor (`None`: no `;`).
    pub tag: Option<String>,
}

/// Why a command cannot be sent.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CommandError {
    /// A parameter is out of its range.
    #[error("SCIP parameter `{field}` = {value} is out of range {range}")]
    OutOfRange {
        /// Parameter name.
        field: &'static str,
        /// Value given.
        value: u32,
        /// Allowed range.
        range: &'static str,
    },
    /// The tag is too long or has characters the protocol does not allow.
    #[error("SCIP tag {0:?} is invalid: at most 16 letters, digits, spaces and `._+@` (section 7)")]
    BadTag(String),
    /// A scan request with 4-character encoding (only time stamps use it).
    #[error("range data is encoded with 2 (MS/GS) or 3 (MD/GD) characters, not 4")]
    FourCharScan,
}

fn valid_tag(tag: &str) -> bool {
    tag.len() <= MAX_TAG_CHARS
        && tag
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || matches!(b, b' ' | b'.' | b'_' | b'+' | b'@'))
}

fn check(
    field: &'static str,
    value: u32,
    max: u32,
    range: &'static str,
) -> Result<(), CommandError> {
    if value > max {
        Err(CommandError::OutOfRange {
            field,
            value,
            range,
        })
    } else {
        Ok(())
    }
}

impl Request {
    /// A command without tag.
    pub fn new(command: Command) -> Self {
        Request { command, tag: None }
    }

    /// The bytes to send, LF included.
    pub fn encode(&self) -> Result<Vec<u8>, CommandError> {
        let mut out = self.command.symbol().as_bytes().to_vec();
        match self.command {
            Command::Time(mode) => out.push(match mode {
                TimeMode::Start => b'0',
                TimeMode::Request => b'1',
                TimeMode::End => b'2',
            }),
            Command::Scan(r) => {
                if r.encoding == Encoding::Four {
                    return Err(CommandError::FourCharScan);
                }
                check("start_step", r.start_step.into(), 9999, "0..=9999")?;
                check("end_step", r.end_step.into(), 9999, "0..=9999")?;
                if r.end_step < r.start_step {
                    return Err(CommandError::OutOfRange {
                        field: "end_step",
                        value: r.end_step.into(),
                        range: "start_step..=9999",
                    });
                }
                check("cluster", r.cluster.into(), 99, "0..=99")?;
                out.extend(format!("{:04}{:04}{:02}", r.start_step, r.end_step, r.cluster).bytes());
                if let ScanKind::Continuous { interval, count } = r.kind {
                    check("interval", interval.into(), 9, "0..=9")?;
                    check("count", count.into(), 99, "0..=99")?;
                    out.extend(format!("{interval:01}{count:02}").bytes());
                }
            }
            _ => {}
        }
        if let Some(tag) = &self.tag {
            if !valid_tag(tag) {
                return Err(CommandError::BadTag(tag.clone()));
            }
            out.push(b';');
            out.extend_from_slice(tag.as_bytes());
        }
        out.push(b'\n');
        Ok(out)
    }
}

/// Why a command line cannot be understood; each maps to the status a sensor answers
/// (section 8.1 for range requests, 8.6 for `TM`, section 9 for unknown symbols).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum ParseRequestError {
    /// Not a SCIP 2.0 command symbol (status `0E`).
    #[error("unknown command")]
    Unknown,
    /// The tag after `;` is too long or has characters outside the allowed set.
    #[error("invalid string characters")]
    BadTag,
    /// A parameter of a range request is wrong: the status code `01`..`07`.
    #[error("invalid parameter (status {0:02})")]
    Parameter(u8),
    /// `TM` with a control code other than 0, 1, 2 (status `01`).
    #[error("invalid TM control code")]
    TimeControl,
}

impl ParseRequestError {
    /// The two status characters a sensor replies with.
    pub fn status(self) -> [u8; 2] {
        match self {
            ParseRequestError::Unknown | ParseRequestError::BadTag => *b"0E",
            ParseRequestError::Parameter(n) => [b'0' + n / 10, b'0' + n % 10],
            ParseRequestError::TimeControl => *b"01",
        }
    }
}

fn number(digits: &[u8]) -> Option<u16> {
    if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
        return None;
    }
    Some(
        digits
            .iter()
            .fold(0u16, |acc, d| acc * 10 + u16::from(d - b'0')),
    )
}

/// Parses a command line (without its LF / CR). Used on the sensor's echoes, so it
/// accepts what the sensor sends back: for `MD`/`MS` the count field holds the scans
/// remaining.
pub fn parse_request(line: &[u8]) -> Result<Request, ParseRequestError> {
    let (body, tag) = match line.iter().position(|&b| b == b';') {
        Some(i) => {
            let tag = std::str::from_utf8(&line[i + 1..]).map_err(|_| ParseRequestError::BadTag)?;
            if !valid_tag(tag) {
                return Err(ParseRequestError::BadTag);
            }
            (&line[..i], Some(tag.to_owned()))
        }
        None => (line, None),
    };
    let command = if body == b"SCIP2.0" {
        Command::Scip20
    } else {
        let (symbol, params) = body.split_at(body.len().min(2));
        let simple = |c: Command| {
            if params.is_empty() {
                Ok(c)
            } else {
                Err(ParseRequestError::Unknown)
            }
        };
        match symbol {
            b"VV" => simple(Command::Version)?,
            b"PP" => simple(Command::Parameters)?,
            b"II" => simple(Command::Info)?,
            b"BM" => simple(Command::LaserOn)?,
            b"QT" => simple(Command::Quit)?,
            b"RS" => simple(Command::Reset)?,
            b"TM" => Command::Time(match params {
                b"0" => TimeMode::Start,
                b"1" => TimeMode::Request,
                b"2" => TimeMode::End,
                _ => return Err(ParseRequestError::TimeControl),
            }),
            b"MD" | b"MS" | b"GD" | b"GS" => Command::Scan(parse_scan(symbol, params)?),
            _ => return Err(ParseRequestError::Unknown),
        }
    };
    Ok(Request { command, tag })
}

fn parse_scan(symbol: &[u8], p: &[u8]) -> Result<ScanRequest, ParseRequestError> {
    let field = |range: std::ops::Range<usize>, status: u8| {
        p.get(range)
            .and_then(number)
            .ok_or(ParseRequestError::Parameter(status))
    };
    let continuous = symbol[0] == b'M';
    let expected_len = if continuous { 13 } else { 10 };
    let start_step = field(0..4, 1)?;
    let end_step = field(4..8, 2)?;
    let cluster = field(8..10, 3)? as u8;
    let kind = if continuous {
        let interval = field(10..11, 6)? as u8;
        let count = field(11..13, 7)? as u8;
        ScanKind::Continuous { interval, count }
    } else {
        ScanKind::Single
    };
    if p.len() != expected_len {
        // Extra characters after the last parameter: the last field is not numeric.
        return Err(ParseRequestError::Parameter(if continuous { 7 } else { 3 }));
    }
    if end_step < start_step {
        return Err(ParseRequestError::Parameter(5));
    }
    Ok(ScanRequest {
        encoding: if symbol[1] == b'S' {
            Encoding::Two
        } else {
            Encoding::Three
        },
        start_step,
        end_step,
        cluster,
        kind,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn md(start: u16, end: u16, cluster: u8, interval: u8, count: u8) -> Request {
        Request::new(Command::Scan(ScanRequest {
            encoding: Encoding::Three,
            start_step: start,
            end_step: end,
            cluster,
            kind: ScanKind::Continuous { interval, count },
        }))
    }

    #[test]
    fn encodes_like_the_manual() {
        assert_eq!(md(44, 725, 1, 0, 0).encode().unwrap(), b"MD0044072501000\n");
        let gd = Request::new(Command::Scan(ScanRequest {
            encoding: Encoding::Two,
            start_step: 10,
            end_step: 750,
            cluster: 3,
            kind: ScanKind::Single,
        }));
        assert_eq!(gd.encode().unwrap(), b"GS0010075003\n");
        let mut tm = Request::new(Command::Time(TimeMode::Request));
        tm.tag = Some("sync 1".into());
        assert_eq!(tm.encode().unwrap(), b"TM1;sync 1\n");
        assert_eq!(
            Request::new(Command::Scip20).encode().unwrap(),
            b"SCIP2.0\n"
        );
    }

    #[test]
    fn parses_what_it_encodes() {
        for req in [
            md(0, 768, 3, 9, 99),
            Request::new(Command::Version),
            Request::new(Command::Time(TimeMode::End)),
            Request {
                command: Command::Quit,
                tag: Some("a.b_c+d@e".into()),
            },
        ] {
            let line = req.encode().unwrap();
            assert_eq!(parse_request(&line[..line.len() - 1]), Ok(req));
        }
    }

    #[test]
    fn refuses_bad_commands_with_their_status() {
        assert_eq!(parse_request(b"XX"), Err(ParseRequestError::Unknown));
        assert_eq!(parse_request(b"BMX"), Err(ParseRequestError::Unknown));
        assert_eq!(parse_request(b"TM3").unwrap_err().status(), *b"01");
        assert_eq!(
            parse_request(b"MD00x4072501000").unwrap_err().status(),
            *b"01"
        );
        assert_eq!(
            parse_request(b"MD00440725010").unwrap_err().status(),
            *b"07"
        );
        assert_eq!(
            parse_request(b"MD0725004401 000").unwrap_err().status(),
            *b"06"
        );
        assert_eq!(
            parse_request(b"MD0725004401000").unwrap_err().status(),
            *b"05"
        );
        assert_eq!(
            parse_request(b"QT;tag!").unwrap_err(),
            ParseRequestError::BadTag
        );
        assert!(matches!(
            md(44, 725, 1, 10, 0).encode(),
            Err(CommandError::OutOfRange {
                field: "interval",
                ..
            })
        ));
        let mut long = Request::new(Command::Quit);
        long.tag = Some("x".repeat(17));
        assert!(long.encode().is_err());
    }

    #[test]
    fn counts_values() {
        let r = ScanRequest {
            encoding: Encoding::Three,
            start_step: 44,
            end_step: 725,
            cluster: 1,
            kind: ScanKind::Single,
        };
        assert_eq!(r.value_count(), 682);
        assert_eq!(ScanRequest { cluster: 3, ..r }.value_count(), 228);
        assert_eq!(ScanRequest { cluster: 0, ..r }.value_count(), 682);
    }

    /// Checks what the emulator relies on for a host line: no panic; an accepted
    /// command that encodes parses back to itself; a refusal maps to a two-digit status.
    fn parse_checked(line: &[u8]) -> Result<(), TestCaseError> {
        match parse_request(line) {
            Ok(request) => {
                if let Ok(encoded) = request.encode() {
                    prop_assert_eq!(encoded.last(), Some(&b'\n'));
                    let again = parse_request(&encoded[..encoded.len() - 1]);
                    prop_assert_eq!(again, Ok(request));
                }
            }
            Err(e) => {
                let status = e.status();
                prop_assert!(status.iter().all(u8::is_ascii_alphanumeric), "{:?}", status);
            }
        }
        Ok(())
    }

    /// Lines that look like host commands: symbols, digits, `;` and tags, and a few
    /// random bytes.
    fn scip_like_line() -> impl Strategy<Value = Vec<u8>> {
        let piece = prop_oneof![
            prop::sample::select(vec![
                "MD", "MS", "GD", "GS", "VV", "PP", "II", "BM", "QT", "RS", "TM", "SCIP2.0",
                "SCIP", ";", ";tag", "0044", "0725", "01", "000", "9999", "0", "1", "2", "99",
            ])
            .prop_map(|s| s.as_bytes().to_vec()),
            proptest::collection::vec(b'0'..=b'9', 1..14),
            proptest::collection::vec(any::<u8>(), 1..4),
        ];
        proptest::collection::vec(piece, 0..8).prop_map(|v| v.concat())
    }

    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        /// Random bytes never panic the parser.
        #[test]
        fn random_lines_never_panic(line in proptest::collection::vec(any::<u8>(), 0..64)) {
            parse_checked(&line)?;
        }

        /// Command-like lines never panic it, and what it accepts round-trips.
        #[test]
        fn scip_like_lines_never_panic_and_round_trip(line in scip_like_line()) {
            parse_checked(&line)?;
        }

        /// Every valid range request with a tag parses to itself.
        #[test]
        fn valid_scan_requests_round_trip(
            start in 0u16..=9999,
            len in 0u16..=9999,
            cluster in 0u8..=99,
            continuous in proptest::option::of((0u8..=9, 0u8..=99)),
            two in any::<bool>(),
            tag in proptest::option::of("[A-Za-z0-9 ._+@]{0,16}"),
        ) {
            let request = Request {
                command: Command::Scan(ScanRequest {
                    encoding: if two { Encoding::Two } else { Encoding::Three },
                    start_step: start,
                    end_step: start.saturating_add(len).min(9999),
                    cluster,
                    kind: match continuous {
                        Some((interval, count)) => ScanKind::Continuous { interval, count },
                        None => ScanKind::Single,
                    },
                }),
                tag,
            };
            let line = request.encode().unwrap();
            prop_assert_eq!(parse_request(&line[..line.len() - 1]), Ok(request));
        }
    }
}
