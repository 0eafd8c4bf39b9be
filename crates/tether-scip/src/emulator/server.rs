//! Running an [`Emulator`] over a pseudo-terminal or TCP, on its own thread.
//!
//! The thread reads the host's bytes with a 10 ms timeout, gives them to the emulator
//! with the time since the server started, and writes what it answers. It is the only
//! place that reads a clock. A write that cannot go out (nobody reads the terminal)
//! stops the stream, as a URG does when its host goes away.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::{Emulator, ScanSource};

/// Granularity of the server loop.
const TICK: Duration = Duration::from_millis(10);

/// Where the host reaches the emulator.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// Path of the terminal to open, like `/dev/pts/3`.
    Pty(String),
    /// TCP address to connect to.
    Tcp(SocketAddr),
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Endpoint::Pty(path) => f.write_str(path),
            Endpoint::Tcp(addr) => write!(f, "{addr}"),
        }
    }
}

/// An emulator serving on a thread; stopped when dropped.
pub struct EmulatorServer<S: ScanSource + 'static> {
    endpoint: Endpoint,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<Emulator<S>>>>,
}

/// How a serving session ended.
enum SessionEnd {
    Stopped,
    Disconnected,
}

fn is_timeout(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

fn serve<S: ScanSource, P: Read + Write>(
    emu: &mut Emulator<S>,
    port: &mut P,
    started: Instant,
    stop: &AtomicBool,
) -> io::Result<SessionEnd> {
    let mut buf = [0u8; 1024];
    let mut out = Vec::new();
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok(SessionEnd::Stopped);
        }
        match port.read(&mut buf) {
            Ok(0) => return Ok(SessionEnd::Disconnected),
            Ok(n) => {
                let now_ms = started.elapsed().as_millis() as u64;
                emu.receive(&buf[..n], now_ms, &mut out);
            }
            Err(e) if is_timeout(&e) => {}
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::ConnectionReset | io::ErrorKind::BrokenPipe
                ) =>
            {
                return Ok(SessionEnd::Disconnected);
            }
            Err(e) => return Err(e),
        }
        let now_ms = started.elapsed().as_millis() as u64;
        emu.poll(now_ms, &mut out);
        if !out.is_empty() {
            match port.write_all(&out) {
                Ok(()) => {}
                Err(e) if is_timeout(&e) => emu.disconnect(),
                Err(_) => {
                    out.clear();
                    return Ok(SessionEnd::Disconnected);
                }
            }
            out.clear();
        }
    }
}

impl<S: ScanSource + 'static> EmulatorServer<S> {
    /// Serves on a new pseudo-terminal; the host opens [`EmulatorServer::endpoint`] as
    /// a serial port. The terminal is in raw mode (no echo, no CR/LF translation).
    #[cfg(unix)]
    pub fn pty(mut emulator: Emulator<S>) -> io::Result<Self> {
        use serialport::SerialPort;
        let (mut master, slave) = serialport::TTYPort::pair().map_err(io::Error::from)?;
        let path = slave
            .name()
            .ok_or_else(|| io::Error::other("the pseudo-terminal has no name"))?;
        master.set_timeout(TICK).map_err(io::Error::from)?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name("urg-emulator-pty".into())
            .spawn(move || {
                // Holding the terminal's other end open keeps the master readable while
                // no host has it open (reads would fail with EIO otherwise).
                let _slave = slave;
                let started = Instant::now();
                while !flag.load(Ordering::Relaxed) {
                    match serve(&mut emulator, &mut master, started, &flag)? {
                        SessionEnd::Stopped => break,
                        SessionEnd::Disconnected => {
                            emulator.disconnect();
                            std::thread::sleep(TICK);
                        }
                    }
                }
                Ok(emulator)
            })?;
        Ok(EmulatorServer {
            endpoint: Endpoint::Pty(path),
            stop,
            thread: Some(thread),
        })
    }

    /// Serves on a TCP address (`127.0.0.1:0` picks a free port), one host at a time
    /// like an Ethernet URG.
    pub fn tcp(mut emulator: Emulator<S>, address: impl ToSocketAddrs) -> io::Result<Self> {
        let listener = TcpListener::bind(address)?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name("urg-emulator-tcp".into())
            .spawn(move || {
                let started = Instant::now();
                while !flag.load(Ordering::Relaxed) {
                    let mut stream: TcpStream = match listener.accept() {
                        Ok((s, _)) => s,
                        Err(e) if is_timeout(&e) => {
                            std::thread::sleep(TICK);
                            continue;
                        }
                        Err(e) => return Err(e),
                    };
                    stream.set_nonblocking(false)?;
                    stream.set_read_timeout(Some(TICK))?;
                    stream.set_write_timeout(Some(Duration::from_secs(1)))?;
                    stream.set_nodelay(true)?;
                    let end = serve(&mut emulator, &mut stream, started, &flag)?;
                    emulator.disconnect();
                    if matches!(end, SessionEnd::Stopped) {
                        break;
                    }
                }
                Ok(emulator)
            })?;
        Ok(EmulatorServer {
            endpoint: Endpoint::Tcp(addr),
            stop,
            thread: Some(thread),
        })
    }

    /// Where the host reaches the emulator.
    pub fn endpoint(&self) -> &Endpoint {
        &self.endpoint
    }

    /// Stops serving and gives the emulator back (with its statistics).
    pub fn stop(mut self) -> io::Result<Emulator<S>> {
        self.stop.store(true, Ordering::Relaxed);
        self.join()
    }

    /// Serves until the thread fails (for a command line that runs until killed).
    pub fn wait(mut self) -> io::Result<Emulator<S>> {
        self.join()
    }

    fn join(&mut self) -> io::Result<Emulator<S>> {
        let thread = self
            .thread
            .take()
            .ok_or_else(|| io::Error::other("the emulator thread was already joined"))?;
        thread
            .join()
            .map_err(|_| io::Error::other("the emulator thread panicked"))?
    }
}

impl<S: ScanSource + 'static> Drop for EmulatorServer<S> {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
