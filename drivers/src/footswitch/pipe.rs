//! A trigger fed through a named pipe (FIFO): every line written to it is
//! one press. It stands in for the pedal of the simulated rig (a test or
//! a demo presses with `echo > PATH`), and serves rigs whose pedal another
//! program reads (a GPIO or a vendor's footswitch tool that writes a line
//! per press).
//!
//! The pipe is created (mode 0660) when missing and reused when it is
//! already a pipe; anything else at the path is refused, naming it. It is
//! opened read-write, so opening never blocks and the pipe never reaches
//! end-of-file when a writer closes. A reader thread stamps each press
//! with the monotonic clock when it arrives; it polls in 100 ms slices and
//! ends when the trigger is dropped. The pipe stays in place after a drop,
//! so a writer's path stays valid while the daemon reopens its rig.
//!
//! Boundaries: Linux FIFOs through `libc` only; no device.

use crate::error::DriverError;
use crate::traits::{monotonic_now, Press, Trigger};
use std::ffi::CString;
use std::fs::File;
use std::io::Read;
use std::os::fd::{AsRawFd, FromRawFd};
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// How often the reader thread looks at its stop flag.
const POLL_SLICE_MS: libc::c_int = 100;

/// A trigger whose presses are lines written to a named pipe.
pub struct PipeTrigger {
    id: String,
    presses: Receiver<Press>,
    alive: Arc<AtomicBool>,
    reader: Option<JoinHandle<()>>,
}

impl PipeTrigger {
    /// Creates the pipe at `path` if needed, opens it and starts reading.
    pub fn open(path: &Path) -> Result<PipeTrigger, DriverError> {
        let id = format!("pipe:{}", path.display());
        let file = open_pipe(path, &id)?;
        let (tx, presses) = channel();
        let alive = Arc::new(AtomicBool::new(true));
        let flag = alive.clone();
        let reader = std::thread::Builder::new()
            .name("matscan-pipe-trigger".into())
            .spawn(move || read_presses(file, &flag, &tx))
            .map_err(|e| DriverError::io(&id, "starting the pipe's reader thread", e))?;
        Ok(PipeTrigger {
            id,
            presses,
            alive,
            reader: Some(reader),
        })
    }
}

fn open_pipe(path: &Path, id: &str) -> Result<File, DriverError> {
    let c = CString::new(path.as_os_str().as_bytes()).map_err(|_| DriverError::InvalidSetting {
        device: id.to_string(),
        reason: "the path holds a NUL byte".into(),
    })?;
    match std::fs::symlink_metadata(path) {
        Ok(meta) if meta.file_type().is_fifo() => {}
        Ok(_) => {
            return Err(DriverError::InvalidSetting {
                device: id.to_string(),
                reason: format!(
                    "{} exists and is not a named pipe (remove it; the trigger creates the pipe)",
                    path.display()
                ),
            })
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            // SAFETY: a valid NUL-terminated path.
            if unsafe { libc::mkfifo(c.as_ptr(), 0o660) } != 0 {
                return Err(DriverError::io(
                    id,
                    "creating the named pipe",
                    std::io::Error::last_os_error(),
                ));
            }
        }
        Err(e) => return Err(DriverError::io(id, "looking at the named pipe", e)),
    }
    // Read-write: opening does not wait for a writer, and the last writer's
    // close is no end-of-file.
    // SAFETY: a valid NUL-terminated path; the fd is owned by the File.
    let fd = unsafe {
        libc::open(
            c.as_ptr(),
            libc::O_RDWR | libc::O_NONBLOCK | libc::O_CLOEXEC,
        )
    };
    if fd < 0 {
        return Err(DriverError::io(
            id,
            "opening the named pipe",
            std::io::Error::last_os_error(),
        ));
    }
    // SAFETY: `fd` is a freshly opened descriptor nobody else owns.
    Ok(unsafe { File::from_raw_fd(fd) })
}

fn read_presses(mut file: File, alive: &AtomicBool, tx: &Sender<Press>) {
    let mut buf = [0u8; 256];
    while alive.load(Ordering::SeqCst) {
        let mut pfd = libc::pollfd {
            fd: file.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd.
        let n = unsafe { libc::poll(&mut pfd, 1, POLL_SLICE_MS) };
        if n <= 0 {
            // Timeout, or EINTR: look at the flag and poll again.
            continue;
        }
        match file.read(&mut buf) {
            Ok(r) => {
                let timestamp = monotonic_now();
                for _ in buf[..r].iter().filter(|b| **b == b'\n') {
                    if tx.send(Press { timestamp }).is_err() {
                        return;
                    }
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::Interrupted
                ) => {}
            Err(e) => {
                tracing::warn!("named-pipe trigger: {e}; no more presses from it");
                return;
            }
        }
    }
}

impl Trigger for PipeTrigger {
    fn id(&self) -> &str {
        &self.id
    }

    fn wait(&mut self, timeout: Duration) -> Result<Option<Press>, DriverError> {
        match self.presses.recv_timeout(timeout) {
            Ok(p) => Ok(Some(p)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(DriverError::Disconnected {
                device: self.id.clone(),
                waited: timeout,
            }),
        }
    }
}

impl Drop for PipeTrigger {
    fn drop(&mut self) {
        self.alive.store(false, Ordering::SeqCst);
        if let Some(reader) = self.reader.take() {
            let _ = reader.join();
        }
    }
}

/// The path of a `pipe:PATH` trigger setting.
pub fn pipe_path(setting: &str) -> Option<PathBuf> {
    setting
        .strip_prefix("pipe:")
        .filter(|p| !p.is_empty())
        .map(PathBuf::from)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::time::Instant;

    fn press(path: &Path, lines: &str) {
        let mut w = std::fs::OpenOptions::new().write(true).open(path).unwrap();
        w.write_all(lines.as_bytes()).unwrap();
    }

    #[test]
    fn every_line_written_is_one_press_stamped_when_it_arrived() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pedal");
        let mut t = PipeTrigger::open(&path).unwrap();
        assert!(std::fs::symlink_metadata(&path)
            .unwrap()
            .file_type()
            .is_fifo());
        assert_eq!(t.wait(Duration::from_millis(50)).unwrap(), None);
        let before = monotonic_now();
        press(&path, "\n");
        press(&path, "press\npress\n");
        let mut got = Vec::new();
        while let Some(p) = t.wait(Duration::from_millis(500)).unwrap() {
            got.push(p);
        }
        assert_eq!(got.len(), 3);
        assert!(got.iter().all(|p| p.timestamp >= before));
        // A writer that closed is no end of file: the next line still counts.
        press(&path, "\n");
        assert!(t.wait(Duration::from_secs(1)).unwrap().is_some());
    }

    #[test]
    fn an_existing_pipe_is_reused_and_survives_the_trigger() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pedal");
        drop(PipeTrigger::open(&path).unwrap());
        assert!(path.exists(), "the pipe stays for the next opening");
        let mut t = PipeTrigger::open(&path).unwrap();
        press(&path, "\n");
        assert!(t.wait(Duration::from_secs(1)).unwrap().is_some());
    }

    #[test]
    fn a_regular_file_at_the_path_is_refused_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("pedal");
        std::fs::write(&path, "x").unwrap();
        let e = PipeTrigger::open(&path).err().unwrap().to_string();
        assert!(e.contains("pedal") && e.contains("not a named pipe"), "{e}");
    }

    #[test]
    fn dropping_the_trigger_ends_its_reader_within_a_poll_slice() {
        let dir = tempfile::tempdir().unwrap();
        let t = PipeTrigger::open(&dir.path().join("pedal")).unwrap();
        let start = Instant::now();
        drop(t);
        assert!(start.elapsed() < Duration::from_millis(1000));
    }

    #[test]
    fn pipe_settings_name_a_path() {
        assert_eq!(pipe_path("pipe:/run/p"), Some(PathBuf::from("/run/p")));
        assert_eq!(pipe_path("pipe:"), None);
        assert_eq!(pipe_path("/dev/input/event3"), None);
    }
}
