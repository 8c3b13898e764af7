//! systemd notification (`Type=notify`): `READY=1`, `STATUS=...`,
//! `WATCHDOG=1` and `STOPPING=1` as datagrams to `$NOTIFY_SOCKET`, written
//! with std's `UnixDatagram` (the protocol is one datagram of
//! newline-separated assignments). `$WATCHDOG_USEC` (when `$WATCHDOG_PID`
//! is absent or ours) gives the watchdog period; we ping at half of it, as
//! sd_watchdog_enabled(3) advises.
//!
//! Why not the `sd-notify` crate: it reads the socket from the process
//! environment on every call and has no way to be handed one. The daemon
//! also runs embedded in other processes (`matscan demo`, the end-to-end
//! tests, several daemons at once in one test binary), each with its own
//! [`Notifier`] or none; with `sd-notify` those would share one
//! process-wide variable, which tests could only change with racy
//! `set_var` calls. The hand-written sender is these few lines, with an
//! explicit target and abstract-namespace support, and is tested here.
//!
//! Boundaries: outside systemd (no `$NOTIFY_SOCKET`) every call is a no-op.

use std::os::unix::net::UnixDatagram;
use std::path::PathBuf;
use std::time::Duration;

/// Where notifications go.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Target {
    Path(PathBuf),
    /// Linux abstract namespace (`@name` in `$NOTIFY_SOCKET`).
    Abstract(Vec<u8>),
}

#[derive(Debug)]
pub struct Notifier {
    target: Option<(UnixDatagram, Target)>,
    watchdog: Option<Duration>,
}

impl Notifier {
    /// From `$NOTIFY_SOCKET`, `$WATCHDOG_USEC` and `$WATCHDOG_PID`.
    pub fn from_env() -> Notifier {
        let socket = std::env::var_os("NOTIFY_SOCKET").map(PathBuf::from);
        let usec = std::env::var("WATCHDOG_USEC").ok();
        let pid = std::env::var("WATCHDOG_PID").ok();
        let ours = pid.is_none_or(|p| p.trim() == std::process::id().to_string());
        let watchdog = usec
            .and_then(|u| u.trim().parse::<u64>().ok())
            .filter(|&u| u > 0 && ours)
            .map(Duration::from_micros);
        Notifier::new(socket, watchdog)
    }

    /// Notifications to `socket` (`@name` for the abstract namespace), with
    /// a watchdog of `watchdog` when given.
    pub fn new(socket: Option<PathBuf>, watchdog: Option<Duration>) -> Notifier {
        let target = socket.and_then(|s| {
            let bytes = s.as_os_str().as_encoded_bytes();
            let target = match bytes.strip_prefix(b"@") {
                Some(name) => Target::Abstract(name.to_vec()),
                None => Target::Path(s.clone()),
            };
            match UnixDatagram::unbound() {
                Ok(sock) => Some((sock, target)),
                Err(e) => {
                    tracing::warn!("cannot open a datagram socket for systemd notification: {e}");
                    None
                }
            }
        });
        Notifier { target, watchdog }
    }

    /// How often [`Notifier::watchdog`] must be called: half the period
    /// systemd was given, or `None` without a watchdog.
    pub fn watchdog_interval(&self) -> Option<Duration> {
        self.watchdog.map(|w| w / 2)
    }

    pub fn ready(&self, status: &str) {
        self.send(&format!("READY=1\nSTATUS={}", one_line(status)));
    }

    pub fn status(&self, status: &str) {
        self.send(&format!("STATUS={}", one_line(status)));
    }

    pub fn watchdog(&self) {
        if self.watchdog.is_some() {
            self.send("WATCHDOG=1");
        }
    }

    pub fn stopping(&self, status: &str) {
        self.send(&format!("STOPPING=1\nSTATUS={}", one_line(status)));
    }

    fn send(&self, message: &str) {
        let Some((sock, target)) = &self.target else {
            return;
        };
        let sent = match target {
            Target::Path(p) => sock.send_to(message.as_bytes(), p),
            Target::Abstract(name) => send_abstract(sock, name, message.as_bytes()),
        };
        // Losing a notification must not stop a scan; systemd's own
        // timeouts tell the operator.
        if let Err(e) = sent {
            tracing::warn!("systemd notification `{message}` not sent: {e}");
        }
    }
}

#[cfg(target_os = "linux")]
fn send_abstract(sock: &UnixDatagram, name: &[u8], bytes: &[u8]) -> std::io::Result<usize> {
    use std::os::linux::net::SocketAddrExt;
    let addr = std::os::unix::net::SocketAddr::from_abstract_name(name)?;
    sock.send_to_addr(bytes, &addr)
}

#[cfg(not(target_os = "linux"))]
fn send_abstract(_sock: &UnixDatagram, _name: &[u8], _bytes: &[u8]) -> std::io::Result<usize> {
    Err(std::io::Error::new(
        std::io::ErrorKind::Unsupported,
        "abstract sockets exist on Linux only",
    ))
}

/// systemd reads one assignment per line.
fn one_line(s: &str) -> String {
    s.replace(['\n', '\r'], " ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recv(sock: &UnixDatagram) -> String {
        let mut buf = [0u8; 512];
        let n = sock.recv(&mut buf).unwrap();
        String::from_utf8_lossy(&buf[..n]).into_owned()
    }

    #[test]
    fn messages_reach_the_notify_socket_one_assignment_per_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notify");
        let listener = UnixDatagram::bind(&path).unwrap();
        let n = Notifier::new(Some(path), Some(Duration::from_secs(10)));
        assert_eq!(n.watchdog_interval(), Some(Duration::from_secs(5)));
        n.ready("idle\nready");
        assert_eq!(recv(&listener), "READY=1\nSTATUS=idle ready");
        n.watchdog();
        assert_eq!(recv(&listener), "WATCHDOG=1");
        n.stopping("bye");
        assert_eq!(recv(&listener), "STOPPING=1\nSTATUS=bye");
    }

    #[test]
    fn abstract_socket_names_are_reached_too() {
        let name = format!("matscan-test-{}", std::process::id());
        use std::os::linux::net::SocketAddrExt;
        let addr = std::os::unix::net::SocketAddr::from_abstract_name(name.as_bytes()).unwrap();
        let listener = UnixDatagram::bind_addr(&addr).unwrap();
        let n = Notifier::new(Some(PathBuf::from(format!("@{name}"))), None);
        n.status("capturing");
        assert_eq!(recv(&listener), "STATUS=capturing");
    }

    #[test]
    fn without_a_socket_or_watchdog_nothing_is_sent() {
        let n = Notifier::new(None, None);
        assert_eq!(n.watchdog_interval(), None);
        assert!(n.target.is_none());
        n.ready("x");
    }
}
