//! Byte links to a sensor: serial / USB-ACM ports and TCP (Ethernet models).

use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

use crate::driver::ScipError;

/// The TCP port of Hokuyo's Ethernet models (UST, UTM-30LX-EW, ...).
pub const DEFAULT_TCP_PORT: u16 = 10940;

/// Baud rate of a URG-04LX on RS-232 at power-on (over USB-ACM any value works).
pub const DEFAULT_BAUD_RATE: u32 = 19_200;

/// A two-way byte link whose reads give up after a timeout.
///
/// A read that times out returns an error of kind `TimedOut` or `WouldBlock`; the
/// driver treats both as "nothing yet".
pub trait Link: Read + Write {
    /// How long one `read` waits for data.
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}

impl Link for TcpStream {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        TcpStream::set_read_timeout(self, Some(timeout.max(Duration::from_millis(1))))
    }
}

impl Link for Box<dyn serialport::SerialPort> {
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.set_timeout(timeout).map_err(io::Error::from)
    }
}

/// Opens a serial or USB-ACM device (e.g. `/dev/ttyACM0`, or a pseudo-terminal of the
/// emulator) at `baud_rate`, 8 data bits, no parity, 1 stop bit, no flow control, as
/// section 4 of the manual specifies.
pub fn open_serial(
    path: &str,
    baud_rate: u32,
) -> Result<Box<dyn serialport::SerialPort>, ScipError> {
    serialport::new(path, baud_rate)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(Duration::from_millis(20))
        .open()
        .map_err(|source| ScipError::Open {
            device: path.to_owned(),
            source: io::Error::from(source),
        })
}

/// Connects to an Ethernet sensor. `address` is `host:port` or just `host` (port
/// 10940 then).
pub fn connect_tcp(address: &str, timeout: Duration) -> Result<TcpStream, ScipError> {
    let with_port = if address.contains(':') {
        address.to_owned()
    } else {
        format!("{address}:{DEFAULT_TCP_PORT}")
    };
    let open_error = |source| ScipError::Open {
        device: with_port.clone(),
        source,
    };
    let addrs = with_port.to_socket_addrs().map_err(open_error)?;
    let mut last = io::Error::new(io::ErrorKind::NotFound, "the address resolves to nothing");
    for addr in addrs {
        match TcpStream::connect_timeout(&addr, timeout) {
            Ok(stream) => {
                stream.set_nodelay(true).map_err(open_error)?;
                return Ok(stream);
            }
            Err(e) => last = e,
        }
    }
    Err(open_error(last))
}
