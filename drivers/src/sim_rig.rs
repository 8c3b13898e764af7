//! The simulated rig: every driver trait backed by the renderer and a
//! scene, for the daemon's end-to-end tests and demos without hardware.
//!
//! It is a state machine: the light controller is the real host protocol
//! talking to the simulated board (`crate::lights::board`) over an
//! in-memory line, the projector and the turntable set shared state, and
//! [`SimCamera::capture`] renders exactly what the board's outputs, the
//! projector's pattern and the position are at that moment. A sequencer
//! that forgets to switch a flash on gets a photo without it. Faults are
//! injected through [`SimFaults`]: the camera lost after N frames, the
//! board going silent (serial timeouts), a flash that acknowledges but does
//! not fire, a full disk ([`SimDisk`]).
//!
//! Light adds linearly, so the camera renders each emitter's light alone
//! at full power and sums what is on at the moment of capture. One path
//! tracing pass renders the environment and several emitters at once
//! (`Renderer::render_position`), as `matscan simulate` renders a
//! position's captures: the camera keeps a position's per-emitter images
//! ([`PhotoCache`]) and renders, on a miss, every rig light and every
//! projector pattern an earlier capture showed in one pass. A scan of
//! three positions of seven captures each costs six passes: four at the
//! first position (its lights, then each new pattern), one at each other.
//!
//! A calibration target (a printed board) takes the object's place while
//! [`SimHand`], the simulated operator, holds it up: the camera then
//! renders the board's scene under the same rig, and a new placement
//! starts a new cache, prefetching the patterns the hand says the next
//! photos will show (a Gray-code sequence renders in one pass).
//!
//! Boundaries: renders through `matscan_sim::render` only; writes nothing
//! but what [`SimDisk`] is asked to.

use crate::error::DriverError;
use crate::lights::{
    memory_pair, Board, BoardConfig, BoardFaults, HostConfig, Port, RunningBoard, SerialLights,
};
use crate::traits::{
    monotonic_now, Camera, CameraSettings, GrayCode, LightController, LightId, LightState,
    Positioner, Press, Projector, ProjectorPattern, TargetHand, TargetPlacement, Trigger,
};
use matscan_scan::raster::RgbRaster;
use matscan_scan::white_bundle::WhiteCard;
use matscan_sim::calib_target::{BoardHolder, INNER_CORNERS};
use matscan_sim::render::{CaptureSpec, RenderOptions, Renderer};
use matscan_sim::scene::Scene;
use matscan_sim::sphere_target::SphereHolder;
use matscan_sim::white_target::{empty_mount_scene, white_card_scene, CARD_ALBEDO, CARD_ROUGHNESS};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

/// Device names of the simulated parts, as they appear in errors.
pub const CAMERA_ID: &str = "sim:camera";
pub const LIGHTS_ID: &str = "sim:lights";
pub const PROJECTOR_ID: &str = "sim:projector";
pub const POSITIONER_ID: &str = "sim:turntable";
pub const TRIGGER_ID: &str = "sim:footswitch";
pub const HAND_ID: &str = "sim:operator";

/// Faults to inject.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SimFaults {
    /// The camera fails every capture after this many frames.
    pub camera_lost_after: Option<u64>,
    /// The light controller's faults: `silent_after` gives serial
    /// timeouts, `dead_lights` flashes that acknowledge but do not fire,
    /// `reset_on` board resets.
    pub board: BoardFaults,
    /// Bytes [`SimDisk`] accepts before reporting a full disk.
    pub disk_capacity: Option<u64>,
}

/// How the simulated rig renders.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Photo size; the scene's intrinsics are scaled to it (the field of
    /// view is kept).
    pub width: u32,
    pub height: u32,
    /// Paths per pixel.
    pub samples: u32,
    pub seed: u64,
    /// Clip photos at 1.0, as a sensor saturates.
    pub saturate: bool,
    /// Light-controller timing (short timeouts keep fault tests quick).
    pub host: HostConfig,
    pub faults: SimFaults,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            width: 64,
            height: 64,
            samples: 4,
            seed: 0,
            saturate: true,
            host: HostConfig {
                reply_timeout: Duration::from_millis(100),
                attempts: 2,
                ..HostConfig::default()
            },
            faults: SimFaults::default(),
        }
    }
}

/// What the projector, the turntable and the operator are doing.
#[derive(Debug)]
struct Stage {
    pattern: ProjectorPattern,
    position: usize,
    /// The calibration target in the object's place, if one is held up.
    target: Option<Arc<Scene>>,
    /// Counts target moves: a photo cache of another placement is stale.
    placement: u64,
    /// The patterns the next photos of this placement will show.
    prefetch: Vec<ProjectorPattern>,
}

/// The parts of a simulated rig, each usable on its own.
pub struct SimulatedRig {
    pub camera: SimCamera,
    pub lights: SimLights,
    pub projector: SimProjector,
    pub positioner: SimPositioner,
    pub trigger: SimTrigger,
    /// Presses the footswitch.
    pub footswitch: FootswitchButton,
    pub disk: SimDisk,
    pub hand: SimHand,
}

impl SimulatedRig {
    /// Powers the rig up: the board boots and the lights connect to it.
    pub fn new(scene: Scene, config: SimConfig) -> Result<SimulatedRig, DriverError> {
        let (host_end, board_end) = memory_pair(LIGHTS_ID, "sim:board");
        let bench = SimBench::new(scene, config.clone(), Box::new(board_end))?;
        let lights = SerialLights::connect(Box::new(host_end), config.host.clone())?;
        Ok(SimulatedRig {
            camera: bench.camera,
            lights: SimLights {
                host: lights,
                board: bench.board,
            },
            projector: bench.projector,
            positioner: bench.positioner,
            trigger: bench.trigger,
            footswitch: bench.footswitch,
            disk: bench.disk,
            hand: bench.hand,
        })
    }
}

/// The simulated rig without its light-controller host: the board serves
/// whatever port it is given (a pseudo-terminal's master end, say) so that
/// the real serial driver can open the other end by its path, as on the
/// scanner PC, while the camera still renders what the board's outputs are.
pub struct SimBench {
    pub camera: SimCamera,
    pub projector: SimProjector,
    pub positioner: SimPositioner,
    pub trigger: SimTrigger,
    pub footswitch: FootswitchButton,
    pub disk: SimDisk,
    pub hand: SimHand,
    /// The simulated light controller serving `board_port`.
    pub board: RunningBoard,
}

impl SimBench {
    /// Boots the board on `board_port` and builds the other parts.
    pub fn new(
        scene: Scene,
        config: SimConfig,
        board_port: Box<dyn Port>,
    ) -> Result<SimBench, DriverError> {
        let scene = Arc::new(scaled(scene, config.width, config.height));
        if scene.rig.positions.is_empty() {
            return Err(DriverError::NoSuchPosition {
                device: POSITIONER_ID.to_string(),
                index: 0,
                count: 0,
            });
        }
        let stage = Arc::new(Mutex::new(Stage {
            pattern: ProjectorPattern::Black,
            position: 0,
            target: None,
            placement: 0,
            prefetch: Vec::new(),
        }));
        let board = RunningBoard::spawn(
            board_port,
            Board::new(BoardConfig::default(), config.faults.board.clone()),
        );
        let exposure = scene.rig.positions[0].exposure_s;
        let settings = CameraSettings::new(exposure, 1.0, 5000).unwrap_or_default();
        let (tx, rx) = channel();
        Ok(SimBench {
            camera: SimCamera {
                scene: scene.clone(),
                stage: stage.clone(),
                board: board.shared(),
                config: config.clone(),
                settings,
                frames: 0,
                exposure: 0,
                cache: None,
                patterns_seen: Vec::new(),
            },
            projector: SimProjector {
                scene: scene.clone(),
                stage: stage.clone(),
            },
            hand: SimHand {
                holder: BoardHolder::new(&scene.rig, INNER_CORNERS, config.seed),
                sphere: SphereHolder::new(&scene.rig, config.seed),
                stage: stage.clone(),
            },
            positioner: SimPositioner { scene, stage },
            trigger: SimTrigger { presses: rx },
            footswitch: FootswitchButton { tx },
            disk: SimDisk {
                capacity: config.faults.disk_capacity,
                used: AtomicU64::new(0),
            },
            board,
        })
    }
}

/// The scene with its camera intrinsics scaled to `width` x `height`.
fn scaled(mut scene: Scene, width: u32, height: u32) -> Scene {
    scene.rig.intrinsics = scene.rig.intrinsics.scaled_to(width, height);
    scene
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // Every update under these locks is a single assignment, so a panic
    // elsewhere cannot leave them half-written.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// The camera: renders the rig's state at the moment of capture.
pub struct SimCamera {
    scene: Arc<Scene>,
    stage: Arc<Mutex<Stage>>,
    board: Arc<Mutex<Board>>,
    config: SimConfig,
    settings: CameraSettings,
    frames: u64,
    /// Which noise the renders draw: a repeated exposure of an unchanged
    /// scene is a fresh render, as a real sensor's frames are fresh noise.
    exposure: u64,
    cache: Option<PhotoCache>,
    /// Every projector pattern a capture has shown, so that the next
    /// position renders them in its first pass.
    patterns_seen: Vec<ProjectorPattern>,
}

/// One position's light, per emitter at full power, exposure-scaled as the
/// renderer returns it.
struct PhotoCache {
    position: usize,
    placement: u64,
    ambient: RgbRaster,
    emitters: Vec<(Emitter, RgbRaster)>,
}

impl PhotoCache {
    /// The light of `emitter` alone, where it was rendered.
    fn get(&self, emitter: Emitter) -> Option<&RgbRaster> {
        self.emitters
            .iter()
            .find(|(e, _)| *e == emitter)
            .map(|(_, r)| r)
    }
}

/// An emitter the camera renders alone.
#[derive(Clone, Copy, PartialEq)]
enum Emitter {
    Light(LightId),
    Projector(ProjectorPattern),
}

impl SimCamera {
    /// What the lights and projector emit now: each emitter that is on,
    /// with the fraction of full power it emits (a projector pattern
    /// carries its own levels, so it counts once).
    fn lit_terms(&self, position: usize) -> Vec<(Emitter, f32)> {
        let (board, pattern) = (lock(&self.board), lock(&self.stage).pattern);
        let mut terms: Vec<(Emitter, f32)> = self
            .lights_of(position)
            .into_iter()
            .map(|light| (Emitter::Light(light), board.output(light) as f32 / 255.0))
            .filter(|(_, level)| *level > 0.0)
            .collect();
        if pattern != ProjectorPattern::Black {
            terms.push((Emitter::Projector(pattern), 1.0));
        }
        terms
    }

    /// The controller's lights the rig has at `position`.
    fn lights_of(&self, position: usize) -> Vec<LightId> {
        let rig = &self.scene.rig.positions[position];
        LightId::ALL
            .into_iter()
            .filter(|light| match light {
                LightId::Backlight => rig.backlight.name == light.name(),
                _ => rig.flashes.iter().any(|f| f.name == light.name()),
            })
            .collect()
    }

    /// The per-emitter images of `position`, rendering what `terms` need
    /// and the cache lacks: a new position gets the environment, every
    /// light and every pattern an earlier capture showed in one pass; a
    /// pattern new at this position is rendered alone, over the position's
    /// environment image already kept.
    fn emitter_images(
        &mut self,
        position: usize,
        terms: &[(Emitter, f32)],
    ) -> Result<&PhotoCache, DriverError> {
        for (e, _) in terms {
            if let Emitter::Projector(p) = e {
                if !self.patterns_seen.contains(p) {
                    self.patterns_seen.push(*p);
                }
            }
        }
        let (placement, target, prefetch) = {
            let stage = lock(&self.stage);
            (
                stage.placement,
                stage.target.is_some(),
                stage.prefetch.clone(),
            )
        };
        let kept = self
            .cache
            .take()
            .filter(|c| c.position == position && c.placement == placement);
        // A target's photos show the patterns its placement announced; a
        // scan's show again what earlier positions showed.
        let ahead = if target {
            prefetch
        } else {
            self.patterns_seen.clone()
        };
        let wanted: Vec<Emitter> = match &kept {
            Some(c) => terms
                .iter()
                .map(|(e, _)| *e)
                .filter(|e| c.get(*e).is_none())
                .collect(),
            None => self
                .lights_of(position)
                .into_iter()
                .map(Emitter::Light)
                .chain(ahead.iter().map(|p| Emitter::Projector(*p)))
                .chain(terms.iter().map(|(e, _)| *e).filter(|e| match e {
                    Emitter::Projector(p) => !ahead.contains(p),
                    Emitter::Light(_) => false,
                }))
                .collect(),
        };
        let cache = match kept {
            Some(c) if wanted.is_empty() => c,
            kept => {
                let images = self.render(position, &wanted)?;
                let mut cache = kept.unwrap_or(PhotoCache {
                    position,
                    placement,
                    ambient: images.ambient,
                    emitters: Vec::new(),
                });
                cache
                    .emitters
                    .extend(wanted.into_iter().zip(images.light_only));
                cache
            }
        };
        Ok(self.cache.insert(cache))
    }

    /// One pass at `position`: the environment and each of `emitters`
    /// alone at full power.
    fn render(
        &self,
        position: usize,
        emitters: &[Emitter],
    ) -> Result<matscan_sim::render::PositionImages, DriverError> {
        let projector = &self.scene.rig.positions[position].projector.name;
        let specs: Vec<CaptureSpec> = emitters
            .iter()
            .map(|e| match e {
                Emitter::Light(l) => CaptureSpec::new(l.name(), &[l.name()], None),
                Emitter::Projector(p) => {
                    CaptureSpec::new(projector, &[projector.as_str()], Some(p.to_pattern()))
                }
            })
            .collect();
        let render_err = |e: matscan_sim::render::SimError| DriverError::Render {
            device: CAMERA_ID.to_string(),
            reason: e.to_string(),
        };
        let scene = lock(&self.stage).target.clone();
        let scene = scene.as_deref().unwrap_or(&self.scene);
        let renderer = Renderer::new(scene).map_err(render_err)?;
        let opts = RenderOptions {
            samples: self.config.samples.max(1),
            // A prime step keeps each exposure's noise apart from the
            // seeds other configurations use.
            seed: self
                .config
                .seed
                .wrapping_add(self.exposure.wrapping_mul(1_000_003)),
            ..RenderOptions::default()
        };
        renderer
            .render_position(position, &specs, &opts)
            .map_err(render_err)
    }
}

impl Camera for SimCamera {
    fn id(&self) -> &str {
        CAMERA_ID
    }

    fn resolution(&self) -> (u32, u32) {
        (
            self.scene.rig.intrinsics.width,
            self.scene.rig.intrinsics.height,
        )
    }

    fn lock(&mut self, settings: CameraSettings) -> Result<(), DriverError> {
        self.settings = settings;
        Ok(())
    }

    fn settings(&self) -> CameraSettings {
        self.settings
    }

    /// Renders are exact snapshots of the state, so nothing is ever stale.
    fn scene_changed(&mut self, _at: Duration) {}

    /// The first frame as [`Camera::capture`] gives it; each further one
    /// rendered afresh with its own noise. The renders of the first stay
    /// what later captures at this placement see.
    fn capture_mean(&mut self, frames: usize) -> Result<crate::Frame, DriverError> {
        let first = self.capture()?;
        let kept = self.cache.take();
        let rgb = first.rgb.mean_with(frames.saturating_sub(1), |k| {
            self.exposure = k as u64;
            self.cache = None;
            self.capture().map(|f| f.rgb)
        });
        self.exposure = 0;
        self.cache = kept;
        Ok(crate::Frame { rgb: rgb?, ..first })
    }

    fn capture(&mut self) -> Result<crate::Frame, DriverError> {
        if let Some(n) = self.config.faults.camera_lost_after {
            if self.frames >= n {
                return Err(DriverError::CameraLost {
                    device: CAMERA_ID.to_string(),
                    frames: self.frames,
                    reason: "injected fault: the camera was unplugged".to_string(),
                });
            }
        }
        let position = lock(&self.stage).position;
        let terms = self.lit_terms(position);
        let rig_exposure = self.scene.rig.positions[position].exposure_s;
        let rig_exposure = if rig_exposure.is_finite() && rig_exposure > 0.0 {
            rig_exposure
        } else {
            1.0
        };
        let scale = self.settings.exposure_s() * self.settings.gain() / rig_exposure;
        let images = self.emitter_images(position, &terms)?;
        let mut rgb: RgbRaster = images.ambient.clone();
        for (emitter, level) in &terms {
            // Every term is in the cache `emitter_images` returned.
            let Some(light) = images.get(*emitter) else {
                continue;
            };
            rgb.add_scaled(light, *level);
        }
        for p in rgb.data.iter_mut() {
            for v in p.iter_mut() {
                let x = *v * scale;
                let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
                *v = if self.config.saturate { x.min(1.0) } else { x };
            }
        }
        self.frames += 1;
        Ok(crate::Frame {
            rgb,
            timestamp: monotonic_now(),
            exposure_s: self.settings.exposure_s(),
            gain: self.settings.gain(),
            sequence: self.frames,
        })
    }
}

/// The light controller: the real host protocol against the simulated
/// board.
pub struct SimLights {
    // Dropped first: the host says ALLOFF while the board still runs.
    host: SerialLights,
    board: RunningBoard,
}

impl SimLights {
    /// The board's state (what each light really emits, resets, ...).
    pub fn board(&self) -> MutexGuard<'_, Board> {
        self.board.board()
    }
}

impl LightController for SimLights {
    fn id(&self) -> &str {
        self.host.id()
    }

    fn set(&mut self, light: LightId, state: LightState) -> Result<(), DriverError> {
        self.host.set(light, state)
    }

    fn all_off(&mut self) -> Result<(), DriverError> {
        self.host.all_off()
    }

    fn state(&self, light: LightId) -> LightState {
        self.host.state(light)
    }
}

/// The projector: its pattern is what the camera renders.
pub struct SimProjector {
    scene: Arc<Scene>,
    stage: Arc<Mutex<Stage>>,
}

impl Projector for SimProjector {
    fn id(&self) -> &str {
        PROJECTOR_ID
    }

    fn resolution(&self) -> (u32, u32) {
        let position = lock(&self.stage).position;
        let k = &self.scene.rig.positions[position].projector.intrinsics;
        (k.width, k.height)
    }

    fn show(&mut self, pattern: ProjectorPattern) -> Result<(), DriverError> {
        lock(&self.stage).pattern = pattern;
        Ok(())
    }

    fn pattern(&self) -> ProjectorPattern {
        lock(&self.stage).pattern
    }
}

/// The simulated operator: holds a printed board up in the object's place
/// ([`BoardHolder`] picks the poses), or the light-calibration sphere
/// ([`SphereHolder`]), or the white card on the board's mount, as a person
/// does for a calibration.
pub struct SimHand {
    holder: BoardHolder,
    sphere: SphereHolder,
    stage: Arc<Mutex<Stage>>,
}

impl SimHand {
    /// The board the operator holds.
    pub fn board(&self) -> &matscan_scan::calib_bundle::Chessboard {
        self.holder.board()
    }

    /// Where the board stands at its reference placement, board to world.
    pub fn reference_to_world(&self) -> glam::DMat4 {
        self.holder.reference_to_world()
    }

    /// The light-calibration sphere's radius, metres.
    pub fn sphere_radius(&self) -> f64 {
        self.sphere.radius()
    }
}

impl TargetHand for SimHand {
    fn id(&self) -> &str {
        HAND_ID
    }

    fn place(&mut self, position: usize, placement: TargetPlacement) -> Result<(), DriverError> {
        let scene = match placement {
            TargetPlacement::Reference => Ok(self.holder.reference()),
            TargetPlacement::Seat => self.holder.on_seat(),
            TargetPlacement::HandHeld => self.holder.hand_held(position, false),
            TargetPlacement::InProjectorView => self.holder.hand_held(position, true),
            TargetPlacement::Sphere => self.sphere.place(position),
            TargetPlacement::WhiteCard => Ok(white_card_scene(
                &WhiteCard::on_board(
                    self.holder.board(),
                    self.holder.reference_to_world(),
                    CARD_ALBEDO,
                    CARD_ROUGHNESS,
                ),
                self.holder.rig(),
            )),
            TargetPlacement::EmptyMount => Ok(empty_mount_scene(self.holder.rig(), position)),
        }
        .map_err(|e| DriverError::InvalidSetting {
            device: HAND_ID.to_string(),
            reason: e.to_string(),
        })?;
        // `hand_held` found the position, and the reference needs none.
        let prefetch = match (placement, scene.rig.positions.get(position)) {
            (TargetPlacement::InProjectorView, Some(at)) => {
                let k = &at.projector.intrinsics;
                GrayCode::sequence(k.width, k.height)
                    .into_iter()
                    .map(ProjectorPattern::GrayCode)
                    .collect()
            }
            // The sphere's and the card's photos show the projector's
            // white field.
            (TargetPlacement::Sphere | TargetPlacement::WhiteCard, _) => {
                vec![ProjectorPattern::Uniform(crate::Level::FULL)]
            }
            _ => Vec::new(),
        };
        let mut stage = lock(&self.stage);
        stage.prefetch = prefetch;
        stage.target = Some(Arc::new(scene));
        stage.placement += 1;
        Ok(())
    }

    fn remove(&mut self) {
        let mut stage = lock(&self.stage);
        if stage.target.take().is_some() {
            stage.placement += 1;
            stage.prefetch.clear();
        }
    }
}

/// The turntable: steps through the scene's rig positions.
pub struct SimPositioner {
    scene: Arc<Scene>,
    stage: Arc<Mutex<Stage>>,
}

impl Positioner for SimPositioner {
    fn id(&self) -> &str {
        POSITIONER_ID
    }

    fn count(&self) -> usize {
        self.scene.rig.positions.len()
    }

    fn position(&self) -> usize {
        lock(&self.stage).position
    }

    fn advance(&mut self) -> Result<usize, DriverError> {
        let count = self.count();
        let mut stage = lock(&self.stage);
        stage.position = (stage.position + 1) % count;
        Ok(stage.position)
    }
}

/// The footswitch: presses come from a [`FootswitchButton`].
pub struct SimTrigger {
    presses: Receiver<Press>,
}

/// Presses the simulated footswitch (from a test or a demo's keyboard).
#[derive(Clone)]
pub struct FootswitchButton {
    tx: Sender<Press>,
}

impl FootswitchButton {
    pub fn press(&self) {
        // The trigger may be gone (the sequencer finished): nobody to tell.
        let _ = self.tx.send(Press {
            timestamp: monotonic_now(),
        });
    }
}

impl Trigger for SimTrigger {
    fn id(&self) -> &str {
        TRIGGER_ID
    }

    fn wait(&mut self, timeout: Duration) -> Result<Option<Press>, DriverError> {
        match self.presses.recv_timeout(timeout) {
            Ok(p) => Ok(Some(p)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(DriverError::Disconnected {
                device: TRIGGER_ID.to_string(),
                waited: timeout,
            }),
        }
    }
}

/// The disk the sequencer writes scans to, with a capacity for the
/// full-disk fault.
#[derive(Debug)]
pub struct SimDisk {
    capacity: Option<u64>,
    used: AtomicU64,
}

impl SimDisk {
    /// Claims `bytes` for `path`; fails as a full disk would once the
    /// capacity is used up.
    pub fn reserve(&self, path: &Path, bytes: u64) -> Result<(), DriverError> {
        let used = self.used.fetch_add(bytes, Ordering::SeqCst);
        match self.capacity {
            Some(cap) if used.saturating_add(bytes) > cap => {
                self.used.fetch_sub(bytes, Ordering::SeqCst);
                Err(DriverError::DiskFull {
                    path: path.to_path_buf(),
                    written: cap.saturating_sub(used),
                    wanted: bytes,
                })
            }
            _ => Ok(()),
        }
    }

    /// Writes `bytes` to `path` if the disk has room.
    pub fn write(&self, path: &Path, bytes: &[u8]) -> Result<(), DriverError> {
        self.reserve(path, bytes.len() as u64)?;
        std::fs::write(path, bytes).map_err(|e| {
            self.used.fetch_sub(bytes.len() as u64, Ordering::SeqCst);
            DriverError::io(&path.display().to_string(), "writing", e)
        })
    }

    /// Bytes written so far.
    pub fn used(&self) -> u64 {
        self.used.load(Ordering::SeqCst)
    }
}

#[cfg(test)]
mod tests;
