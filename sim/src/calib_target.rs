//! Calibration targets on the simulated rig: a printed chessboard as a
//! scene, posed in front of a rig's camera and rendered by the same path
//! tracer as the scans, written as a `matscan-calib/1` bundle together with
//! the rig that took it (`truth-rig.toml`), so that rig calibration from
//! photos can be checked against the truth.
//!
//! The board is a flat, matte, two-sided quad: black and white squares
//! (albedo 0.03 and 0.8) in a white margin of half a square, textured at
//! [`TEXELS_PER_SQUARE`] so that its edges are sharp at any camera size
//! this crate renders. It is lit by both flashes and the environment; for
//! the projector's shots, also by each Gray-code pattern alone (with the
//! environment, as every capture is).
//!
//! Boundaries: writes bundles through `matscan-scan`'s calibration format;
//! finds no corners and solves nothing.

use crate::render::{CaptureSpec, Environment, RenderOptions, Renderer, SimError};
use crate::scene::{
    random_rig, rig_to_manifest_lights, EnvSource, EnvSpec, MaterialField, Rig, RigOptions, Scene,
    Texture,
};
use glam::{DMat3, DMat4, DQuat, DVec3, Vec2, Vec3};
use matscan_scan::atomic::{write_atomic, PendingDir};
use matscan_scan::calib_bundle::{
    graycode_file, BoardFrames, BoardPlacement, CalibManifest, CalibPosition, Chessboard,
    ProjectorSize, Shot, CALIB_MANIFEST, SEAT,
};
use matscan_scan::image_io::write_rgb_exr;
use matscan_scan::raster::{Raster, RgbRaster};
use matscan_scan::{GrayAxis, Manifest, Mesh, Pattern, PinholeCamera, Position, Precision};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::path::{Path, PathBuf};

/// Texture resolution of the board: texels along one square's edge.
pub const TEXELS_PER_SQUARE: u32 = 32;
/// The angle between the reference board's normal and each camera's view
/// of it that the reference placement aims at.
pub const REFERENCE_VIEW_DEG: f64 = 45.0;
/// Inner corners (columns, rows) of the simulated operator's board: many
/// corners fix each pose better, above all the reference pose on which a
/// position's camera pose rests alone.
pub const INNER_CORNERS: (u32, u32) = (13, 9);
/// The rig file the simulator writes beside the photos: the truth.
pub const TRUTH_RIG: &str = "truth-rig.toml";
const WHITE: f32 = 0.8;
const BLACK: f32 = 0.03;

/// What to render.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardBundleOptions {
    /// Camera image size, pixels.
    pub width: u32,
    pub height: u32,
    /// Rig positions.
    pub positions: usize,
    /// Shots per position, the reference shot included (at least 1).
    pub shots_per_position: usize,
    /// One more shot per position with the board on the mount's further
    /// seat ([`seat_placement`]).
    pub seat: bool,
    /// Frames averaged into each photo of the board, by where it is, each
    /// rendered with its own noise.
    pub frames: BoardFrames,
    /// Further shots at the first position with the projector's Gray
    /// codes on the board (0 for none).
    pub projector_shots: usize,
    /// Inner corners of the board (columns, rows).
    pub inner_corners: (u32, u32),
    /// The true camera's distortion (OpenCV k1 k2 p1 p2 k3).
    pub distortion: [f64; 5],
    /// Seeds the rig, the board poses and the renders.
    pub seed: u64,
    /// Paths per pixel.
    pub samples: u32,
}

impl Default for BoardBundleOptions {
    fn default() -> Self {
        BoardBundleOptions {
            width: 1024,
            height: 1024,
            positions: 3,
            shots_per_position: 8,
            seat: true,
            frames: BoardFrames::DEFAULT,
            projector_shots: 12,
            inner_corners: INNER_CORNERS,
            distortion: [-0.08, 0.05, 0.0005, -0.0003, 0.0],
            seed: 1,
            samples: 16,
        }
    }
}

/// The board's scene: its mesh at `board_to_world` and its printed squares.
pub fn board_scene(board: &Chessboard, board_to_world: DMat4, rig: &Rig) -> Scene {
    let s = board.square;
    let (sq_x, sq_y) = board.squares();
    // The print: outer squares from -s to cols*s, plus half a square of
    // white margin on every side.
    let mesh = flat_mesh(
        board_to_world * DMat4::from_translation(DVec3::new(-1.5 * s, -1.5 * s, 0.0)),
        [(f64::from(sq_x) + 1.0) * s, (f64::from(sq_y) + 1.0) * s],
    );
    let t = TEXELS_PER_SQUARE;
    let (w, h) = ((sq_x + 1) * t, (sq_y + 1) * t);
    // Texel (c, r) with row 0 on top = board y smallest; the margin is half
    // a square, so squares start at texel t / 2.
    let print = Raster::from_fn(w, h, |c, r| {
        let (c, r) = (c as i64 - i64::from(t / 2), r as i64 - i64::from(t / 2));
        let inside = c >= 0 && r >= 0 && c < i64::from(sq_x * t) && r < i64::from(sq_y * t);
        let black = inside && ((c / i64::from(t)) + (r / i64::from(t))) % 2 == 0;
        [if black { BLACK } else { WHITE }; 3]
    });
    target_scene("chessboard", "board", mesh, Texture::Map(print), 0.7, rig)
}

/// A flat target's mesh: the rectangle `[0, w] x [0, h]` (`size`) of the
/// plane z = 0 of the frame `to_world` maps to the world, wound so that its
/// geometric normal faces -z (the printed or white side), UV origin bottom
/// left with the frame's y running down the print.
pub(crate) fn flat_mesh(to_world: DMat4, [w, h]: [f64; 2]) -> Mesh {
    let corner = |x: f64, y: f64| to_world.transform_point3(DVec3::new(x, y, 0.0)).as_vec3();
    Mesh {
        positions: vec![
            corner(0.0, 0.0),
            corner(w, 0.0),
            corner(w, h),
            corner(0.0, h),
        ],
        normals: None,
        uvs: Some(vec![
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 0.0),
        ]),
        triangles: vec![[0, 2, 1], [0, 3, 2]],
    }
}

/// A calibration target's scene: `mesh` of a dielectric with `basecolor`
/// and `roughness`, named `kind` and `geometry`, under `rig` and a dim
/// procedural room (the same for every target, so the ambient photos of
/// all calibrations look alike).
pub(crate) fn target_scene(
    kind: &str,
    geometry: &str,
    mesh: Mesh,
    basecolor: Texture<[f32; 3]>,
    roughness: f32,
    rig: &Rig,
) -> Scene {
    Scene {
        name: kind.into(),
        kind: kind.into(),
        geometry: geometry.into(),
        mesh,
        material: MaterialField {
            basecolor,
            roughness: Texture::Constant(roughness),
            metallic: Texture::Constant(0.0),
            transmission: Texture::Constant(0.0),
            subsurface: Texture::Constant(0.0),
            subsurface_radius: Vec3::splat(0.01),
        },
        environment: EnvSpec {
            source: EnvSource::Procedural { seed: 7 },
            strength: 0.3,
            rotation: 0.0,
        },
        rig: rig.clone(),
    }
}

/// The square that makes the board, margin included, about half as wide
/// as the camera's view at the rig's working distance, and narrow enough
/// that the projector lights it whole a little farther away (its shots may
/// stand back to 1.4 times the distance), rounded to a millimetre.
pub fn board_for(rig: &Rig, inner_corners: (u32, u32)) -> Chessboard {
    let k = &rig.intrinsics;
    let Some(first) = rig.positions.first() else {
        return Chessboard {
            cols: inner_corners.0,
            rows: inner_corners.1,
            square: 0.05,
        };
    };
    let distance = first.camera_to_world.w_axis.truncate().length();
    let p = &first.projector.intrinsics;
    let camera = (f64::from(k.width) / k.fx).min(f64::from(k.height) / k.fy);
    let projector = (f64::from(p.width) / p.fx).min(f64::from(p.height) / p.fy);
    let view = distance * camera.min(1.2 * projector);
    let square = (0.5 * view / f64::from(inner_corners.0 + 2) * 1000.0).round() / 1000.0;
    Chessboard {
        cols: inner_corners.0,
        rows: inner_corners.1,
        square: square.max(0.001),
    }
}

/// The reference placement: the board centred on the world origin, where
/// the object stands, its printed side towards the base position's camera
/// (-Z), columns along -X and rows along -Y as that camera sees them, and
/// leaning like a board on an easel, turned and tilted so that every
/// position's camera sees it as near [`REFERENCE_VIEW_DEG`] as can be.
///
/// A position's camera pose rests on this one view, and a board seen
/// nearly head-on hardly tells a sideways camera shift from a turn (its
/// image changes alike); the board's depth across the view tells them
/// apart, the more the steeper it is seen, until foreshortening blurs its
/// corners (`docs/results.md` has the study).
pub fn reference_placement(board: &Chessboard, rig: &Rig) -> DMat4 {
    let facing = DMat3::from_cols(DVec3::NEG_X, DVec3::NEG_Y, DVec3::Z);
    let centre = board.corner(board.cols - 1, board.rows - 1) * 0.5;
    let target = REFERENCE_VIEW_DEG.to_radians();
    // How far from the target view the worst camera sees the board's
    // normal (its z axis); each camera looks at the origin.
    let miss = |rotation: &DMat3| {
        let normal = *rotation * DVec3::Z;
        rig.positions
            .iter()
            .map(|p| {
                let to_camera = p.camera_to_world.w_axis.truncate().normalize_or_zero();
                (view_angle(normal, to_camera) - target).abs()
            })
            .fold(0.0, f64::max)
    };
    let rotation = (0..=12)
        .flat_map(|l| (0..24).map(move |k| (f64::from(l) * 5.0, k)))
        .map(|(lean_deg, k)| {
            let heading = f64::from(k) * std::f64::consts::TAU / 24.0;
            let axis = DVec3::new(heading.cos(), heading.sin(), 0.0);
            DMat3::from_axis_angle(axis, lean_deg.to_radians()) * facing
        })
        .min_by(|a, b| miss(a).total_cmp(&miss(b)))
        .unwrap_or(facing);
    DMat4::from_rotation_translation(DQuat::from_mat3(&rotation), -(rotation * centre))
}

/// The mount's further seat: the reference placement tilted about its own
/// long (column) axis or turned about the world's vertical (+Y), through
/// its centre, by 30 to 90 degrees either way: of the placements whose
/// printed side every position's camera sees within 65 degrees of
/// head-on, with the board's columns
/// running across the photo and longer there than its rows (so the
/// detector labels it as at the reference), the one that keeps every
/// camera nearest [`REFERENCE_VIEW_DEG`]. `None` when no such placement
/// exists. Seen together with the reference, the two boards are a target
/// with depth; the calibration finds the seat's placement itself, so a
/// real mount's seat need only repeat.
pub fn seat_placement(board: &Chessboard, rig: &Rig) -> Option<DMat4> {
    let reference = reference_placement(board, rig);
    let target = REFERENCE_VIEW_DEG.to_radians();
    let centre = board.corner(board.cols - 1, board.rows - 1) * 0.5;
    let (last_col, last_row) = (board.cols - 1, board.rows - 1);
    // How far from the target view the worst camera sees the board; `None`
    // where some camera sees its back or would label it turned.
    let miss = |m: &DMat4| -> Option<f64> {
        // The board's z axis points into the print: the camera sees the
        // printed side where it points away from the camera.
        let normal = m.transform_vector3(DVec3::Z).normalize_or_zero();
        let mut worst: f64 = 0.0;
        for p in &rig.positions {
            let camera = PinholeCamera::new(rig.intrinsics, p.camera_to_world);
            let at = |i, j| camera.project(m.transform_point3(board.corner(i, j)));
            let (origin, across, down) = (at(0, 0)?, at(last_col, 0)?, at(0, last_row)?);
            let (cols, rows) = (across - origin, down - origin);
            let upright = cols.length() > 1.1 * rows.length()
                && cols.x.abs() > 2.0 * cols.y.abs()
                && rows.y.abs() > 2.0 * rows.x.abs();
            let to_camera = (p.camera_to_world.w_axis.truncate() - m.transform_point3(centre))
                .normalize_or_zero();
            let facing = -normal.dot(to_camera);
            // Steeper than 65 degrees, corners blur into each other.
            if facing < 65f64.to_radians().cos() || !upright {
                return None;
            }
            worst = worst.max((facing.clamp(0.0, 1.0).acos() - target).abs());
        }
        Some(worst)
    };
    let long_axis = reference.transform_vector3(DVec3::X).normalize_or_zero();
    [long_axis, DVec3::Y]
        .into_iter()
        .flat_map(|axis| {
            (6..=18).flat_map(move |k| {
                [-1.0, 1.0].map(|side| {
                    let angle = (side * f64::from(k) * 5.0_f64).to_radians();
                    DMat4::from_axis_angle(axis, angle) * reference
                })
            })
        })
        .filter_map(|m| miss(&m).map(|worst| (m, worst)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(m, _)| m)
}

/// How a person holds the board: tilted within `tilt_deg` about an axis
/// in its plane, at `distance` times the working distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hold {
    pub tilt_deg: (f64, f64),
    pub distance: (f64, f64),
}

impl Hold {
    /// Before the camera alone: tilted 10 to 40 degrees, 0.8 to 1.1 of the
    /// working distance.
    pub const CAMERA: Hold = Hold {
        tilt_deg: (10.0, 40.0),
        distance: (0.8, 1.1),
    };
    /// Where the projector lights it whole too: a little farther back.
    pub const PROJECTOR: Hold = Hold {
        tilt_deg: (10.0, 40.0),
        distance: (0.9, 1.4),
    };
}

/// A random board pose, as a person holds a board for calibration, in
/// front of the camera at `camera_to_world`: the whole print in view (and
/// in `projector`'s image, when given), held as [`Hold::CAMERA`] (or
/// [`Hold::PROJECTOR`]) says and turned in plane up to 15 degrees; `None`
/// when no pose in 500 tries fits.
pub fn hand_held_pose(
    rng: &mut Pcg64,
    board: &Chessboard,
    rig: &Rig,
    camera_to_world: DMat4,
    projector: Option<&PinholeCamera>,
) -> Option<DMat4> {
    let hold = if projector.is_some() {
        Hold::PROJECTOR
    } else {
        Hold::CAMERA
    };
    held_pose(rng, board, rig, camera_to_world, projector, hold)
}

/// [`hand_held_pose`] held as `hold` says.
pub fn held_pose(
    rng: &mut Pcg64,
    board: &Chessboard,
    rig: &Rig,
    camera_to_world: DMat4,
    projector: Option<&PinholeCamera>,
    hold: Hold,
) -> Option<DMat4> {
    let k = rig.intrinsics;
    let distance = camera_to_world.w_axis.truncate().length();
    let (sq_x, sq_y) = board.squares();
    let (x1, y1) = (
        (f64::from(sq_x) - 0.5) * board.square,
        (f64::from(sq_y) - 0.5) * board.square,
    );
    let outline = [
        DVec3::new(-1.5 * board.square, -1.5 * board.square, 0.0),
        DVec3::new(x1, -1.5 * board.square, 0.0),
        DVec3::new(x1, y1, 0.0),
        DVec3::new(-1.5 * board.square, y1, 0.0),
    ];
    let centre = board.corner(board.cols - 1, board.rows - 1) * 0.5;
    for _ in 0..500 {
        let heading = rng.gen_range(0.0..std::f64::consts::TAU);
        let tilt = rng.gen_range(hold.tilt_deg.0.to_radians()..hold.tilt_deg.1.to_radians());
        let rotation = DQuat::from_rotation_z(rng.gen_range(-0.26..0.26))
            * DQuat::from_axis_angle(DVec3::new(heading.cos(), heading.sin(), 0.0), tilt);
        let z = distance * rng.gen_range(hold.distance.0..hold.distance.1);
        let spread = 0.35 * z * f64::from(k.width) / k.fx;
        let at = DVec3::new(
            rng.gen_range(-spread..spread),
            rng.gen_range(-spread..spread),
            z,
        );
        let board_to_camera = DMat4::from_rotation_translation(rotation, at - rotation * centre);
        let fits = outline.iter().all(|&p| {
            let pc = board_to_camera.transform_point3(p);
            k.project_camera_point(pc).is_some_and(|px| {
                let m = 0.03 * f64::from(k.width.min(k.height));
                px.x > m
                    && px.y > m
                    && px.x < f64::from(k.width) - m
                    && px.y < f64::from(k.height) - m
            })
        });
        let board_to_world = camera_to_world * board_to_camera;
        let lit = projector.is_none_or(|projector| {
            let k = projector.intrinsics;
            outline.iter().all(|&p| {
                projector
                    .project(board_to_world.transform_point3(p))
                    .is_some_and(|px| {
                        let m = 0.03 * f64::from(k.width.min(k.height));
                        px.x > m
                            && px.y > m
                            && px.x < f64::from(k.width) - m
                            && px.y < f64::from(k.height) - m
                    })
            })
        });
        // The solver refuses a board seen more than 70 degrees from
        // head-on (the line of sight to its origin, as `rigcal` measures
        // it); a tilt and an off-axis place can add up to that on a
        // short-focus rig, and a person is told to keep it turned
        // towards the camera.
        let seen = view_angle(rotation * DVec3::Z, board_to_camera.w_axis.truncate());
        if fits && lit && seen.to_degrees() <= MAX_HELD_VIEW_DEG {
            return Some(board_to_world);
        }
    }
    None
}

/// The angle between a board's `normal` and the line of `sight` between
/// it and a camera, radians, whichever way either points (0 = head-on).
pub fn view_angle(normal: DVec3, sight: DVec3) -> f64 {
    normal
        .normalize_or_zero()
        .dot(sight.normalize_or_zero())
        .abs()
        .clamp(0.0, 1.0)
        .acos()
}

/// The most a hand-held board is seen from head-on, degrees: inside the
/// solver's 70 with a margin for its own estimate of the angle.
pub const MAX_HELD_VIEW_DEG: f64 = 68.0;

/// A person holding a printed board in front of a simulated rig: the
/// board sized for the rig ([`board_for`]), at its reference placement or
/// wherever the next hand-held photo wants it.
#[derive(Debug, Clone)]
pub struct BoardHolder {
    board: Chessboard,
    rig: Rig,
    rng: Pcg64,
}

impl BoardHolder {
    /// A board of `inner_corners` for `rig`; `seed` picks the poses.
    pub fn new(rig: &Rig, inner_corners: (u32, u32), seed: u64) -> BoardHolder {
        BoardHolder {
            board: board_for(rig, inner_corners),
            rig: rig.clone(),
            rng: Pcg64::seed_from_u64(seed),
        }
    }

    pub fn board(&self) -> &Chessboard {
        &self.board
    }

    /// The board's reference placement, board to world.
    pub fn reference_to_world(&self) -> DMat4 {
        reference_placement(&self.board, &self.rig)
    }

    /// The scene with the board at its reference placement.
    pub fn reference(&self) -> Scene {
        board_scene(&self.board, self.reference_to_world(), &self.rig)
    }

    /// The scene with the board on the mount's further seat
    /// ([`seat_placement`]); an error when no seat suits every camera.
    pub fn on_seat(&self) -> Result<Scene, SimError> {
        let seat = seat_placement(&self.board, &self.rig).ok_or_else(no_seat)?;
        Ok(board_scene(&self.board, seat, &self.rig))
    }

    /// The rig the board is held before.
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// The scene with the board held at a fresh pose before the camera of
    /// rig position `position`, also lit whole by that position's
    /// projector when `in_projector_view`.
    pub fn hand_held(
        &mut self,
        position: usize,
        in_projector_view: bool,
    ) -> Result<Scene, SimError> {
        let at = self.rig.positions.get(position).ok_or_else(|| {
            SimError::Options(format!(
                "rig position {position} does not exist ({} positions)",
                self.rig.positions.len()
            ))
        })?;
        let projector = in_projector_view
            .then(|| PinholeCamera::new(at.projector.intrinsics, at.projector.projector_to_world));
        let pose = hand_held_pose(
            &mut self.rng,
            &self.board,
            &self.rig,
            at.camera_to_world,
            projector.as_ref(),
        )
        .ok_or_else(|| {
            SimError::Options(format!(
                "no board pose fits the {} view at position {}",
                if in_projector_view {
                    "camera's and the projector's"
                } else {
                    "camera's"
                },
                at.name
            ))
        })?;
        Ok(board_scene(&self.board, pose, &self.rig))
    }
}

fn no_seat() -> SimError {
    SimError::Options(
        "no second seat shows every camera the board's printed side with its columns across \
         the photo; calibrate without the seat"
            .into(),
    )
}

/// The random rig `write_board_bundle` photographs for `opts` (its seed,
/// size, positions and lens distortion), with the generator that goes on
/// to draw the hand-held poses.
pub fn board_rig(opts: &BoardBundleOptions) -> (Rig, Pcg64) {
    let mut rng = Pcg64::seed_from_u64(opts.seed);
    let mut rig = random_rig(
        &mut rng,
        RigOptions {
            width: opts.width,
            height: opts.height,
            positions: opts.positions,
        },
    );
    rig.intrinsics.distortion = opts.distortion;
    (rig, rng)
}

/// Renders the board at every shot of every position of a random rig and
/// writes the bundle at `out_dir` (which must not exist), with the true rig
/// beside it as `truth-rig.toml`. Returns the manifest written.
pub fn write_board_bundle(
    opts: &BoardBundleOptions,
    out_dir: &Path,
) -> Result<CalibManifest, SimError> {
    if opts.samples == 0 || opts.shots_per_position == 0 {
        return Err(SimError::Options(
            "samples and shots per position must be at least 1".into(),
        ));
    }
    let (rig, mut rng) = board_rig(opts);
    let board = board_for(&rig, opts.inner_corners);
    let reference = reference_placement(&board, &rig);
    let env = Environment::from_spec(&board_scene(&board, reference, &rig).environment)?;
    let ropts = RenderOptions {
        samples: opts.samples,
        seed: opts.seed,
        ..RenderOptions::default()
    };
    let capture = [CaptureSpec::new("board", &["flash0", "flash1"], None)];
    let pending = PendingDir::create(out_dir)?;
    let mut positions = Vec::new();
    for (p, position) in rig.positions.iter().enumerate() {
        std::fs::create_dir_all(pending.path().join(&position.name)).map_err(|e| SimError::Io {
            path: pending.path().join(&position.name),
            source: e,
        })?;
        let mut shots = Vec::new();
        let mut placed = vec![(BoardPlacement::Reference, reference)];
        if opts.seat {
            let seat = seat_placement(&board, &rig).ok_or_else(no_seat)?;
            placed.push((BoardPlacement::Seat(SEAT.into()), seat));
        }
        for _ in 1..opts.shots_per_position {
            let pose = hand_held_pose(&mut rng, &board, &rig, position.camera_to_world, None)
                .ok_or_else(|| {
                    SimError::Options(format!(
                        "no board pose fits the view at position {}",
                        position.name
                    ))
                })?;
            placed.push((BoardPlacement::Held, pose));
        }
        for (s, (placement, board_to_world)) in placed.into_iter().enumerate() {
            let scene = board_scene(&board, board_to_world, &rig);
            let renderer = Renderer::with_environment(&scene, env.clone());
            let first = renderer
                .render_position(p, &capture, &ropts)?
                .photos
                .remove(0);
            let frames = opts.frames.for_placement(&placement);
            let photo = mean_of_frames(first, &renderer, p, &capture, &ropts, frames)?;
            let file = PathBuf::from(&position.name).join(format!("board-{s:02}.exr"));
            write_rgb_exr(&pending.path().join(&file), &photo, Precision::Half)?;
            shots.push(Shot {
                file,
                placement,
                graycode: None,
            });
        }
        if p == 0 {
            for k in 0..opts.projector_shots {
                shots.push(projector_shot(
                    &mut rng,
                    &board,
                    &rig,
                    &env,
                    &ropts,
                    opts.frames.held,
                    pending.path(),
                    k,
                )?);
            }
        }
        positions.push(CalibPosition {
            name: position.name.clone(),
            shots,
        });
    }
    let projector = &rig.positions[0].projector.intrinsics;
    let manifest = CalibManifest {
        units: "m".into(),
        board,
        reference_to_world: reference,
        positions,
        projector: (opts.projector_shots > 0).then_some(ProjectorSize {
            width: projector.width,
            height: projector.height,
        }),
    };
    write_atomic(
        &pending.path().join(CALIB_MANIFEST),
        manifest.to_toml().as_bytes(),
    )?;
    write_atomic(
        &pending.path().join(TRUTH_RIG),
        truth_rig(&rig).to_toml().as_bytes(),
    )?;
    pending.publish()?;
    Ok(manifest)
}

/// `first`, a render of the one capture in `capture` at position `p`,
/// averaged with `frames - 1` fresh renders of it, each with its own
/// noise: the photo the daemon takes of a board holding still.
fn mean_of_frames(
    first: RgbRaster,
    renderer: &Renderer,
    p: usize,
    capture: &[CaptureSpec],
    ropts: &RenderOptions,
    frames: usize,
) -> Result<RgbRaster, SimError> {
    first.mean_with(frames.saturating_sub(1), |k| {
        let fresh = RenderOptions {
            seed: ropts.seed.wrapping_add(k as u64 * 1_000_003),
            ..*ropts
        };
        Ok(renderer
            .render_position(p, capture, &fresh)?
            .photos
            .remove(0))
    })
}

/// The `k`-th Gray-code shot at the first position: the board where both
/// the camera and the projector see it whole, photographed under the
/// flashes (for its corners, the mean of `frames` frames) and under every
/// Gray-code pattern, rendered in one pass.
#[allow(clippy::too_many_arguments)]
fn projector_shot(
    rng: &mut Pcg64,
    board: &Chessboard,
    rig: &Rig,
    env: &Environment,
    ropts: &RenderOptions,
    frames: usize,
    root: &Path,
    k: usize,
) -> Result<Shot, SimError> {
    let position = &rig.positions[0];
    let projector = PinholeCamera::new(
        position.projector.intrinsics,
        position.projector.projector_to_world,
    );
    let placement = hand_held_pose(rng, board, rig, position.camera_to_world, Some(&projector))
        .ok_or_else(|| {
            SimError::Options(format!(
                "no board pose fits both the camera's and the projector's view at {}",
                position.name
            ))
        })?;
    let size = ProjectorSize {
        width: projector.intrinsics.width,
        height: projector.intrinsics.height,
    };
    let name = position.projector.name.as_str();
    let mut captures = vec![CaptureSpec::new("board", &["flash0", "flash1"], None)];
    let mut files = Vec::new();
    for axis in [GrayAxis::Columns, GrayAxis::Rows] {
        for bit in 0..size.bits(axis) {
            for inverted in [false, true] {
                let pattern = Pattern::GrayCode {
                    axis,
                    bit,
                    inverted,
                };
                let file = graycode_file(axis, bit, inverted);
                captures.push(CaptureSpec::new(&file, &[name], Some(pattern)));
                files.push(file);
            }
        }
    }
    let scene = board_scene(board, placement, rig);
    let renderer = Renderer::with_environment(&scene, env.clone());
    let mut photos = renderer.render_position(0, &captures, ropts)?.photos;
    let first = photos.remove(0);
    let lit_photo = mean_of_frames(first, &renderer, 0, &captures[..1], ropts, frames)?;
    let folder = PathBuf::from(&position.name).join(format!("projector-{k:02}"));
    std::fs::create_dir_all(root.join(&folder)).map_err(|e| SimError::Io {
        path: root.join(&folder),
        source: e,
    })?;
    let lit = folder.join("board.exr");
    write_rgb_exr(&root.join(&lit), &lit_photo, Precision::Half)?;
    for (file, photo) in files.iter().zip(&photos) {
        write_rgb_exr(&root.join(&folder).join(file), photo, Precision::Half)?;
    }
    Ok(Shot {
        file: lit,
        placement: BoardPlacement::Held,
        graycode: Some(folder),
    })
}

/// The rig as a rig calibration file: the camera, its pose at each
/// position and the lights, as the simulator knows them.
pub fn truth_rig(rig: &Rig) -> Manifest {
    Manifest {
        units: "m".into(),
        name: "simulated rig".into(),
        created: matscan_scan::time::rfc3339_now(),
        camera: rig.intrinsics,
        positions: rig
            .positions
            .iter()
            .map(|p| Position {
                name: p.name.clone(),
                camera_to_world: p.camera_to_world,
                lights: rig_to_manifest_lights(p),
                captures: Vec::new(),
                white_reference_mask: None,
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hand_held_board_is_never_seen_steeper_than_the_solver_takes() {
        // Seed 2's short-focus rig drew a board seen 72 degrees from
        // head-on among 16 shots per position before the limit.
        for seed in 1..=3 {
            let (rig, _) = board_rig(&BoardBundleOptions {
                seed,
                ..BoardBundleOptions::default()
            });
            let board = board_for(&rig, INNER_CORNERS);
            let mut rng = Pcg64::seed_from_u64(seed);
            let mut steepest = 0.0f64;
            for p in &rig.positions {
                let world_to_camera = p.camera_to_world.inverse();
                for _ in 0..200 {
                    let b2w = hand_held_pose(&mut rng, &board, &rig, p.camera_to_world, None)
                        .unwrap_or_else(|| panic!("rig {seed} {}: no pose", p.name));
                    let b2c = world_to_camera * b2w;
                    let seen = view_angle(b2c.transform_vector3(DVec3::Z), b2c.w_axis.truncate());
                    steepest = steepest.max(seen.to_degrees());
                }
            }
            assert!(
                steepest <= MAX_HELD_VIEW_DEG + 1e-9,
                "rig {seed}: {steepest}"
            );
            // The limit bites only at the edge: boards are still held steep.
            assert!(steepest > 50.0, "rig {seed}: {steepest}");
        }
    }

    #[test]
    fn the_second_seat_shows_every_camera_the_board_upright_at_an_angle_to_the_reference() {
        for seed in 1..=8 {
            let (rig, _) = board_rig(&BoardBundleOptions {
                seed,
                ..BoardBundleOptions::default()
            });
            let board = board_for(&rig, INNER_CORNERS);
            let reference = reference_placement(&board, &rig);
            let seat = seat_placement(&board, &rig)
                .unwrap_or_else(|| panic!("rig {seed}: no seat placement"));
            let (normal, reference_normal) = (
                seat.transform_vector3(DVec3::Z),
                reference.transform_vector3(DVec3::Z),
            );
            let turn = normal.angle_between(reference_normal).to_degrees();
            assert!((29.9..=90.1).contains(&turn), "rig {seed}: turned {turn}");
            for p in &rig.positions {
                let camera = PinholeCamera::new(rig.intrinsics, p.camera_to_world);
                let centre =
                    seat.transform_point3(board.corner(board.cols - 1, board.rows - 1) * 0.5);
                let to_camera = (p.camera_to_world.w_axis.truncate() - centre).normalize();
                let tilt = (-normal.dot(to_camera)).acos().to_degrees();
                assert!(tilt < 70.0, "rig {seed} {}: seen at {tilt} degrees", p.name);
                let at = |i, j| {
                    camera
                        .project(seat.transform_point3(board.corner(i, j)))
                        .unwrap()
                };
                let cols = at(board.cols - 1, 0) - at(0, 0);
                let rows = at(0, board.rows - 1) - at(0, 0);
                assert!(cols.length() > rows.length(), "rig {seed} {}", p.name);
            }
        }
    }
}
