//! A pseudo-terminal pair as two [`Port`]s, so the protocol is tested over
//! a real tty (line discipline, kernel buffering) without hardware.
//!
//! Boundaries: Unix only (`libc::openpty`); both ends are put in raw mode so
//! the tty neither echoes nor translates newlines, like a serial port
//! configured by `serialport`.

use super::port::Port;
use std::io::{self, Read, Write};
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::time::Duration;

/// One end of a pseudo-terminal.
pub struct PtyPort {
    fd: OwnedFd,
    name: String,
    timeout: Duration,
}

/// Opens a pseudo-terminal: `(master, slave)`.
pub fn pty_pair() -> io::Result<(PtyPort, PtyPort)> {
    let mut master: libc::c_int = -1;
    let mut slave: libc::c_int = -1;
    // SAFETY: openpty writes two descriptors into the given ints; the name,
    // termios and winsize pointers may be null.
    let rc = unsafe {
        libc::openpty(
            &mut master,
            &mut slave,
            std::ptr::null_mut(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    if rc != 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: openpty succeeded, so both are fresh descriptors we own.
    let (master, slave) = unsafe { (OwnedFd::from_raw_fd(master), OwnedFd::from_raw_fd(slave)) };
    for fd in [&master, &slave] {
        make_raw(fd.as_raw_fd())?;
    }
    let end = |fd, name: &str| PtyPort {
        fd,
        name: name.to_string(),
        timeout: Duration::from_millis(100),
    };
    Ok((end(master, "pty-master"), end(slave, "pty-slave")))
}

fn make_raw(fd: libc::c_int) -> io::Result<()> {
    // SAFETY: termios is plain data; tcgetattr fills it for a valid fd.
    unsafe {
        let mut t: libc::termios = std::mem::zeroed();
        if libc::tcgetattr(fd, &mut t) != 0 {
            return Err(io::Error::last_os_error());
        }
        libc::cfmakeraw(&mut t);
        if libc::tcsetattr(fd, libc::TCSANOW, &t) != 0 {
            return Err(io::Error::last_os_error());
        }
    }
    Ok(())
}

impl Read for PtyPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let mut pfd = libc::pollfd {
            fd: self.fd.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        let ms = self.timeout.as_millis().min(i32::MAX as u128) as libc::c_int;
        // SAFETY: one valid pollfd.
        let n = unsafe { libc::poll(&mut pfd, 1, ms) };
        if n < 0 {
            return Err(io::Error::last_os_error());
        }
        if n == 0 {
            return Err(io::Error::new(io::ErrorKind::TimedOut, "read timed out"));
        }
        // SAFETY: buf is valid for buf.len() bytes.
        let r = unsafe { libc::read(self.fd.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
        if r < 0 {
            let e = io::Error::last_os_error();
            // The master reads EIO once the slave side is closed: the other
            // end is gone.
            return if e.raw_os_error() == Some(libc::EIO) {
                Ok(0)
            } else {
                Err(e)
            };
        }
        Ok(r as usize)
    }
}

impl Write for PtyPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        // SAFETY: buf is valid for buf.len() bytes.
        let r = unsafe { libc::write(self.fd.as_raw_fd(), buf.as_ptr().cast(), buf.len()) };
        if r < 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(r as usize)
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl PtyPort {
    /// The terminal's device path (`/dev/pts/N` for the slave end), which a
    /// program opens as it would a serial port.
    pub fn tty_path(&self) -> io::Result<std::path::PathBuf> {
        let mut buf = vec![0u8; 128];
        // SAFETY: buf is valid and writable for buf.len() bytes; ttyname_r
        // writes a NUL-terminated path into it or returns an error number.
        let rc =
            unsafe { libc::ttyname_r(self.fd.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
        if rc != 0 {
            // Containers that mount a private devpts may not resolve the
            // name; the descriptor's /proc link opens the same terminal.
            let proc = std::path::PathBuf::from(format!("/proc/self/fd/{}", self.fd.as_raw_fd()));
            return if proc.exists() {
                Ok(proc)
            } else {
                Err(io::Error::from_raw_os_error(rc))
            };
        }
        let len = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
        buf.truncate(len);
        use std::os::unix::ffi::OsStringExt;
        Ok(std::ffi::OsString::from_vec(buf).into())
    }
}

impl Port for PtyPort {
    fn name(&self) -> &str {
        &self.name
    }

    fn set_read_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.timeout = timeout;
        Ok(())
    }
}
