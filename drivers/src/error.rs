//! The one error type of every driver. Each message names the device (a
//! path, a port or an id) and says what was expected, so that a failed scan
//! tells the operator which cable to check.

use std::path::PathBuf;
use std::time::Duration;

/// What went wrong talking to the rig.
#[derive(Debug, thiserror::Error)]
pub enum DriverError {
    #[error("{device}: {action} failed: {source}")]
    Io {
        device: String,
        action: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{port}: no reply to `{command}` after {attempts} attempts of {timeout:?} each \
         (is the light controller connected and running the matscan firmware?)"
    )]
    Timeout {
        port: String,
        command: String,
        attempts: u32,
        timeout: Duration,
    },
    #[error("{port}: no READY banner within {waited:?} after opening, and no reply to HELLO")]
    NotReady { port: String, waited: Duration },
    #[error("{port}: the light controller speaks protocol {got}, expected {expected}")]
    ProtocolMismatch {
        port: String,
        expected: u32,
        got: String,
    },
    #[error("{port}: the light controller refused `{command}`: {reason}")]
    Refused {
        port: String,
        command: String,
        reason: String,
    },
    #[error("{port}: the light controller reset {resets} times during `{command}`; giving up")]
    KeepsResetting {
        port: String,
        command: String,
        resets: u32,
    },
    #[error("{device}: malformed reply `{line}` ({expected})")]
    Malformed {
        device: String,
        line: String,
        expected: &'static str,
    },
    #[error("{device}: the camera is gone after {frames} frames ({reason})")]
    CameraLost {
        device: String,
        frames: u64,
        reason: String,
    },
    #[error("{device}: unsupported pixel format `{fourcc}` (expected one of {expected})")]
    UnsupportedFormat {
        device: String,
        fourcc: String,
        expected: &'static str,
    },
    #[error("{device}: a {fourcc} frame of {width}x{height} needs {expected} bytes, got {got}")]
    FrameSize {
        device: String,
        fourcc: String,
        width: u32,
        height: u32,
        expected: usize,
        got: usize,
    },
    #[error("{device}: cannot decode a frame: {reason}")]
    Decode { device: String, reason: String },
    #[error("{device}: control `{control}` cannot be locked: {reason}")]
    Control {
        device: String,
        control: &'static str,
        reason: String,
    },
    #[error("{device}: no fresh frame within {waited:?} after a change (dropped {dropped} stale frames)")]
    NoFreshFrame {
        device: String,
        waited: Duration,
        dropped: u32,
    },
    #[error("{device}: invalid setting: {reason}")]
    InvalidSetting { device: String, reason: String },
    #[error("{device}: the device was disconnected and did not come back within {waited:?}")]
    Disconnected { device: String, waited: Duration },
    #[error("{device}: no position {index} (the positioner has {count})")]
    NoSuchPosition {
        device: String,
        index: usize,
        count: usize,
    },
    #[error("{path}: no space left on the device (wrote {written} of {wanted} bytes)")]
    DiskFull {
        path: PathBuf,
        written: u64,
        wanted: u64,
    },
    #[error("{device}: rendering the simulated photo failed: {reason}")]
    Render { device: String, reason: String },
}

impl DriverError {
    pub(crate) fn io(device: &str, action: &'static str, source: std::io::Error) -> Self {
        DriverError::Io {
            device: device.to_string(),
            action,
            source,
        }
    }
}
