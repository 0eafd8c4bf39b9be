//! Hokuyo SCIP 2.0: the protocol of the URG-04LX and its siblings (UBG-04LX, UTM-30LX,
//! and over TCP port 10940 the Ethernet models), after the manual "Communication
//! Protocol Specification For SCIP2.0", Hokuyo drawing C-42-03320B.
//!
//! The protocol is transport-agnostic and nothing in it reads a clock:
//!
//! - [`encoding`]: 2-, 3- and 4-character encodings and the check character
//!   `(sum & 0x3F) + 0x30` (sections 6 and 7);
//! - [`command`]: commands (`SCIP2.0`, `VV`, `PP`, `II`, `BM`, `QT`, `RS`, `TM`,
//!   `MD`/`MS`, `GD`/`GS`) encoded for the sensor and parsed back (section 8);
//! - [`response`]: a parser that consumes bytes as they come and emits one event per
//!   reply, dropping damaged replies and re-synchronising at the next LF LF;
//! - [`time`]: the sensor's 24-bit millisecond clock mapped to host time from `TM`
//!   round trips, tracking drift from scan arrivals.
//!
//! On top: [`UrgDriver`], the driver on a serial / USB-ACM port ([`open_serial`], the
//! `serialport` crate without libudev) or TCP ([`connect_tcp`]), producing
//! [`tether_core::LaserScan`]s (angles from `PP`'s `AMIN`, `AFRT`, `ARES`: 682 beams
//! from -2.0862 rad on a URG-04LX; error codes below `DMIN` = 20 mm become "no
//! return"); and [`emulator`], a URG that speaks the protocol byte for byte, with fault
//! injection, over a pseudo-terminal or TCP.

pub mod command;
mod driver;
pub mod emulator;
pub mod encoding;
mod link;
pub mod response;
pub mod time;

pub use command::{Command, Request, ScanKind, ScanRequest, TimeMode};
pub use driver::{
    Clock, DriverConfig, DriverEvent, DriverStats, Fault, ScipError, SensorInfo, SystemClock,
    UrgDriver, UrgScan, laser_scan,
};
pub use encoding::Encoding;
pub use link::{DEFAULT_BAUD_RATE, DEFAULT_TCP_PORT, Link, connect_tcp, open_serial};
pub use response::{ParseEvent, Reply, ReplyFault, ReplyParser, ScanReply, Status, StatusKind};
