//! The light controller on a serial line: flash0, flash1 and the backlight
//! switched by a microcontroller that speaks the line protocol of
//! `docs/light-protocol.md` (sequence numbers, CRC-16, acknowledgement,
//! timeout and retry, HELLO, heartbeat, READY after reset).
//!
//! - [`wire`]: line framing, CRC, requests and replies;
//! - [`port`]: the byte pipe ([`Port`]): a real serial port, an in-memory
//!   duplex;
//! - [`pty`]: a pseudo-terminal pair, for tests over a real tty;
//! - [`host`]: [`SerialLights`], the [`crate::LightController`];
//! - [`board`]: the firmware's state machine with fault injection, the
//!   simulated controller (the reference firmware is
//!   `drivers/firmware/light_controller/light_controller.ino`);
//! - [`board_runner`]: a simulated board serving a port in a thread.
//!
//! Boundaries: lights only; the camera and projector are elsewhere.
//! Crate choice: `serialport` without its `libudev` feature (ports are
//! addressed by their /dev/serial/by-id path, so enumeration is not needed
//! and the build needs no system library).

pub mod board;
pub mod board_runner;
pub mod host;
pub mod port;
pub mod pty;
pub mod wire;

#[cfg(test)]
mod tests;

pub use board::{Board, BoardConfig, BoardFaults};
pub use board_runner::RunningBoard;
pub use host::{BoardInfo, HostConfig, SerialLights};
pub use port::{memory_pair, MemoryPort, Port, SerialDevice};
pub use pty::{pty_pair, PtyPort};

/// Opens the light controller at `path` (e.g.
/// `/dev/serial/by-id/usb-Arduino...-if00`): opening resets most boards,
/// so this waits for their READY banner.
pub fn open_lights(
    path: &str,
    baud: u32,
    config: HostConfig,
) -> Result<SerialLights, crate::DriverError> {
    let port = SerialDevice::open(path, baud)?;
    SerialLights::connect(Box::new(port), config)
}
