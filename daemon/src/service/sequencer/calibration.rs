//! The calibration capture: photos of a printed board that `matscan calib
//! rig` turns into the rig calibration file, taken by the same sequencer,
//! drivers and operator loop as a scan, and published as a
//! `matscan-calib/1` bundle.
//!
//! Per position (the turntable turns, or the operator moves the camera and
//! presses): the board at its reference placement, on the mount's further
//! seat where the plan asks (the same seat at every position: with the
//! reference it is a target with depth), then at further poses (propped on
//! a stand, or held by hand where a held photo is one frame), each photo
//! under both flashes and the mean of the plan's frames for its placement.
//! At the first position the board then stands where the projector lights
//! it whole, and each such pose is photographed under the flashes and
//! under every Gray-code image
//! of the projector's columns and rows (each bit and its inverse). Before
//! each pose the operator is prompted and the sequencer waits for the
//! footswitch, as between a scan's positions; the simulated rig's
//! operator ([`matscan_drivers::TargetHand`]) places the board itself.
//!
//! The light calibration (a [`CalibrationPlan::Sphere`]) photographs a
//! glossy sphere of known radius at several places before the first
//! position's camera, each place under every light alone (ambient, the
//! backlight for its silhouette, each flash for its highlight), and
//! publishes a `matscan-lights/1` bundle: the flashes ride with the camera,
//! so one position's photos locate them at all.
//!
//! Each bundle is built in a hidden temporary folder and renamed into place
//! only when complete, so an error or a cancellation leaves nothing that
//! looks like a calibration.

use super::{CaptureError, Progress, RigDevices, RunSettings};
use matscan_drivers::{monotonic_now, GrayCode, Level, LightId, ProjectorPattern, TargetPlacement};
use matscan_scan::atomic::{write_atomic, PendingDir};
use matscan_scan::calib_bundle::{
    graycode_file, BoardFrames, BoardPlacement, CalibManifest, CalibPosition, Chessboard,
    ProjectorSize, Shot, CALIB_MANIFEST, SEAT,
};
use matscan_scan::image_io::write_rgb_exr;
use matscan_scan::lights_bundle::{
    light_photo, LightsManifest, Placement, AMBIENT_PHOTO, BACKLIGHT_PHOTO, CLIPPED_LEVEL, FLASHES,
    LIGHTS_MANIFEST, PROJECTOR_PHOTO,
};
use matscan_scan::raster::RgbRaster;
use matscan_scan::white_bundle::{WhiteCard, WhiteManifest, WhitePhoto, WHITE_MANIFEST};
use matscan_scan::Precision;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The printed board and where its reference placement stands in the
/// world (board frame to world).
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationTarget {
    pub board: Chessboard,
    pub reference_to_world: glam::DMat4,
}

/// How many board poses a calibration photographs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoardPlan {
    /// Poses per position, the reference placement included.
    pub shots: usize,
    /// Further poses at the first position with the projector's Gray codes
    /// (0: the projector is not calibrated).
    pub projector_shots: usize,
    /// One more photo per position with the board on the mount's further
    /// seat ([`SEAT`]).
    pub seat: bool,
    /// Frames averaged into each photo of the board, by where it is.
    pub frames: BoardFrames,
}

impl BoardPlan {
    /// Most poses per position or for the projector a request may ask.
    pub const MAX_SHOTS: usize = 64;

    /// The plan, unless there is not even the reference shot, a count
    /// exceeds [`BoardPlan::MAX_SHOTS`], or a frame count is outside 1 to
    /// [`BoardFrames::MAX`] (the error says what is expected).
    pub fn new(
        shots: usize,
        projector_shots: usize,
        seat: bool,
        frames: BoardFrames,
    ) -> Result<BoardPlan, String> {
        let max = Self::MAX_SHOTS;
        BoardFrames::check("resting_frames", frames.resting)?;
        BoardFrames::check("held_frames", frames.held)?;
        ((1..=max).contains(&shots) && projector_shots <= max)
            .then_some(BoardPlan {
                shots,
                projector_shots,
                seat,
                frames,
            })
            .ok_or_else(|| {
                format!(
                    "shots = {shots}, projector_shots = {projector_shots}: expected 1 to {max} \
                     board poses per position and at most {max} for the projector"
                )
            })
    }
}

/// How many places a light calibration photographs the sphere at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SpherePlan {
    pub placements: usize,
}

impl SpherePlan {
    /// The plan, unless there are fewer than 2 or more than
    /// [`BoardPlan::MAX_SHOTS`] places: a flash is where the rays of two or
    /// more places meet.
    pub fn new(placements: usize) -> Result<SpherePlan, String> {
        let max = BoardPlan::MAX_SHOTS;
        (2..=max)
            .contains(&placements)
            .then_some(SpherePlan { placements })
            .ok_or_else(|| format!("{placements}: expected 2 to {max} places of the sphere"))
    }
}

/// How a radiometric calibration photographs the white card: every light
/// alone at one exposure, and the first flash at `exposures` exposures in
/// all (each half the last) for the camera's linearity; with the card's
/// reflectance as the configuration gives it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhitePlan {
    pub exposures: usize,
    /// The card's diffuse reflectance.
    pub albedo: f64,
    /// The card's roughness (Principled BSDF).
    pub roughness: f64,
}

impl WhitePlan {
    /// Most exposures: the last is 1/32 of the first.
    pub const MAX_EXPOSURES: usize = 6;

    /// The plan, unless `exposures` is outside 1 to
    /// [`WhitePlan::MAX_EXPOSURES`] (1: no linearity check).
    pub fn new(exposures: usize, albedo: f64, roughness: f64) -> Result<WhitePlan, String> {
        let max = Self::MAX_EXPOSURES;
        (1..=max)
            .contains(&exposures)
            .then_some(WhitePlan {
                exposures,
                albedo,
                roughness,
            })
            .ok_or_else(|| format!("{exposures}: expected 1 to {max} exposures of the white card"))
    }
}

/// What a calibration capture photographs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CalibrationPlan {
    /// The printed board: the cameras, and the projector by Gray codes.
    Board(BoardPlan),
    /// The glossy sphere: the flashes.
    Sphere(SpherePlan),
    /// The white card: the lights' intensities.
    White(WhitePlan),
}

impl CalibrationPlan {
    /// The target's name in requests and events.
    pub fn target(&self) -> &'static str {
        match self {
            CalibrationPlan::Board(_) => "board",
            CalibrationPlan::Sphere(_) => "sphere",
            CalibrationPlan::White(_) => "white",
        }
    }

    /// The plan as events show it.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            CalibrationPlan::Board(b) => serde_json::json!({
                "target": "board", "shots": b.shots, "projector_shots": b.projector_shots,
                "seat": b.seat, "resting_frames": b.frames.resting,
                "held_frames": b.frames.held,
            }),
            CalibrationPlan::Sphere(s) => serde_json::json!({
                "target": "sphere", "placements": s.placements,
            }),
            CalibrationPlan::White(w) => serde_json::json!({
                "target": "white", "exposures": w.exposures, "albedo": w.albedo,
            }),
        }
    }
}

/// What a finished calibration capture produced.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationOutcome {
    /// The published bundle.
    pub bundle: PathBuf,
    pub positions: usize,
    /// Board photos (the Gray-code poses' flash photos included), or the
    /// sphere's places.
    pub shots: usize,
    pub graycode_shots: usize,
    /// Every photo taken.
    pub photos: usize,
    pub seconds: f64,
}

impl RigDevices {
    /// Photographs the target `plan` asks for (the board, the sphere or
    /// the white card) and publishes its bundle at `target` (which must
    /// not exist); the rig is left dark whatever happens. `prompt` hears
    /// what the operator is to do before each pose; `stop` and `progress`
    /// as for [`RigDevices::capture`].
    pub fn capture_calibration(
        &mut self,
        plan: CalibrationPlan,
        target: &Path,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
        prompt: &mut dyn FnMut(&str),
        progress: &mut dyn FnMut(Progress),
    ) -> Result<CalibrationOutcome, CaptureError> {
        let result = match plan {
            CalibrationPlan::Board(b) => {
                self.board_bundle(b, target, settings, stop, prompt, progress)
            }
            CalibrationPlan::Sphere(s) => {
                self.sphere_bundle(s, target, settings, stop, prompt, progress)
            }
            CalibrationPlan::White(w) => {
                self.white_bundle(w, target, settings, stop, prompt, progress)
            }
        };
        self.leave_dark("calibration");
        result
    }

    /// The board at every position, and the Gray-code poses (see the
    /// module doc).
    fn board_bundle(
        &mut self,
        plan: BoardPlan,
        target: &Path,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
        prompt: &mut dyn FnMut(&str),
        progress: &mut dyn FnMut(Progress),
    ) -> Result<CalibrationOutcome, CaptureError> {
        let start = Instant::now();
        let board = self
            .calibration_target
            .clone()
            .ok_or(CaptureError::NoCalibrationTarget)?;
        let codes = self.gray_codes(plan)?;
        let count = self.geometry.positions.len();
        if count > 1 && self.positioner.is_none() && self.trigger.is_none() {
            return Err(CaptureError::CannotMove { positions: count });
        }
        let per_position = plan.shots + usize::from(plan.seat);
        let total = count * per_position + plan.projector_shots * (1 + codes.len());
        let pending = PendingDir::create(target)?;
        self.start_dark()?;
        let mut done = 0;
        let mut positions = Vec::with_capacity(count);
        for index in 0..count {
            let geometry = self.geometry.positions[index].clone();
            if index > 0 {
                if self.positioner.is_none() {
                    prompt(&format!("move the object to {}", geometry.name));
                }
                self.next_position(&geometry.name, settings, stop)?;
            }
            self.lock_exposure(&geometry.name, geometry.exposure_s)?;
            let folder = PathBuf::from(&geometry.name);
            create_dir(&pending.path().join(&folder))?;
            let mut shots = Vec::new();
            // Frames averaged into a held pose's photo need a board that
            // does not move while they are taken.
            let hold = if plan.frames.held > 1 {
                "prop the board on its stand"
            } else {
                "hold the board"
            };
            let resting = std::iter::once((
                BoardPlacement::Reference,
                TargetPlacement::Reference,
                format!(
                    "put the board at its reference placement, seen from {}",
                    geometry.name
                ),
            ))
            .chain(plan.seat.then(|| {
                (
                    BoardPlacement::Seat(SEAT.into()),
                    TargetPlacement::Seat,
                    format!(
                        "put the board on the mount's second seat, seen from {}",
                        geometry.name
                    ),
                )
            }));
            let held = (1..plan.shots).map(|s| {
                (
                    BoardPlacement::Held,
                    TargetPlacement::HandHeld,
                    format!(
                        "{hold} at a new pose before the camera at {} (pose {} of {}), whole in view and tilted",
                        geometry.name,
                        s + 1,
                        plan.shots
                    ),
                )
            });
            for (s, (placement, place, task)) in resting.chain(held).enumerate() {
                self.present(index, place, &task, settings, stop, prompt)?;
                let file = folder.join(format!("board-{s:02}.exr"));
                let frames = plan.frames.for_placement(&placement);
                self.photograph_board(pending.path(), &file, frames, stop)?;
                done += 1;
                progress(Progress {
                    done,
                    total,
                    what: file.display().to_string(),
                });
                shots.push(Shot {
                    file,
                    placement,
                    graycode: None,
                });
            }
            if index == 0 {
                for k in 0..plan.projector_shots {
                    let task = format!(
                        "{hold} where the projector lights it whole (Gray-code pose {} of {})",
                        k + 1,
                        plan.projector_shots
                    );
                    self.present(
                        index,
                        TargetPlacement::InProjectorView,
                        &task,
                        settings,
                        stop,
                        prompt,
                    )?;
                    let shot = folder.join(format!("projector-{k:02}"));
                    create_dir(&pending.path().join(&shot))?;
                    let file = shot.join("board.exr");
                    self.photograph_board(pending.path(), &file, plan.frames.held, stop)?;
                    done += 1;
                    progress(Progress {
                        done,
                        total,
                        what: file.display().to_string(),
                    });
                    for code in &codes {
                        if stop() {
                            return Err(CaptureError::Cancelled);
                        }
                        let frame = self.with_projector(ProjectorPattern::GrayCode(*code))?;
                        let name = shot.join(graycode_file(code.axis, code.bit, code.inverted));
                        self.write_photo(pending.path(), &name, &frame)?;
                        done += 1;
                        progress(Progress {
                            done,
                            total,
                            what: name.display().to_string(),
                        });
                    }
                    shots.push(Shot {
                        file,
                        placement: BoardPlacement::Held,
                        graycode: Some(shot),
                    });
                }
            }
            positions.push(CalibPosition {
                name: geometry.name.clone(),
                shots,
            });
        }
        self.home()?;
        let projector = match (plan.projector_shots, self.projector.as_ref()) {
            (0, _) | (_, None) => None,
            (_, Some(p)) => {
                let (width, height) = p.resolution();
                Some(ProjectorSize { width, height })
            }
        };
        let manifest = CalibManifest {
            units: "m".into(),
            board: board.board,
            reference_to_world: board.reference_to_world,
            positions,
            projector,
        };
        let bundle = self.publish(pending, CALIB_MANIFEST, &manifest.to_toml())?;
        Ok(CalibrationOutcome {
            bundle,
            positions: count,
            shots: count * per_position + plan.projector_shots,
            graycode_shots: plan.projector_shots,
            photos: total,
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The sphere at `plan`'s places before the first position's camera.
    fn sphere_bundle(
        &mut self,
        plan: SpherePlan,
        target: &Path,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
        prompt: &mut dyn FnMut(&str),
        progress: &mut dyn FnMut(Progress),
    ) -> Result<CalibrationOutcome, CaptureError> {
        let start = Instant::now();
        let radius = self.sphere_radius.ok_or(CaptureError::NoSphere)?;
        let Some(geometry) = self.geometry.positions.first().cloned() else {
            return Err(CaptureError::CannotMove { positions: 0 });
        };
        // The projector's highlight centres the sphere (its pose is
        // calibrated by the board): photographed where it can show white.
        let shots = self.lit_shots();
        // Ambient and backlight besides.
        let total = plan.placements * (2 + shots.len());
        let pending = PendingDir::create(target)?;
        self.start_dark()?;
        let mut placements = Vec::new();
        let mut done = 0;
        for k in 0..plan.placements {
            let task = format!(
                "hold the sphere somewhere new before the camera at {} (place {} of {}), \
                 the backlight panel behind it, nearer and farther, left and right",
                geometry.name,
                k + 1,
                plan.placements
            );
            self.present(0, TargetPlacement::Sphere, &task, settings, stop, prompt)?;
            let folder = PathBuf::from(&geometry.name).join(format!("sphere-{k:02}"));
            create_dir(&pending.path().join(&folder))?;
            let (_, ambient, flashes) =
                self.unclipped(&geometry.name, geometry.exposure_s, &shots, stop)?;
            let backlit = self.photo_with(&[LightId::Backlight], stop)?;
            let photos = [
                (AMBIENT_PHOTO.to_string(), ambient),
                (BACKLIGHT_PHOTO.to_string(), backlit),
            ]
            .into_iter()
            .chain(flashes);
            for (file, rgb) in photos {
                let name = folder.join(&file);
                self.write_photo(pending.path(), &name, &rgb)?;
                done += 1;
                progress(Progress {
                    done,
                    total,
                    what: name.display().to_string(),
                });
            }
            placements.push(Placement {
                position: geometry.name.clone(),
                folder,
            });
        }
        let manifest = LightsManifest {
            units: "m".into(),
            radius,
            placements,
        };
        let bundle = self.publish(pending, LIGHTS_MANIFEST, &manifest.to_toml())?;
        Ok(CalibrationOutcome {
            bundle,
            positions: 1,
            shots: plan.placements,
            graycode_shots: 0,
            photos: total,
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The backlight panel with the mount empty, the white card on the
    /// board's mount under every light alone, then the first flash at
    /// `plan`'s shorter exposures.
    fn white_bundle(
        &mut self,
        plan: WhitePlan,
        target: &Path,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
        prompt: &mut dyn FnMut(&str),
        progress: &mut dyn FnMut(Progress),
    ) -> Result<CalibrationOutcome, CaptureError> {
        let start = Instant::now();
        let board = self
            .calibration_target
            .clone()
            .ok_or(CaptureError::NoCalibrationTarget)?;
        let card = WhiteCard::on_board(
            &board.board,
            board.reference_to_world,
            plan.albedo,
            plan.roughness,
        );
        let Some(geometry) = self.geometry.positions.first().cloned() else {
            return Err(CaptureError::CannotMove { positions: 0 });
        };
        let panel = [LitShot::Light(LightId::Backlight)];
        let shots = self.lit_shots();
        // The panel and its ambient, the card's ambient and lights, and the
        // first flash with its ambient at each shorter exposure.
        let total = 2 + 1 + shots.len() + 2 * (plan.exposures - 1);
        let pending = PendingDir::create(target)?;
        self.start_dark()?;
        let folder = PathBuf::from(&geometry.name);
        create_dir(&pending.path().join(&folder))?;
        let mut photos = Vec::new();
        let mut done = 0;
        let mut keep = |this: &Self,
                        name: String,
                        rgb: &RgbRaster,
                        exposure_s: f32,
                        lights: Vec<String>,
                        ambient: Option<&str>|
         -> Result<(), CaptureError> {
            let file = folder.join(&name);
            this.write_photo(pending.path(), &file, rgb)?;
            done += 1;
            progress(Progress {
                done,
                total,
                what: file.display().to_string(),
            });
            photos.push(WhitePhoto {
                file,
                exposure_s: f64::from(exposure_s),
                lights,
                ambient: ambient.map(|a| folder.join(a)),
            });
            Ok(())
        };
        // The panel first, with the mount empty: a card before it lights
        // it back and brightens it by several per cent. Then the card.
        let stages = [
            (
                TargetPlacement::EmptyMount,
                format!(
                    "take everything off the mount: the backlight panel is photographed \
                     alone from {}",
                    geometry.name
                ),
                &panel[..],
                PANEL_AMBIENT,
            ),
            (
                TargetPlacement::WhiteCard,
                format!(
                    "put the white card on the board's mount at its reference placement, \
                     white side to the camera at {}, nothing between it and the lights",
                    geometry.name
                ),
                &shots[..],
                AMBIENT_PHOTO,
            ),
        ];
        let mut exposure = geometry.exposure_s;
        for (placement, task, lit_shots, ambient_file) in stages {
            self.present(0, placement, &task, settings, stop, prompt)?;
            let (e, ambient, lit) =
                self.unclipped(&geometry.name, geometry.exposure_s, lit_shots, stop)?;
            keep(self, ambient_file.into(), &ambient, e, Vec::new(), None)?;
            for ((file, rgb), shot) in lit.iter().zip(lit_shots) {
                let lights = vec![shot.light_name()];
                keep(self, file.clone(), rgb, e, lights, Some(ambient_file))?;
            }
            exposure = e;
        }
        // The linearity check: the first flash at each shorter exposure,
        // with its own ambient.
        if let Some(flash) = FLASHES.iter().find_map(|f| LightId::from_name(f)) {
            for k in 1..plan.exposures {
                let e = exposure / (1u32 << k) as f32;
                self.lock_exposure(&geometry.name, e)?;
                self.camera.scene_changed(monotonic_now());
                let ambient = self.camera.capture()?.rgb;
                let rgb = self.photo_with(&[flash], stop)?;
                let ambient_file = format!("ambient-e{k}.exr");
                keep(self, ambient_file.clone(), &ambient, e, Vec::new(), None)?;
                let lights = vec![flash.name().to_string()];
                let file = format!("{}-e{k}.exr", flash.name());
                keep(self, file, &rgb, e, lights, Some(&ambient_file))?;
            }
        }
        let manifest = WhiteManifest {
            units: "m".into(),
            position: geometry.name.clone(),
            card,
            photos,
        };
        let bundle = self.publish(pending, WHITE_MANIFEST, &manifest.to_toml())?;
        Ok(CalibrationOutcome {
            bundle,
            positions: 1,
            shots: 1,
            graycode_shots: 0,
            photos: total,
            seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The lights a light calibration photographs one at a time before
    /// its target: each flash, and the projector where it can show uniform
    /// white.
    fn lit_shots(&self) -> Vec<LitShot> {
        let mut shots: Vec<LitShot> = FLASHES
            .iter()
            .filter_map(|f| LightId::from_name(f))
            .map(LitShot::Light)
            .collect();
        if self
            .projector
            .as_ref()
            .is_some_and(|p| p.can_show(&ProjectorPattern::Uniform(Level::FULL)))
        {
            shots.push(LitShot::Projector);
        }
        shots
    }

    /// The ambient photo and one photo per shot in `shots`, all at one
    /// exposure: `exposure_s` or shorter, until no light clips a pixel
    /// (a glossy sphere mirrors a flash far brighter than anything the
    /// scans see). A pixel clipped in ambient too (a lamp in the room) is
    /// not the lights' doing. Returns the exposure, the ambient photo and
    /// each shot's file name and photo.
    #[allow(clippy::type_complexity)]
    fn unclipped(
        &mut self,
        position: &str,
        exposure_s: f32,
        shots: &[LitShot],
        stop: &dyn Fn() -> bool,
    ) -> Result<(f32, RgbRaster, Vec<(String, RgbRaster)>), CaptureError> {
        let mut scale = 1.0f32;
        loop {
            let exposure = exposure_s * scale;
            self.lock_exposure(position, exposure)?;
            self.camera.scene_changed(monotonic_now());
            let ambient = self.camera.capture()?.rgb;
            let mut frames = Vec::new();
            for shot in shots {
                let frame = match shot {
                    LitShot::Light(l) => self.photo_with(&[*l], stop)?,
                    LitShot::Projector => {
                        self.with_projector(ProjectorPattern::Uniform(Level::FULL))?
                    }
                };
                frames.push((shot.file(), frame));
            }
            let clipped = |v: &[f32; 3]| v.iter().any(|&c| c >= CLIPPED_LEVEL);
            let lit_clips = frames.iter().any(|(_, f)| {
                f.data
                    .iter()
                    .zip(&ambient.data)
                    .any(|(p, a)| clipped(p) && !clipped(a))
            });
            if !lit_clips {
                return Ok((exposure, ambient, frames));
            }
            if scale < 1.0 / 4096.0 {
                return Err(CaptureError::HighlightClipped {
                    device: self.camera.id().to_string(),
                    position: position.to_string(),
                });
            }
            scale *= 0.25;
        }
    }

    /// Writes the bundle's manifest `file` (with a simulated rig's truth
    /// beside it, for `matscan calib compare`) and publishes `pending`.
    fn publish(
        &self,
        pending: PendingDir,
        file: &str,
        manifest: &str,
    ) -> Result<PathBuf, CaptureError> {
        write_atomic(&pending.path().join(file), manifest.as_bytes())?;
        if let Some(rig) = self.truth.as_ref().and_then(|t| t.rig()) {
            write_atomic(
                &pending.path().join(matscan_sim::calib_target::TRUTH_RIG),
                rig.to_toml().as_bytes(),
            )?;
        }
        Ok(pending.publish()?)
    }

    /// One photo with `lights` alone at full power.
    fn photo_with(
        &mut self,
        lights: &[LightId],
        stop: &dyn Fn() -> bool,
    ) -> Result<RgbRaster, CaptureError> {
        self.photo_averaged(lights, 1, stop)
    }

    /// The mean of `frames` photos (at least one,
    /// [`matscan_drivers::Camera::capture_mean`])
    /// with `lights` on at full power, then off again.
    fn photo_averaged(
        &mut self,
        lights: &[LightId],
        frames: usize,
        stop: &dyn Fn() -> bool,
    ) -> Result<RgbRaster, CaptureError> {
        if stop() {
            return Err(CaptureError::Cancelled);
        }
        for &light in lights {
            self.lights.on(light, Level::FULL)?;
        }
        self.camera.scene_changed(monotonic_now());
        let frame = self.camera.capture_mean(frames);
        for &light in lights {
            self.lights.off(light)?;
        }
        self.camera.scene_changed(monotonic_now());
        Ok(frame?.rgb)
    }

    /// The Gray-code images each projector pose needs; an error when the
    /// plan wants them and the projector is missing or cannot show them.
    fn gray_codes(&self, plan: BoardPlan) -> Result<Vec<GrayCode>, CaptureError> {
        if plan.projector_shots == 0 {
            return Ok(Vec::new());
        }
        let projector =
            self.projector
                .as_ref()
                .ok_or_else(|| CaptureError::CannotShowGrayCode {
                    device: "projector".into(),
                    reason: "this rig has no projector; ask for no projector shots".into(),
                })?;
        let (width, height) = projector.resolution();
        let codes = GrayCode::sequence(width, height);
        if let Some(code) = codes
            .iter()
            .find(|c| !projector.can_show(&ProjectorPattern::GrayCode(**c)))
        {
            return Err(CaptureError::CannotShowGrayCode {
                device: projector.id().to_string(),
                reason: format!(
                    "it cannot show the Gray code of its {} (bit {})",
                    code.axis.name(),
                    code.bit
                ),
            });
        }
        Ok(codes)
    }

    /// The board placed for the next photos: by the simulated operator's
    /// hand, or by the operator, prompted, who presses when done.
    fn present(
        &mut self,
        position: usize,
        placement: TargetPlacement,
        task: &str,
        settings: &RunSettings,
        stop: &dyn Fn() -> bool,
        prompt: &mut dyn FnMut(&str),
    ) -> Result<(), CaptureError> {
        if stop() {
            return Err(CaptureError::Cancelled);
        }
        prompt(task);
        if let Some(hand) = self.hand.as_mut() {
            hand.place(position, placement)?;
            self.camera.scene_changed(monotonic_now());
            return Ok(());
        }
        self.wait_for_press(
            task,
            &format!("to say the board is placed ({task})"),
            settings,
            stop,
        )?;
        Ok(())
    }

    /// Photographs the board under both flashes into `root/file`.
    fn photograph_board(
        &mut self,
        root: &Path,
        file: &Path,
        frames: usize,
        stop: &dyn Fn() -> bool,
    ) -> Result<(), CaptureError> {
        let rgb = self.photo_averaged(&[LightId::Flash0, LightId::Flash1], frames, stop)?;
        self.write_photo(root, file, &rgb)
    }

    /// One photo with the projector alone showing `pattern`, then black.
    fn with_projector(&mut self, pattern: ProjectorPattern) -> Result<RgbRaster, CaptureError> {
        self.projector()?.show(pattern)?;
        self.camera.scene_changed(monotonic_now());
        let frame = self.camera.capture();
        self.projector()?.show(ProjectorPattern::Black)?;
        self.camera.scene_changed(monotonic_now());
        Ok(frame?.rgb)
    }

    /// Writes `rgb` at `root/file` (half-float EXR, as scan photos) and
    /// books it on the disk quota.
    fn write_photo(&self, root: &Path, file: &Path, rgb: &RgbRaster) -> Result<(), CaptureError> {
        let path = root.join(file);
        write_rgb_exr(&path, rgb, Precision::Half)?;
        if let Some(disk) = &self.disk {
            let bytes = std::fs::metadata(&path)
                .map_err(|source| matscan_scan::ScanError::Io {
                    path: path.clone(),
                    source,
                })?
                .len();
            disk.reserve(&path, bytes)?;
        }
        Ok(())
    }
}

/// The ambient photo of the empty mount, which the backlight panel's photo
/// is read against.
const PANEL_AMBIENT: &str = "ambient-panel.exr";

/// One light photographed alone in a light calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
enum LitShot {
    Light(LightId),
    /// The projector showing uniform white.
    Projector,
}

impl LitShot {
    /// The light's name in the rig file.
    fn light_name(&self) -> String {
        match self {
            LitShot::Light(l) => l.name().to_string(),
            LitShot::Projector => "projector".to_string(),
        }
    }

    /// Its photo's file name.
    fn file(&self) -> String {
        match self {
            LitShot::Light(l) => light_photo(l.name()),
            LitShot::Projector => PROJECTOR_PHOTO.to_string(),
        }
    }
}

fn create_dir(path: &Path) -> Result<(), CaptureError> {
    std::fs::create_dir_all(path).map_err(|source| {
        CaptureError::Scan(matscan_scan::ScanError::Io {
            path: path.to_path_buf(),
            source,
        })
    })
}
