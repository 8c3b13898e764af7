//! The matscan capture service, as it runs on the scanner PC under systemd
//! (`matscan daemon`), and its client.
//!
//! - [`service`]: the capture sequencer, the control socket, systemd
//!   notification and the estimation worker;
//! - [`client`]: `matscan capture-now` and `matscan status` over the
//!   control socket;
//! - [`procstat`]: file descriptors, threads and memory of this process
//!   (the soak harness);
//! - [`soak`]: many captures in a row, with resources sampled.
//!
//! Boundaries: drives the rig through `matscan-drivers`' traits, writes
//! bundles through `matscan-scan`, estimates through `matscan-estimate`;
//! no evaluation, benchmarking or argument parsing (the binary's).
//!
//! Crate choices: `crossbeam-channel` feeds the estimation worker; `libc`
//! for signal handling, `getgrnam_r` and `chown`; `serde_json` for the
//! socket's line protocol (docs/daemon-protocol.md).

pub mod client;
pub mod procstat;
pub mod service;
pub mod soak;
