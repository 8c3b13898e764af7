//! The projector on a real DRM card (feature `hardware`): open the card,
//! become DRM master, pick the output, its CRTC and mode, allocate two dumb
//! buffers with framebuffers, modeset to black, then page-flip patterns
//! with the flip-complete event read by polling the card's fd.
//!
//! Legacy (non-atomic) modesetting is used: it is all a single full-screen
//! output needs, every KMS driver supports it, and its page flips deliver
//! the same events. On drop the CRTC gets back the framebuffer and mode it
//! had (the console's, usually), best effort.
//!
//! Boundaries: the `drm` crate and `libc::poll`; the rules (mode choice,
//! raster, flip timing) are the sibling modules'.

use crate::error::DriverError;
use crate::projector::kms::connector::{pick_connector, ConnectorInfo};
use crate::projector::kms::edid::Edid;
use crate::projector::kms::flip::{FlipChain, FlipTiming, Scanout};
use crate::projector::kms::mode::{select_mode, ListedMode, ModeChoice, ModeRequest, Timing};
use crate::projector::kms::raster::Gamma;
use crate::traits::{monotonic_now, Projector, ProjectorPattern};
use drm::buffer::DrmFourcc;
use drm::control::dumbbuffer::DumbBuffer;
use drm::control::{
    connector, crtc, framebuffer, Device as ControlDevice, Event, Mode, ModeFlags, ModeTypeFlags,
    PageFlipFlags, ResourceHandles,
};
use drm::{Device as BasicDevice, DriverCapability};
use std::fs::{File, OpenOptions};
use std::io;
use std::os::fd::{AsFd, AsRawFd, BorrowedFd};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How to open the projector's output.
#[derive(Debug, Clone, PartialEq)]
pub struct DrmConfig {
    /// `/dev/dri/card0`, or better a `/dev/dri/by-path/...-card` link
    /// (card numbers follow probe order).
    pub card: PathBuf,
    /// The output's kernel name (`HDMI-A-1`, `DP-2`, as in
    /// `/sys/class/drm/card0-HDMI-A-1`); `None`: the only connected one.
    pub connector: Option<String>,
    /// The mode; `None`: the output's preferred mode.
    pub mode: Option<ModeRequest>,
    /// From the flip event to the projector emitting the frame.
    pub latency: Duration,
    /// The projector's video gamma (levels are linear light).
    pub gamma: f32,
    /// Longest wait for a flip-complete event.
    pub flip_timeout: Duration,
    /// Extra wait after a modeset for the projector to lock on.
    pub modeset_settle: Duration,
}

impl DrmConfig {
    /// Defaults: the only connected output, its preferred mode, 100 ms
    /// latency, gamma 2.2, 1 s flip timeout, 2 s modeset settle.
    pub fn new(card: impl Into<PathBuf>) -> DrmConfig {
        let t = FlipTiming::default();
        DrmConfig {
            card: card.into(),
            connector: None,
            mode: None,
            latency: t.latency,
            gamma: Gamma::DEFAULT.get(),
            flip_timeout: t.flip_timeout,
            modeset_settle: t.modeset_settle,
        }
    }
}

/// A card opened read-write; drm-rs's traits do the ioctls on its fd.
struct Card(File);

impl AsFd for Card {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.0.as_fd()
    }
}

impl BasicDevice for Card {}
impl ControlDevice for Card {}

impl Card {
    fn open(path: &Path) -> Result<Card, DriverError> {
        let name = path.display().to_string();
        OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .map(Card)
            .map_err(|e| {
                let action = match e.kind() {
                    io::ErrorKind::PermissionDenied => {
                        "opening the DRM card (is the user in the `video` group?)"
                    }
                    io::ErrorKind::NotFound => {
                        "opening the DRM card (see `ls /dev/dri/by-path/` for the cards)"
                    }
                    _ => "opening the DRM card",
                };
                DriverError::io(&name, action, e)
            })
    }
}

/// The projector on a DRM output.
pub struct DrmProjector {
    id: String,
    size: (u32, u32),
    chain: FlipChain<KmsScanout>,
}

impl DrmProjector {
    /// Opens `config.card`, takes the output and shows black (a modeset,
    /// which waits `modeset_settle` + `latency`).
    pub fn open(config: DrmConfig) -> Result<DrmProjector, DriverError> {
        let card_name = config.card.display().to_string();
        let gamma = Gamma::new(config.gamma).ok_or_else(|| DriverError::InvalidSetting {
            device: card_name.clone(),
            reason: format!(
                "projector gamma {} is outside 0.1..=10 (2.2 is usual)",
                config.gamma
            ),
        })?;
        let card = Card::open(&config.card)?;
        become_master(&card, &card_name)?;
        let res = card
            .resource_handles()
            .map_err(|e| DriverError::io(&card_name, "reading the card's KMS resources", e))?;
        // A forced probe (we are master) re-reads the EDID, so a projector
        // switched on after boot shows its real modes.
        let (handles, infos) = read_connectors(&card, &res, true, &card_name)?;
        let index = pick_connector(&infos, config.connector.as_deref(), &card_name)?;
        let (conn, info) = (&handles[index], &infos[index]);
        let id = format!("{card_name}:{}", info.name);
        let choice = select_mode(&info.modes, config.mode.as_ref(), &id)?;
        let mode = match choice {
            ModeChoice::Listed(i) => conn.modes()[i],
            ModeChoice::Forced(t) => drm_mode(&t),
        };
        let crtc = pick_crtc(&card, &res, conn, &id)?;
        let saved = card.get_crtc(crtc).ok();
        let monotonic = card
            .get_driver_capability(DriverCapability::MonotonicTimestamp)
            .map(|v| v == 1)
            .unwrap_or(false);
        let (w, h) = mode.size();
        let mut scanout = KmsScanout {
            name: id.clone(),
            card,
            crtc,
            connector: conn.handle(),
            mode,
            size: (w as u32, h as u32),
            stride: 0,
            buffers: Vec::new(),
            fbs: Vec::new(),
            saved,
            modeset: false,
            monotonic,
        };
        scanout.allocate()?;
        tracing::info!(
            projector = %id,
            display = %info.edid.as_ref().map(Edid::describe).unwrap_or_else(|| "no EDID".into()),
            mode = %timing_of(&mode),
            forced = matches!(choice, ModeChoice::Forced(_)),
            "opening the projector output"
        );
        let timing = FlipTiming {
            latency: config.latency,
            flip_timeout: config.flip_timeout,
            modeset_settle: config.modeset_settle,
        };
        let mut chain = FlipChain::new(scanout, gamma, timing);
        chain.show(ProjectorPattern::Black)?;
        Ok(DrmProjector {
            id,
            size: (w as u32, h as u32),
            chain,
        })
    }
}

impl Projector for DrmProjector {
    fn id(&self) -> &str {
        &self.id
    }

    fn resolution(&self) -> (u32, u32) {
        self.size
    }

    fn show(&mut self, pattern: ProjectorPattern) -> Result<(), DriverError> {
        self.chain.show(pattern)
    }

    fn pattern(&self) -> ProjectorPattern {
        self.chain.pattern()
    }
}

/// The outputs of `card`, for diagnostics (no master needed; no forced
/// probe, so the kernel's last-known state).
pub fn list_connectors(card: &Path) -> Result<Vec<ConnectorInfo>, DriverError> {
    let name = card.display().to_string();
    let card = Card::open(card)?;
    let res = card
        .resource_handles()
        .map_err(|e| DriverError::io(&name, "reading the card's KMS resources", e))?;
    Ok(read_connectors(&card, &res, false, &name)?.1)
}

fn become_master(card: &Card, name: &str) -> Result<(), DriverError> {
    // Opening a card no one holds makes us master; this call then succeeds
    // (already master). With another master it fails: EBUSY for root,
    // EACCES otherwise.
    match card.acquire_master_lock() {
        Ok(()) => Ok(()),
        Err(e)
            if matches!(
                e.raw_os_error(),
                Some(libc::EBUSY) | Some(libc::EACCES) | Some(libc::EPERM)
            ) =>
        {
            Err(DriverError::InvalidSetting {
                device: name.to_string(),
                reason: format!(
                    "cannot become DRM master ({e}): another program, usually a desktop \
                     session or display manager, drives this card; stop it (e.g. `sudo \
                     systemctl stop display-manager`) or plug the projector into a GPU no \
                     session uses"
                ),
            })
        }
        Err(e) => Err(DriverError::io(name, "becoming DRM master", e)),
    }
}

fn read_connectors(
    card: &Card,
    res: &ResourceHandles,
    force_probe: bool,
    name: &str,
) -> Result<(Vec<connector::Info>, Vec<ConnectorInfo>), DriverError> {
    let mut handles = Vec::new();
    let mut infos = Vec::new();
    for &h in res.connectors() {
        let c = card
            .get_connector(h, force_probe)
            .map_err(|e| DriverError::io(name, "reading a connector", e))?;
        let connected = c.state() == connector::State::Connected;
        infos.push(ConnectorInfo {
            name: c.to_string(),
            connected,
            modes: c.modes().iter().map(listed_mode).collect(),
            edid: if connected { read_edid(card, h) } else { None },
        });
        handles.push(c);
    }
    Ok((handles, infos))
}

/// The connector's EDID property blob, parsed; `None` when absent or
/// invalid (logged: a bad EDID is why a projector lists no modes).
fn read_edid(card: &Card, handle: connector::Handle) -> Option<Edid> {
    let props = card.get_properties(handle).ok()?;
    let (ids, values) = props.as_props_and_values();
    for (&id, &value) in ids.iter().zip(values) {
        let Ok(info) = card.get_property(id) else {
            continue;
        };
        if info.name().to_bytes() != b"EDID" {
            continue;
        }
        if value == 0 {
            return None;
        }
        let blob = card.get_property_blob(value).ok()?;
        return match Edid::parse(&blob) {
            Ok(e) => Some(e),
            Err(e) => {
                tracing::warn!(error = %e, "unreadable EDID");
                None
            }
        };
    }
    None
}

fn listed_mode(m: &Mode) -> ListedMode {
    ListedMode {
        timing: timing_of(m),
        preferred: m.mode_type().contains(ModeTypeFlags::PREFERRED),
    }
}

fn timing_of(m: &Mode) -> Timing {
    let (hdisplay, vdisplay) = m.size();
    let (hsync_start, hsync_end, htotal) = m.hsync();
    let (vsync_start, vsync_end, vtotal) = m.vsync();
    Timing {
        clock_khz: m.clock(),
        hdisplay,
        hsync_start,
        hsync_end,
        htotal,
        vdisplay,
        vsync_start,
        vsync_end,
        vtotal,
        hsync_positive: m.flags().contains(ModeFlags::PHSYNC),
        vsync_positive: m.flags().contains(ModeFlags::PVSYNC),
        interlaced: m.flags().contains(ModeFlags::INTERLACE),
    }
}

const DRM_MODE_TYPE_USERDEF: u32 = 1 << 5;
const DRM_MODE_FLAG_PHSYNC: u32 = 1 << 0;
const DRM_MODE_FLAG_NHSYNC: u32 = 1 << 1;
const DRM_MODE_FLAG_PVSYNC: u32 = 1 << 2;
const DRM_MODE_FLAG_NVSYNC: u32 = 1 << 3;
const DRM_MODE_FLAG_INTERLACE: u32 = 1 << 4;

/// A drm-rs mode for a timing the connector does not list.
fn drm_mode(t: &Timing) -> Mode {
    let mut name = [0 as libc::c_char; 32];
    let text = format!("{}x{}", t.hdisplay, t.vdisplay);
    for (d, &s) in name.iter_mut().zip(text.as_bytes().iter().take(31)) {
        *d = s as libc::c_char;
    }
    let raw = drm_ffi::drm_mode_modeinfo {
        clock: t.clock_khz,
        hdisplay: t.hdisplay,
        hsync_start: t.hsync_start,
        hsync_end: t.hsync_end,
        htotal: t.htotal,
        hskew: 0,
        vdisplay: t.vdisplay,
        vsync_start: t.vsync_start,
        vsync_end: t.vsync_end,
        vtotal: t.vtotal,
        vscan: 0,
        vrefresh: t.refresh_hz().round() as u32,
        flags: if t.hsync_positive {
            DRM_MODE_FLAG_PHSYNC
        } else {
            DRM_MODE_FLAG_NHSYNC
        } | if t.vsync_positive {
            DRM_MODE_FLAG_PVSYNC
        } else {
            DRM_MODE_FLAG_NVSYNC
        } | if t.interlaced {
            DRM_MODE_FLAG_INTERLACE
        } else {
            0
        },
        type_: DRM_MODE_TYPE_USERDEF,
        name,
    };
    Mode::from(raw)
}

/// The CRTC to drive `conn`: the one it is on (the console's, usually),
/// else a free one its encoders can use. Never one another output is on.
fn pick_crtc(
    card: &Card,
    res: &ResourceHandles,
    conn: &connector::Info,
    name: &str,
) -> Result<crtc::Handle, DriverError> {
    if let Some(crtc) = conn
        .current_encoder()
        .and_then(|e| card.get_encoder(e).ok())
        .and_then(|e| e.crtc())
    {
        return Ok(crtc);
    }
    let busy: Vec<crtc::Handle> = res
        .encoders()
        .iter()
        .filter_map(|&e| card.get_encoder(e).ok()?.crtc())
        .collect();
    for &e in conn.encoders() {
        let Ok(enc) = card.get_encoder(e) else {
            continue;
        };
        if let Some(c) = res
            .filter_crtcs(enc.possible_crtcs())
            .into_iter()
            .find(|c| !busy.contains(c))
        {
            return Ok(c);
        }
    }
    Err(DriverError::InvalidSetting {
        device: name.to_string(),
        reason: "every display controller (CRTC) that can drive this output is in use by \
                 another output; unplug or disable one"
            .into(),
    })
}

/// Two dumb buffers on one CRTC of a real card.
struct KmsScanout {
    name: String,
    card: Card,
    crtc: crtc::Handle,
    connector: connector::Handle,
    mode: Mode,
    size: (u32, u32),
    stride: usize,
    buffers: Vec<DumbBuffer>,
    fbs: Vec<framebuffer::Handle>,
    /// The CRTC as it was before us, restored on drop.
    saved: Option<crtc::Info>,
    /// True once we set the CRTC.
    modeset: bool,
    /// Flip events are stamped on CLOCK_MONOTONIC (every kernel since 3.x).
    monotonic: bool,
}

impl KmsScanout {
    fn allocate(&mut self) -> Result<(), DriverError> {
        let (w, h) = self.size;
        for _ in 0..2 {
            let db = self
                .card
                .create_dumb_buffer((w, h), DrmFourcc::Xrgb8888, 32)
                .map_err(|e| DriverError::io(&self.name, "creating a scanout buffer", e))?;
            self.buffers.push(db);
            let fb = self
                .card
                .add_framebuffer(&db, 24, 32)
                .map_err(|e| DriverError::io(&self.name, "adding a framebuffer", e))?;
            self.fbs.push(fb);
        }
        use drm::buffer::Buffer;
        self.stride = self.buffers[0].pitch() as usize;
        if self.buffers[1].pitch() as usize != self.stride {
            return Err(DriverError::InvalidSetting {
                device: self.name.clone(),
                reason: "the two scanout buffers got different strides".into(),
            });
        }
        Ok(())
    }

    /// Reads and drops the events already queued on the card.
    fn drain_events(&mut self) -> Result<(), DriverError> {
        while self.poll_readable(0)? {
            let dropped = self
                .card
                .receive_events()
                .map_err(self.io_err("reading DRM events"))?
                .count();
            tracing::debug!(projector = %self.name, dropped, "dropped stale DRM events");
        }
        Ok(())
    }

    /// Whether the card has events to read within `ms` milliseconds.
    fn poll_readable(&self, ms: libc::c_int) -> Result<bool, DriverError> {
        loop {
            let mut fds = [libc::pollfd {
                fd: self.card.as_fd().as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            }];
            // SAFETY: `fds` is one valid pollfd on an fd we own for the
            // whole call.
            let n = unsafe { libc::poll(fds.as_mut_ptr(), 1, ms) };
            if n >= 0 {
                return Ok(n > 0);
            }
            let e = io::Error::last_os_error();
            if e.kind() != io::ErrorKind::Interrupted {
                return Err(DriverError::io(&self.name, "polling for DRM events", e));
            }
        }
    }

    fn io_err(&self, action: &'static str) -> impl FnOnce(io::Error) -> DriverError + '_ {
        move |e| DriverError::io(&self.name, action, e)
    }
}

impl Scanout for KmsScanout {
    fn name(&self) -> &str {
        &self.name
    }

    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn stride(&self) -> usize {
        self.stride
    }

    fn with_buffer(
        &mut self,
        index: usize,
        draw: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), DriverError> {
        let mut map = self
            .card
            .map_dumb_buffer(&mut self.buffers[index])
            .map_err(|e| DriverError::io(&self.name, "mapping a scanout buffer", e))?;
        draw(&mut map);
        Ok(())
    }

    fn set_crtc(&mut self, index: usize) -> Result<(), DriverError> {
        self.card
            .set_crtc(
                self.crtc,
                Some(self.fbs[index]),
                (0, 0),
                &[self.connector],
                Some(self.mode),
            )
            .map_err(
                self.io_err("setting the mode (the projector refused it, or DRM master was lost?)"),
            )?;
        self.modeset = true;
        // A flip that timed out before this (recovery) modeset has sent its
        // event by now (the modeset waits for it); drop it so the next
        // wait does not take it for its own.
        self.drain_events()
    }

    fn page_flip(&mut self, index: usize) -> Result<(), DriverError> {
        self.card
            .page_flip(self.crtc, self.fbs[index], PageFlipFlags::EVENT, None)
            .map_err(self.io_err("queueing a page flip"))
    }

    fn wait_flip(&mut self, timeout: Duration) -> Result<Option<Duration>, DriverError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            let ms = left.as_micros().div_ceil(1000).min(i32::MAX as u128) as libc::c_int;
            if !self.poll_readable(ms)? {
                continue;
            }
            let events = self
                .card
                .receive_events()
                .map_err(self.io_err("reading DRM events"))?;
            for event in events {
                if let Event::PageFlip(flip) = event {
                    if flip.crtc != self.crtc {
                        continue;
                    }
                    let now = monotonic_now();
                    // `duration` is the vblank's timestamp; on another clock
                    // (very old kernels), count from now instead.
                    let at = if self.monotonic && flip.duration <= now {
                        flip.duration
                    } else {
                        now
                    };
                    return Ok(Some(at));
                }
            }
        }
    }
}

impl Drop for KmsScanout {
    fn drop(&mut self) {
        if self.modeset {
            let restored = match &self.saved {
                Some(s) if s.mode().is_some() && s.framebuffer().is_some() => self.card.set_crtc(
                    self.crtc,
                    s.framebuffer(),
                    s.position(),
                    &[self.connector],
                    s.mode(),
                ),
                // It was off: switch it off again.
                _ => self.card.set_crtc(self.crtc, None, (0, 0), &[], None),
            };
            if let Err(e) = restored {
                tracing::warn!(projector = %self.name, error = %e, "could not restore the previous display state");
            }
        }
        for &fb in &self.fbs {
            if let Err(e) = self.card.destroy_framebuffer(fb) {
                tracing::warn!(projector = %self.name, error = %e, "could not remove a framebuffer");
            }
        }
        for db in self.buffers.drain(..) {
            if let Err(e) = self.card.destroy_dumb_buffer(db) {
                tracing::warn!(projector = %self.name, error = %e, "could not free a scanout buffer");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::projector::kms::mode::cvt_reduced_blanking;
    use crate::traits::{Checker, Level};
    use std::num::NonZeroU32;

    #[test]
    fn forced_mode_reads_back_through_drm_rs() {
        let t = cvt_reduced_blanking(1280, 800, 60.0).unwrap();
        let m = drm_mode(&t);
        assert_eq!(m.clock(), 71_000);
        assert_eq!(m.size(), (1280, 800));
        assert_eq!(m.hsync(), (1328, 1360, 1440));
        assert_eq!(m.vsync(), (803, 809, 823));
        assert_eq!((m.hskew(), m.vscan()), (0, 0));
        assert_eq!(m.vrefresh(), 60);
        assert_eq!(m.flags(), ModeFlags::PHSYNC | ModeFlags::NVSYNC);
        assert_eq!(m.mode_type(), ModeTypeFlags::USERDEF);
        assert_eq!(m.name().to_str().unwrap(), "1280x800");
        assert_eq!(timing_of(&m), t);
        assert!(!listed_mode(&m).preferred);
    }

    #[test]
    fn config_defaults_match_the_documented_ones() {
        let c = DrmConfig::new("/dev/dri/card0");
        assert_eq!(c.card, PathBuf::from("/dev/dri/card0"));
        assert_eq!(c.connector, None);
        assert_eq!(c.mode, None);
        assert_eq!(c.latency, Duration::from_millis(100));
        assert_eq!(c.gamma, 2.2);
        assert_eq!(c.flip_timeout, Duration::from_secs(1));
    }

    #[test]
    fn bad_gamma_is_refused_before_touching_the_card() {
        let mut c = DrmConfig::new("/nonexistent/card9");
        c.gamma = 0.0;
        let err = DrmProjector::open(c).err().expect("refused").to_string();
        assert!(err.contains("/nonexistent/card9"), "{err}");
        assert!(err.contains("gamma 0"), "{err}");
    }

    #[test]
    fn missing_card_is_an_io_error_naming_it() {
        let err = DrmProjector::open(DrmConfig::new("/nonexistent/card9"))
            .err()
            .expect("refused")
            .to_string();
        assert!(err.contains("/nonexistent/card9"), "{err}");
        assert!(err.contains("opening the DRM card"), "{err}");
    }

    /// The cards with a connected output, with their listings.
    fn cards_with_outputs() -> Vec<(PathBuf, Vec<ConnectorInfo>)> {
        let Ok(dir) = std::fs::read_dir("/dev/dri") else {
            return Vec::new();
        };
        let mut cards: Vec<PathBuf> = dir
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("card"))
            })
            .collect();
        cards.sort();
        cards
            .into_iter()
            .filter_map(|c| {
                let list = list_connectors(&c).ok()?;
                list.iter().any(|i| i.connected).then_some((c, list))
            })
            .collect()
    }

    /// Runs where a DRM device with a connected output exists: lists it
    /// and checks the listing. Showing patterns takes the output over, so
    /// that part also needs `MATSCAN_TEST_KMS_OUTPUT=<card>:<connector>`
    /// (e.g. `/dev/dri/card0:HDMI-A-1`) naming an output that may go dark.
    #[test]
    fn real_output_lists_and_shows_patterns() {
        let cards = cards_with_outputs();
        if cards.is_empty() {
            println!("skipped: no DRM device with a connected output");
            return;
        }
        for (card, list) in &cards {
            for c in list {
                println!("{}: {}", card.display(), c.describe());
                assert!(c.name.contains('-'), "kernel connector name {}", c.name);
                for m in &c.modes {
                    assert!(m.timing.htotal > m.timing.hdisplay);
                    assert!(m.timing.refresh_hz() > 1.0);
                }
            }
        }
        let Ok(target) = std::env::var("MATSCAN_TEST_KMS_OUTPUT") else {
            println!("skipped showing: set MATSCAN_TEST_KMS_OUTPUT=/dev/dri/cardN:CONNECTOR");
            return;
        };
        let (card, conn) = target
            .rsplit_once(':')
            .expect("MATSCAN_TEST_KMS_OUTPUT is CARD:CONNECTOR");
        let mut config = DrmConfig::new(card);
        config.connector = Some(conn.to_string());
        let mut p = DrmProjector::open(config).expect("open the output");
        assert_eq!(p.id(), target);
        let (w, h) = p.resolution();
        assert!(w > 0 && h > 0);
        assert_eq!(p.pattern(), ProjectorPattern::Black);
        let checker = ProjectorPattern::Checker(Checker {
            period_px: NonZeroU32::new(64).unwrap(),
            phase_px: [0, 0],
            low: Level::ZERO,
            high: Level::FULL,
        });
        let t = Instant::now();
        p.show(checker).expect("flip to the checker");
        // At least the latency; at most latency + a few frames.
        assert!(
            t.elapsed() >= Duration::from_millis(100),
            "{:?}",
            t.elapsed()
        );
        assert!(
            t.elapsed() < Duration::from_millis(400),
            "{:?}",
            t.elapsed()
        );
        assert_eq!(p.pattern(), checker);
        p.show(ProjectorPattern::Uniform(Level::FULL))
            .expect("flip to white");
        p.show(ProjectorPattern::Black).expect("flip to black");
        assert_eq!(p.pattern(), ProjectorPattern::Black);
    }
}
