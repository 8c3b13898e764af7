//! The byte pipe to a light controller: the [`Port`] trait and its three
//! implementations: a real serial port ([`SerialDevice`], over
//! `serialport`), an in-memory duplex ([`memory_pair`]) and a
//! pseudo-terminal pair (`super::pty`).
//!
//! Boundaries: bytes and timeouts only; lines and the protocol are
//! `super::wire` and `super::host`.

use crate::error::DriverError;
use std::io::{self, Read, Write};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::time::Duration;

/// A bidirectional byte stream to a controller. A read that waits longer
/// than the read timeout fails with `TimedOut` or `WouldBlock`; `Ok(0)`
/// means the other end is gone.
pub trait Port: Read + Write + Send {
    /// The device's name for messages (its path).
    fn name(&self) -> &str;
    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}

/// One end of an in-memory duplex (tests, and the simulated rig's link to
/// its simulated board).
pub struct MemoryPort {
    name: String,
    tx: Sender<Vec<u8>>,
    rx: Receiver<Vec<u8>>,
    pending: Vec<u8>,
    timeout: Duration,
}

/// Two connected ends: what one writes the other reads.
pub fn memory_pair(name_a: &str, name_b: &str) -> (MemoryPort, MemoryPort) {
    let (tx_a, rx_b) = channel();
    let (tx_b, rx_a) = channel();
    let end = |name: &str, tx, rx| MemoryPort {
        name: name.to_string(),
        tx,
        rx,
        pending: Vec::new(),
        timeout: Duration::from_millis(100),
    };
    (end(name_a, tx_a, rx_a), end(name_b, tx_b, rx_b))
}

impl Read for MemoryPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.pending.is_empty() {
            match self.rx.recv_timeout(self.timeout) {
                Ok(bytes) => self.pending = bytes,
                Err(RecvTimeoutError::Timeout) => {
                    return Err(io::Error::new(io::ErrorKind::TimedOut, "read timed out"))
                }
                Err(RecvTimeoutError::Disconnected) => return Ok(0),
            }
        }
        let n = buf.len().min(self.pending.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

impl Write for MemoryPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.tx
            .send(buf.to_vec())
            .map_err(|_| io::Error::new(io::ErrorKind::BrokenPipe, "the other end is closed"))?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Port for MemoryPort {
    fn name(&self) -> &str {
        &self.name
    }

    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.timeout = timeout;
        Ok(())
    }
}

/// A real serial port (USB CDC or a USB-serial bridge), 8N1.
pub struct SerialDevice {
    name: String,
    port: Box<dyn serialport::SerialPort>,
}

impl SerialDevice {
    /// Opens `path` (prefer a stable /dev/serial/by-id/... path) at `baud`
    /// and asserts DTR, which resets boards with an auto-reset circuit (the
    /// Uno and Nano): the host then waits for the board's READY banner.
    pub fn open(path: &str, baud: u32) -> Result<SerialDevice, DriverError> {
        let map = |e: serialport::Error| DriverError::io(path, "opening the serial port", e.into());
        let mut port = serialport::new(path, baud)
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .timeout(Duration::from_millis(100))
            .open()
            .map_err(map)?;
        match port.write_data_terminal_ready(true) {
            Ok(()) => {}
            // A terminal without modem lines (a pseudo-terminal, some USB
            // CDC boards) cannot assert DTR: nothing resets the board, and
            // the host's HELLO finds it awake instead of its READY banner.
            Err(e) if no_modem_lines(&e) => {
                tracing::debug!("{path}: no DTR line to assert ({e}); not resetting the board")
            }
            Err(e) => return Err(map(e)),
        }
        port.clear(serialport::ClearBuffer::All).map_err(map)?;
        Ok(SerialDevice {
            name: path.to_string(),
            port,
        })
    }
}

/// Whether `e` says the port has no modem control lines: `ENOTTY` from
/// the `TIOCMBIS` ioctl. serialport keeps only errno's text (nix's wording
/// or libc's), so the text is what can be matched.
fn no_modem_lines(e: &serialport::Error) -> bool {
    e.description.contains("Not a typewriter") || e.description.contains("Inappropriate ioctl")
}

impl Read for SerialDevice {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.port.read(buf)
    }
}

impl Write for SerialDevice {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.port.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.port.flush()
    }
}

impl Port for SerialDevice {
    fn name(&self) -> &str {
        &self.name
    }

    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.port.set_timeout(timeout).map_err(io::Error::from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_pair_carries_bytes_both_ways_and_times_out() {
        let (mut a, mut b) = memory_pair("a", "b");
        a.write_all(b"hello").unwrap();
        let mut buf = [0u8; 3];
        assert_eq!(b.read(&mut buf).unwrap(), 3);
        assert_eq!(&buf, b"hel");
        assert_eq!(b.read(&mut buf).unwrap(), 2);
        b.set_read_timeout(Duration::from_millis(1)).unwrap();
        assert_eq!(
            b.read(&mut buf).unwrap_err().kind(),
            io::ErrorKind::TimedOut
        );
        drop(a);
        assert_eq!(b.read(&mut buf).unwrap(), 0);
    }

    #[test]
    fn opening_a_missing_serial_port_names_it() {
        let err = match SerialDevice::open("/dev/serial/by-id/no-such-board", 115200) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("opened a port that does not exist"),
        };
        assert!(err.contains("/dev/serial/by-id/no-such-board"), "{err}");
    }
}
