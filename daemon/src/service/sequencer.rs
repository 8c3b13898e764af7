//! The capture sequencer: carries out a [`CapturePlan`] on the rig's
//! drivers and writes the scan bundle.
//!
//! Per position: lock the exposure, take ambient, then each light alone
//! (flashes, the projector's grey image, the backlight, the checkerboards);
//! every lit photo must differ from ambient, else it is retried and then
//! fails naming the light. Between positions the positioner turns the
//! object or, without one, the sequencer waits for the operator's press.
//! The bundle is built in a hidden temporary folder in the scans folder and
//! renamed into place only when complete (`BundleWriter`), so an error or a
//! cancellation leaves nothing that looks like a scan.
//!
//! Boundaries: knows the driver traits and the bundle writer; where the
//! geometry and calibration come from is the caller's ([`RigGeometry`]).

use super::plan::{checker_of, Capabilities, CapturePlan, Step};
use matscan_drivers::{
    monotonic_now, Camera, CameraSettings, DriverError, LightController, LightId, Positioner,
    Projector, ProjectorPattern, TargetHand, Trigger,
};
use matscan_scan::bundle::BundleWriter;
use matscan_scan::raster::RgbRaster;
use matscan_scan::{Capture, Intrinsics, Light, Manifest, Mesh, Position, Precision, ScanError};
use std::num::NonZeroU32;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The known geometry and calibration of the rig and the object.
#[derive(Debug, Clone)]
pub struct RigGeometry {
    /// Names the scans (`<name>` in the manifest).
    pub name: String,
    pub mesh: Mesh,
    pub intrinsics: Intrinsics,
    pub positions: Vec<PositionPose>,
    /// Small and large checkerboard periods, projector pixels.
    pub checker_periods: (NonZeroU32, NonZeroU32),
}

#[derive(Debug, Clone)]
pub struct PositionPose {
    pub name: String,
    pub camera_to_world: glam::DMat4,
    /// Every rig light in world space at this position (manifest form).
    pub lights: Vec<Light>,
    pub exposure_s: f32,
}

/// Accounts for the bytes a scan writes (a disk quota; the simulated rig's
/// full-disk fault).
pub trait DiskQuota {
    fn reserve(&self, path: &Path, bytes: u64) -> Result<(), DriverError>;
}

impl DiskQuota for matscan_drivers::sim_rig::SimDisk {
    fn reserve(&self, path: &Path, bytes: u64) -> Result<(), DriverError> {
        matscan_drivers::sim_rig::SimDisk::reserve(self, path, bytes)
    }
}

/// Ground truth a rig knows about its object (only a simulated one does):
/// written into each position of the scan so that the estimate reports its
/// error.
pub trait TruthSource {
    /// Writes position `index`'s truth maps (named `position`) into the
    /// scan being written.
    fn write(&self, writer: &BundleWriter, index: usize, position: &str) -> Result<(), String>;
    /// The rig as it really is (a rig calibration file), written beside a
    /// calibration's photos so that the calibration can be checked.
    fn rig(&self) -> Option<Manifest> {
        None
    }
}

/// The rig's devices and what is known about them.
pub struct RigDevices {
    pub camera: Box<dyn Camera>,
    pub lights: Box<dyn LightController>,
    /// `None`: a rig without projector (the plan then takes no projector
    /// photo, see [`RigDevices::capabilities`]).
    pub projector: Option<Box<dyn Projector>>,
    /// `None`: the operator moves the object and presses `trigger`.
    pub positioner: Option<Box<dyn Positioner>>,
    pub trigger: Option<Box<dyn Trigger>>,
    pub disk: Option<Box<dyn DiskQuota>>,
    pub geometry: RigGeometry,
    /// `Some` for the simulated rig.
    pub truth: Option<Box<dyn TruthSource>>,
    /// Where the object's mesh is re-read before every capture (the 3D
    /// scanner's export path on a real rig); `None`: the geometry's mesh is
    /// fixed (the simulated rig's scene).
    pub mesh_source: Option<PathBuf>,
    /// The printed board calibrations photograph; `None`: not configured,
    /// and a calibration capture says so.
    pub calibration_target: Option<CalibrationTarget>,
    /// Places the board without a person (the simulated rig); `None`: the
    /// operator is prompted and presses the footswitch.
    pub hand: Option<Box<dyn TargetHand>>,
    /// The light-calibration sphere's radius, metres; `None`: not
    /// configured, and a sphere capture says so.
    pub sphere_radius: Option<f64>,
}

#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    #[error("writing the simulated truth of position {position}: {message}")]
    Truth { position: String, message: String },
    #[error("{0}")]
    Driver(#[from] DriverError),
    #[error("writing the scan: {0}")]
    Scan(#[from] ScanError),
    #[error(
        "{device}: light `{light}` did not fire for capture `{capture}` at position \
         {position} ({attempts} attempts; the photo differs from ambient by {difference:.2e}, \
         expected at least {threshold:.2e})"
    )]
    LightDidNotFire {
        device: String,
        light: String,
        capture: String,
        position: String,
        attempts: u32,
        difference: f32,
        threshold: f32,
    },
    #[error("{device}: no press within {waited:?} {waiting_for}")]
    OperatorTimeout {
        device: String,
        /// What the press was to say, as "to continue at position p1".
        waiting_for: String,
        waited: Duration,
    },
    #[error("the rig has {positions} positions but neither a positioner nor a trigger to move between them")]
    CannotMove { positions: usize },
    #[error("exposure {exposure_s} s at position {position} is not a valid camera setting")]
    BadExposure { position: String, exposure_s: f32 },
    #[error("the capture was cancelled (the daemon is stopping)")]
    Cancelled,
    #[error("the rig has no footswitch to say when the operator is done: cannot {task}")]
    NoTrigger { task: String },
    #[error(
        "no calibration board is configured: set [calibration] board (inner corners, columns \
         and rows) and square (its edge, metres) in the daemon's configuration"
    )]
    NoCalibrationTarget,
    #[error(
        "no light-calibration sphere is configured: set [calibration] sphere_radius (the \
         glossy sphere's radius, metres) in the daemon's configuration"
    )]
    NoSphere,
    #[error(
        "{device}: a flash's highlight on the sphere clips at position {position} even at \
         1/4096 of the exposure; lower the flashes' power"
    )]
    HighlightClipped { device: String, position: String },
    #[error("{device}: cannot calibrate the projector: {reason}")]
    CannotShowGrayCode { device: String, reason: String },
}

/// Progress of one capture, reported after each photo.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    pub done: usize,
    pub total: usize,
    /// `<position>/<capture>` of the photo just taken.
    pub what: String,
}

/// What a finished capture produced.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureOutcome {
    /// The published scan folder.
    pub scan: PathBuf,
    pub positions: usize,
    pub photos: usize,
    /// Lit photos that had to be retried.
    pub retries: u32,
    pub left_out: Vec<String>,
    pub seconds: f64,
    /// Footswitch presses made while photos were being taken (not counted
    /// as "the object is in place"): the caller decides whether they ask
    /// for another capture.
    pub presses_during: usize,
}

/// Knobs of one capture run.
#[derive(Debug, Clone, Copy)]
pub struct RunSettings {
    pub light_retries: u32,
    pub min_light_difference: f32,
    pub operator_timeout: Duration,
}

/// Reads every press `trigger` already holds (short polls, at most 64) and
/// returns how many there were.
pub fn drain_presses(trigger: &mut dyn Trigger) -> usize {
    let mut n = 0;
    // 1 ms, not zero: some triggers read a zero timeout as "forever".
    while n < 64 && matches!(trigger.wait(Duration::from_millis(1)), Ok(Some(_))) {
        n += 1;
    }
    n
}

/// The name of the side file recording the profile of a capture.
pub const CAPTURE_INFO_FILE: &str = "capture.toml";

impl RigDevices {
    /// Takes every photo of `plan` at every position and publishes the scan
    /// at `target` (which must not exist). `stop` is asked before each photo
    /// and every 200 ms while waiting for the operator (the daemon also
    /// beats its watchdog there); `progress` hears of each photo taken.
    pub fn capture(
        &mut self,
        plan: &CapturePlan,
        profile_info: &str,
        target: &Path,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<CaptureOutcome, CaptureError> {
        let result = self.capture_inner(plan, profile_info, target, settings, stop, progress);
        self.leave_dark("capture");
        result
    }

    /// Every rig light off, the projector black and the target, if a hand
    /// holds one, taken away; after a capture, whatever happened. A
    /// failure here is logged: it must not hide the capture's own error.
    fn leave_dark(&mut self, what: &str) {
        if let Some(hand) = self.hand.as_mut() {
            hand.remove();
        }
        if let Err(e) = self.lights.all_off() {
            tracing::warn!("switching the lights off after the {what}: {e}");
        }
        if let Some(projector) = self.projector.as_mut() {
            if let Err(e) = projector.show(ProjectorPattern::Black) {
                tracing::warn!("blanking the projector after the {what}: {e}");
            }
        }
    }

    /// Every rig light off, the projector black, the turntable home: where
    /// every capture starts.
    fn start_dark(&mut self) -> Result<(), CaptureError> {
        self.lights.all_off()?;
        if let Some(projector) = self.projector.as_mut() {
            projector.show(ProjectorPattern::Black)?;
        }
        self.home()
    }

    /// Locks the camera at `exposure_s` for photos at `position`.
    fn lock_exposure(&mut self, position: &str, exposure_s: f32) -> Result<(), CaptureError> {
        let settings = CameraSettings::new(exposure_s, 1.0, 5000).ok_or_else(|| {
            CaptureError::BadExposure {
                position: position.to_string(),
                exposure_s,
            }
        })?;
        Ok(self.camera.lock(settings)?)
    }

    fn capture_inner(
        &mut self,
        plan: &CapturePlan,
        profile_info: &str,
        target: &Path,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<CaptureOutcome, CaptureError> {
        let start = Instant::now();
        let count = self.geometry.positions.len();
        if count > 1 && self.positioner.is_none() && self.trigger.is_none() {
            return Err(CaptureError::CannotMove { positions: count });
        }
        let writer = BundleWriter::create(target)?;
        self.start_dark()?;
        let total = count * plan.captures.len();
        let mut positions = Vec::with_capacity(count);
        let mut retries = 0;
        let mut presses_during = 0;
        for index in 0..count {
            let geometry = self.geometry.positions[index].clone();
            if index > 0 {
                presses_during += self.next_position(&geometry.name, settings, stop)?;
            }
            self.lock_exposure(&geometry.name, geometry.exposure_s)?;
            let mut captures = Vec::new();
            let mut ambient: Option<RgbRaster> = None;
            for planned in &plan.captures {
                if stop() {
                    return Err(CaptureError::Cancelled);
                }
                let (frame, tries) = self.take(
                    &planned.step,
                    &planned.name,
                    &geometry.name,
                    ambient.as_ref(),
                    settings,
                )?;
                retries += tries;
                let file = writer.write_photo(
                    &geometry.name,
                    &planned.name,
                    &frame.rgb,
                    Precision::Half,
                )?;
                self.account(&writer, &file)?;
                if planned.step == Step::Ambient {
                    ambient = Some(frame.rgb.clone());
                }
                captures.push(self.manifest_capture(&planned.step, &planned.name, file, &frame));
                progress(Progress {
                    done: index * plan.captures.len() + captures.len(),
                    total,
                    what: format!("{}/{}", geometry.name, planned.name),
                });
            }
            if let Some(truth) = &self.truth {
                truth
                    .write(&writer, index, &geometry.name)
                    .map_err(|message| CaptureError::Truth {
                        position: geometry.name.clone(),
                        message,
                    })?;
            }
            positions.push(Position {
                name: geometry.name.clone(),
                camera_to_world: geometry.camera_to_world,
                lights: geometry.lights.clone(),
                captures,
                white_reference_mask: None,
            });
        }
        // Leave the turntable where the next scan starts.
        self.home()?;
        writer.write_mesh(&self.geometry.mesh)?;
        writer.write_file(CAPTURE_INFO_FILE, profile_info.as_bytes())?;
        let manifest = Manifest {
            units: "m".into(),
            name: self.geometry.name.clone(),
            created: matscan_scan::time::rfc3339_now(),
            camera: self.geometry.intrinsics,
            positions,
        };
        let bundle = writer.finish(&manifest)?;
        Ok(CaptureOutcome {
            scan: bundle.root,
            positions: count,
            photos: total,
            retries,
            left_out: plan.left_out.clone(),
            seconds: start.elapsed().as_secs_f64(),
            presses_during,
        })
    }

    /// Turns the positioner back to its first position.
    fn home(&mut self) -> Result<(), CaptureError> {
        if let Some(p) = self.positioner.as_mut() {
            for _ in 0..p.count() {
                if p.position() == 0 {
                    break;
                }
                p.advance()?;
            }
        }
        Ok(())
    }

    /// Moves to the next position: turns the positioner, or waits for the
    /// operator's press ([`RigDevices::wait_for_press`]).
    fn next_position(
        &mut self,
        name: &str,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
    ) -> Result<usize, CaptureError> {
        if let Some(p) = self.positioner.as_mut() {
            p.advance()?;
            self.camera.scene_changed(monotonic_now());
            return Ok(0);
        }
        if self.trigger.is_none() {
            return Err(CaptureError::CannotMove {
                positions: self.geometry.positions.len(),
            });
        }
        self.wait_for_press(
            &format!("move the object to {name}"),
            &format!("to continue at position {name}"),
            settings,
            stop,
        )
    }

    /// Waits for the operator to do `task` and press. Presses already
    /// waiting when the wait begins were made while photos were being
    /// taken, before the operator could have done it: they do not count
    /// (else the next photos would catch the rig in motion) and are
    /// returned as a count. An unplugged footswitch is waited for until the
    /// operator timeout; `waiting_for` ends that error's message.
    fn wait_for_press(
        &mut self,
        task: &str,
        waiting_for: &str,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
    ) -> Result<usize, CaptureError> {
        let Some(trigger) = self.trigger.as_mut() else {
            return Err(CaptureError::NoTrigger {
                task: task.to_string(),
            });
        };
        let early = drain_presses(trigger.as_mut());
        if early > 0 {
            tracing::info!(
                "{}: {early} press(es) during the photos ignored: {task}, then press again",
                trigger.id()
            );
        }
        tracing::info!("waiting for the operator to {task} and press");
        let deadline = Instant::now() + settings.operator_timeout;
        let mut unplugged: Option<DriverError> = None;
        // Short waits so that a stop request is heard while the operator
        // takes their time.
        loop {
            if stop() {
                return Err(CaptureError::Cancelled);
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                if let Some(DriverError::Disconnected { device, .. }) = unplugged {
                    return Err(CaptureError::Driver(DriverError::Disconnected {
                        device,
                        waited: settings.operator_timeout,
                    }));
                }
                return Err(CaptureError::OperatorTimeout {
                    device: trigger.id().to_string(),
                    waiting_for: waiting_for.to_string(),
                    waited: settings.operator_timeout,
                });
            }
            match trigger.wait(left.min(Duration::from_millis(200))) {
                Ok(Some(_)) => {
                    self.camera.scene_changed(monotonic_now());
                    return Ok(early);
                }
                Ok(None) => unplugged = None,
                Err(e @ DriverError::Disconnected { .. }) => {
                    if unplugged.is_none() {
                        tracing::warn!("{e}; waiting for it to come back");
                    }
                    unplugged = Some(e);
                    // A trigger that fails at once must not spin.
                    std::thread::sleep(left.min(Duration::from_millis(200)));
                }
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Sets the rig up for `step`, takes the photo and switches off again;
    /// retries a lit photo that looks like ambient. Returns the frame and
    /// the number of retries it took.
    fn take(
        &mut self,
        step: &Step,
        capture: &str,
        position: &str,
        ambient: Option<&RgbRaster>,
        settings: &RunSettings,
    ) -> Result<(matscan_drivers::Frame, u32), CaptureError> {
        let attempts = settings.light_retries + 1;
        let mut difference = 0.0;
        for attempt in 0..attempts {
            self.switch(step, true)?;
            let frame = self.camera.capture();
            let off = self.switch(step, false);
            let frame = frame?;
            off?;
            let Some(ambient) = ambient.filter(|_| step.is_lit()) else {
                return Ok((frame, 0));
            };
            difference = mean_abs_difference(&frame.rgb, ambient);
            if difference >= settings.min_light_difference {
                return Ok((frame, attempt));
            }
            tracing::warn!(
                "{position}/{capture}: the photo looks like ambient (difference {difference:.2e}); \
                 attempt {} of {attempts}",
                attempt + 1
            );
        }
        Err(CaptureError::LightDidNotFire {
            device: self.device_of(step),
            light: self.light_name(step),
            capture: capture.to_string(),
            position: position.to_string(),
            attempts,
            difference,
            threshold: settings.min_light_difference,
        })
    }

    fn switch(&mut self, step: &Step, on: bool) -> Result<(), CaptureError> {
        match *step {
            Step::Ambient => {}
            Step::Flash(light) => {
                if on {
                    self.lights.on(light, matscan_drivers::Level::FULL)?
                } else {
                    self.lights.off(light)?
                }
            }
            Step::Backlit => {
                if on {
                    self.lights
                        .on(LightId::Backlight, matscan_drivers::Level::FULL)?
                } else {
                    self.lights.off(LightId::Backlight)?
                }
            }
            Step::ProjectorUniform(level) => self.projector()?.show(if on {
                ProjectorPattern::Uniform(level)
            } else {
                ProjectorPattern::Black
            })?,
            Step::Checker(c) => self.projector()?.show(if on {
                ProjectorPattern::Checker(c)
            } else {
                ProjectorPattern::Black
            })?,
        }
        self.camera.scene_changed(monotonic_now());
        Ok(())
    }

    fn light_name(&self, step: &Step) -> String {
        match step {
            Step::Ambient => String::new(),
            Step::Flash(l) => l.name().to_string(),
            Step::Backlit => LightId::Backlight.name().to_string(),
            Step::ProjectorUniform(_) | Step::Checker(_) => self.projector_name(),
        }
    }

    fn device_of(&self, step: &Step) -> String {
        match step {
            Step::ProjectorUniform(_) | Step::Checker(_) => self
                .projector
                .as_ref()
                .map_or_else(|| "projector".to_string(), |p| p.id().to_string()),
            _ => self.lights.id().to_string(),
        }
    }

    /// The projector, or an error naming the plan's mistake: a plan made
    /// for [`RigDevices::capabilities`] never asks a rig without one.
    fn projector(&mut self) -> Result<&mut Box<dyn Projector>, DriverError> {
        self.projector
            .as_mut()
            .ok_or_else(|| DriverError::InvalidSetting {
                device: "projector".to_string(),
                reason: "this rig has no projector, but the capture plan asks for one".to_string(),
            })
    }

    /// Re-reads the object's mesh from [`RigDevices::mesh_source`], if any: the
    /// scanner software exports each new object there before the press.
    pub fn reload_mesh(&mut self) -> Result<(), ScanError> {
        if let Some(path) = &self.mesh_source {
            self.geometry.mesh = matscan_scan::mesh_io::read_mesh(path)?;
        }
        Ok(())
    }

    /// What the rig can capture: a projector photo needs a projector driver
    /// and a projector among the calibrated lights; a backlit photo needs a
    /// backlight panel among them.
    pub fn capabilities(&self) -> Capabilities {
        let has = |want: fn(&matscan_scan::LightKind) -> bool| {
            self.geometry
                .positions
                .iter()
                .all(|p| p.lights.iter().any(|l| want(&l.kind)))
        };
        let projector = self.projector.is_some()
            && has(|k| matches!(k, matscan_scan::LightKind::Projector { .. }));
        let (small, large) = self.geometry.checker_periods;
        let checkers = projector
            && self.projector.as_ref().is_some_and(|p| {
                [small, large]
                    .into_iter()
                    .all(|period| p.can_show(&ProjectorPattern::Checker(checker_of(period))))
            });
        Capabilities {
            projector,
            checkers,
            backlight: has(|k| matches!(k, matscan_scan::LightKind::Backlight)),
        }
    }

    /// The projector's name among the manifest lights.
    fn projector_name(&self) -> String {
        self.geometry
            .positions
            .first()
            .and_then(|p| {
                p.lights
                    .iter()
                    .find(|l| matches!(l.kind, matscan_scan::LightKind::Projector { .. }))
            })
            .map_or_else(|| "projector".to_string(), |l| l.name.clone())
    }

    fn manifest_capture(
        &self,
        step: &Step,
        name: &str,
        file: PathBuf,
        frame: &matscan_drivers::Frame,
    ) -> Capture {
        let (lights, pattern) = match step {
            Step::Ambient => (vec![], None),
            Step::Flash(_) | Step::Backlit => (vec![self.light_name(step)], None),
            Step::ProjectorUniform(l) => (
                vec![self.projector_name()],
                Some(ProjectorPattern::Uniform(*l).to_pattern()),
            ),
            Step::Checker(c) => (
                vec![self.projector_name()],
                Some(ProjectorPattern::Checker(*c).to_pattern()),
            ),
        };
        Capture {
            name: name.to_string(),
            file,
            exposure_s: frame.exposure_s as f64 * frame.gain as f64,
            lights,
            pattern,
            encoding: None,
        }
    }

    fn account(&self, writer: &BundleWriter, rel: &Path) -> Result<(), CaptureError> {
        if let Some(disk) = &self.disk {
            let path = writer.dir().join(rel);
            let bytes = std::fs::metadata(&path)
                .map_err(|source| ScanError::Io {
                    path: path.clone(),
                    source,
                })?
                .len();
            disk.reserve(&writer.target().join(rel), bytes)?;
        }
        Ok(())
    }
}

/// Mean over pixels and channels of `|a - b|` (0 when sizes differ, which
/// the camera never produces within one scan).
pub fn mean_abs_difference(a: &RgbRaster, b: &RgbRaster) -> f32 {
    if a.data.len() != b.data.len() || a.data.is_empty() {
        return 0.0;
    }
    let sum: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(p, q)| (0..3).map(|c| (p[c] - q[c]).abs() as f64).sum::<f64>())
        .sum();
    let mean = sum / (3 * a.data.len()) as f64;
    if mean.is_finite() {
        mean as f32
    } else {
        0.0
    }
}

pub mod calibration;
pub use calibration::{
    BoardPlan, CalibrationOutcome, CalibrationPlan, CalibrationTarget, SpherePlan, WhitePlan,
};

#[cfg(test)]
mod tests;

/// A test's operator at a rig without turntable: once the first
/// position's photos are taken, turns the object (`turn`), then presses
/// `button` every 50 ms until the capture ends. Presses that land before
/// the sequencer waits are ignored by it, as they must be; the first one
/// after moves it on.
#[cfg(test)]
pub(crate) fn capture_with_operator(
    rig: &mut RigDevices,
    plan: &CapturePlan,
    target: &Path,
    settings: &RunSettings,
    button: matscan_drivers::sim_rig::FootswitchButton,
    turn: impl FnOnce() + Send + 'static,
) -> Result<CaptureOutcome, CaptureError> {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let per_position = plan.captures.len();
    let first_done = Arc::new(AtomicBool::new(false));
    let finished = Arc::new(AtomicBool::new(false));
    let operator = {
        let (first_done, finished) = (first_done.clone(), finished.clone());
        std::thread::spawn(move || {
            let mut turn = Some(turn);
            while !finished.load(Ordering::SeqCst) {
                if first_done.load(Ordering::SeqCst) {
                    if let Some(t) = turn.take() {
                        t();
                    }
                    button.press();
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        })
    };
    let out = rig.capture(plan, "", target, settings, &|| false, &mut |p| {
        if p.done == per_position {
            first_done.store(true, Ordering::SeqCst);
        }
    });
    finished.store(true, Ordering::SeqCst);
    operator.join().expect("the operator thread");
    out
}
