//! The projector calibrated as an inverse camera (Moreno and Taubin 2012,
//! "Simple, accurate, and robust projector-camera calibration"): the Gray
//! codes on each board pose tell, for every camera pixel on the board,
//! which projector column and row lit it; a homography fitted to the
//! decoded pixels around each board corner gives the corner's position in
//! the projector's image; the projector's intrinsics and its board poses
//! then follow from the same closed form and refinement as the camera's,
//! and its pose from the board poses both see, refined with its intrinsics
//! against every corner with the boards where the camera put them.
//!
//! Decoding: a bit is read as set where the pattern photo is brighter than
//! its inverse, and trusted where the two differ by at least a quarter of
//! the pixel's strongest difference over all bits (a shadow or a black
//! square has none). Stripes narrower than the camera resolves are
//! unreadable; the finest bit that most board pixels read is found per
//! shot and the finer ones are left out, so a corner's projector position
//! comes from groups of `2^bit` projector pixels, which the local
//! homography averages.

use crate::camera::{read_shot, CameraCalibration};
use crate::detect::{corner_spacing, luminance, percentile, Corner};
use crate::error::RigcalError;
use crate::model::{project, Pose};
use crate::refine::{least_squares, refine, ShotPoints, PROJECTOR_FIXED};
use crate::zhang;
use glam::{DMat4, DQuat, DVec2, DVec3};
use matscan_scan::calib_bundle::{graycode_file, ProjectorSize};
use matscan_scan::camera::Intrinsics;
use matscan_scan::{gray_decode, GrayAxis};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Smallest share of a shot's corners that must decode.
const MIN_DECODED_SHARE: f64 = 0.5;
/// Decoded pixels a corner's local homography needs at least.
const MIN_WINDOW_PIXELS: usize = 24;
/// A trusted bit differs from its inverse by this share of the pixel's
/// strongest difference.
const TRUST: f32 = 0.25;

/// One Gray-code shot's figures.
#[derive(Debug, Clone, Serialize)]
pub struct ProjectorShotReport {
    pub graycode: PathBuf,
    pub corners: usize,
    /// Finest bit read (columns, rows): positions come from groups of
    /// `2^bit` projector pixels.
    pub finest_bits: [u32; 2],
    pub rms_px: f64,
    pub tilt_deg: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct ProjectorReport {
    #[serde(flatten)]
    pub lens: Intrinsics,
    /// Reprojection RMS in projector pixels.
    pub rms_px: f64,
    /// Spread of the projector's pose over the shots: largest distance of
    /// one shot's projector centre from the mean, bundle units, and of its
    /// orientation, degrees.
    pub pose_spread: f64,
    pub pose_spread_deg: f64,
    pub shots: Vec<ProjectorShotReport>,
}

/// The projector: intrinsics, its pose in the camera frame, and per
/// position in the world.
#[derive(Debug, Clone)]
pub struct ProjectorCalibration {
    pub intrinsics: Intrinsics,
    pub projector_to_camera: DMat4,
    /// Per position of the bundle, in order.
    pub projector_to_world: Vec<(String, DMat4)>,
    pub report: ProjectorReport,
}

/// Per camera pixel the decoded projector index along one axis, or `None`.
struct Decoded {
    width: usize,
    index: Vec<Option<u32>>,
    finest: u32,
}

/// Calibrates the projector from the Gray-code shots of the bundle in
/// `dir`, given the camera calibrated from it (whose shots, corners and
/// board poses it reuses). `Ok(None)` when the bundle has no Gray codes;
/// an error when it has some but the camera's calibration left every
/// one of their poses out.
pub fn calibrate_projector(
    dir: &Path,
    camera: &CameraCalibration,
) -> Result<Option<ProjectorCalibration>, RigcalError> {
    let manifest = &camera.manifest;
    let Some(size) = manifest.projector else {
        return Ok(None);
    };
    let shots: Vec<(usize, PathBuf)> = manifest
        .positions
        .iter()
        .flat_map(|p| p.shots.iter())
        .enumerate()
        .filter_map(|(k, s)| s.graycode.clone().map(|g| (k, g)))
        .collect();
    // Gray codes the camera left out with their poses (no complete board
    // in them) are too few, not absent: the count below refuses them.
    if shots.is_empty() && camera.report.skipped.iter().all(|s| s.graycode.is_none()) {
        return Ok(None);
    }
    type Found = Result<(ShotPoints, [u32; 2]), RigcalError>;
    let found: Vec<Found> = shots
        .par_iter()
        .map(|(k, folder)| {
            let corners = &camera.corners[*k].0;
            projector_points(&dir.join(folder), size, corners, &manifest.board)
        })
        .collect();
    let mut points = Vec::with_capacity(found.len());
    let mut finest = Vec::with_capacity(found.len());
    for r in found {
        let (mut p, f) = r?;
        p.pose = points.len();
        points.push(p);
        finest.push(f);
    }
    if points.len() < 3 {
        return Err(RigcalError::TooFewGrayCodeShots {
            found: points.len(),
            needed: 3,
        });
    }
    let homographies = points
        .iter()
        .zip(&shots)
        .map(|(sp, (_, folder))| {
            let plane: Vec<DVec2> = sp.board.iter().map(|x| x.truncate()).collect();
            zhang::homography(&plane, &sp.pixels).ok_or_else(|| RigcalError::GrayCode {
                path: dir.join(folder),
                reason: "the decoded corners do not map the board's plane".into(),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let start = zhang::intrinsics(&homographies, size.width, size.height)?;
    let poses = homographies
        .iter()
        .zip(&shots)
        .map(|(h, (_, folder))| {
            zhang::pose(h, &start).ok_or_else(|| RigcalError::GrayCode {
                path: dir.join(folder),
                reason: "no board pose fits the decoded corners".into(),
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let refined = refine(&start, &poses, &points, PROJECTOR_FIXED);
    // Projector to camera through each shot's board: camera_T_board times
    // the inverse of projector_T_board; the mean over the shots.
    let per_shot: Vec<DMat4> = shots
        .iter()
        .zip(&refined.poses)
        .map(|((k, _), projector_pose)| {
            camera.poses[*k].matrix() * projector_pose.matrix().inverse()
        })
        .collect();
    let start_to_camera = mean_transform(&per_shot);
    // Then the projector's intrinsics and its pose in the camera frame
    // together, through the camera's board poses (a stereo refinement):
    // the board's distance is the camera's, so the projector's focal
    // length no longer trades off against it.
    let (intrinsics, projector_to_camera) =
        refine_in_camera_frame(&refined.camera, start_to_camera, &shots, &points, camera);
    let (spread, spread_deg) = per_shot
        .iter()
        .map(|t| crate::compare::pose_difference(t, &projector_to_camera))
        .fold((0.0f64, 0.0f64), |(a, b), (d, r)| (a.max(d), b.max(r)));
    let k = intrinsics;
    let mut shot_reports = Vec::with_capacity(shots.len());
    let (mut sum, mut count) = (0.0, 0usize);
    for (((sp, pose), (_, folder)), bits) in
        points.iter().zip(&refined.poses).zip(&shots).zip(&finest)
    {
        let squares: f64 = sp
            .board
            .iter()
            .zip(&sp.pixels)
            .map(|(&x, &p)| (project(&k, pose, x) - p).length_squared())
            .sum();
        sum += squares;
        count += sp.board.len();
        shot_reports.push(ProjectorShotReport {
            graycode: folder.clone(),
            corners: sp.board.len(),
            finest_bits: *bits,
            rms_px: (squares / sp.board.len().max(1) as f64).sqrt(),
            tilt_deg: pose.tilt_deg(),
        });
    }
    Ok(Some(ProjectorCalibration {
        intrinsics: k,
        projector_to_camera,
        projector_to_world: camera
            .camera_to_world
            .iter()
            .map(|(name, c)| (name.clone(), *c * projector_to_camera))
            .collect(),
        report: ProjectorReport {
            lens: k,
            rms_px: (sum / count.max(1) as f64).sqrt(),
            pose_spread: spread,
            pose_spread_deg: spread_deg,
            shots: shot_reports,
        },
    }))
}

/// The projector's intrinsics (no distortion) and its pose in the camera
/// frame that best explain every Gray-code corner, the boards where the
/// camera put them.
fn refine_in_camera_frame(
    start: &Intrinsics,
    projector_to_camera: DMat4,
    shots: &[(usize, PathBuf)],
    points: &[ShotPoints],
    camera: &CameraCalibration,
) -> (Intrinsics, DMat4) {
    let to_projector = Pose::from_matrix(&projector_to_camera.inverse());
    let mut params = vec![start.fx, start.fy, start.cx, start.cy];
    params.extend_from_slice(&to_projector.pack());
    let boards: Vec<DMat4> = shots
        .iter()
        .map(|(k, _)| camera.poses[*k].matrix())
        .collect();
    let unpack = |p: &[f64]| {
        let k = Intrinsics {
            fx: p[0],
            fy: p[1],
            cx: p[2],
            cy: p[3],
            distortion: [0.0; 5],
            ..*start
        };
        (k, Pose::unpack(&p[4..10]).matrix())
    };
    let solved = least_squares(&params, |p| {
        let (k, camera_to_projector) = unpack(p);
        let mut r = Vec::new();
        for (sp, board) in points.iter().zip(&boards) {
            let pose = Pose::from_matrix(&(camera_to_projector * *board));
            for (&x, &observed) in sp.board.iter().zip(&sp.pixels) {
                let e = project(&k, &pose, x) - observed;
                r.push(e.x);
                r.push(e.y);
            }
        }
        r
    });
    let (k, camera_to_projector) = unpack(&solved);
    (k, camera_to_projector.inverse())
}

/// The mean of rigid transforms: translations averaged, rotations by the
/// normalized sum of their quaternions (signs aligned to the first).
fn mean_transform(ts: &[DMat4]) -> DMat4 {
    let mut q_sum = glam::DVec4::ZERO;
    let mut t_sum = DVec3::ZERO;
    let mut first: Option<DQuat> = None;
    for t in ts {
        let (_, q, p) = t.to_scale_rotation_translation();
        let q = match first {
            Some(f) if f.dot(q) < 0.0 => -q,
            Some(_) => q,
            None => {
                first = Some(q);
                q
            }
        };
        q_sum += glam::DVec4::from(q);
        t_sum += p;
    }
    let n = ts.len().max(1) as f64;
    let q = DQuat::from_vec4(q_sum).normalize();
    DMat4::from_rotation_translation(q, t_sum / n)
}

/// Each decoded corner of one shot: its board point and its projector
/// pixel position; and the finest bits read (columns, rows).
fn projector_points(
    folder: &Path,
    size: ProjectorSize,
    corners: &[Corner],
    board: &matscan_scan::calib_bundle::Chessboard,
) -> Result<(ShotPoints, [u32; 2]), RigcalError> {
    let columns = decode(folder, size, GrayAxis::Columns)?;
    let rows = decode(folder, size, GrayAxis::Rows)?;
    let spacing = corner_spacing(corners);
    let height = columns.index.len() / columns.width.max(1);
    let mut out = ShotPoints {
        board: Vec::new(),
        pixels: Vec::new(),
        pose: 0,
        placement: None,
        weight: 1.0,
    };
    for (corner, r) in corners.iter().zip(spacing) {
        let (x0, x1) = (
            (corner.pixel.x - r).floor().max(0.0) as usize,
            (corner.pixel.x + r).ceil() as usize,
        );
        let (y0, y1) = (
            (corner.pixel.y - r).floor().max(0.0) as usize,
            (corner.pixel.y + r).ceil() as usize,
        );
        let (mut cam, mut proj) = (Vec::new(), Vec::new());
        for y in y0..y1.min(height) {
            for x in x0..x1.min(columns.width) {
                let at = y * columns.width + x;
                if let (Some(u), Some(v)) = (columns.index[at], rows.index[at]) {
                    let centre = |i: u32, finest: u32| {
                        f64::from(i) * f64::from(1u32 << finest) + 0.5 * f64::from(1u32 << finest)
                    };
                    cam.push(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
                    proj.push(DVec2::new(
                        centre(u, columns.finest),
                        centre(v, rows.finest),
                    ));
                }
            }
        }
        if cam.len() < MIN_WINDOW_PIXELS {
            continue;
        }
        let Some(h) = zhang::homography(&cam, &proj) else {
            continue;
        };
        let p = h * corner.pixel.extend(1.0);
        let p = p.truncate() / p.z;
        if p.is_finite() {
            out.board.push(board.corner(corner.i, corner.j));
            out.pixels.push(p);
        }
    }
    let share = out.board.len() as f64 / corners.len().max(1) as f64;
    if share < MIN_DECODED_SHARE {
        return Err(RigcalError::GrayCode {
            path: folder.to_path_buf(),
            reason: format!(
                "{} of {} board corners decode; the codes must light the whole board \
                 (is the projector on, the board inside its image, the exposure unsaturated?)",
                out.board.len(),
                corners.len()
            ),
        });
    }
    Ok((out, [columns.finest, rows.finest]))
}

/// Decodes one axis's Gray codes in `folder`.
fn decode(folder: &Path, size: ProjectorSize, axis: GrayAxis) -> Result<Decoded, RigcalError> {
    let bits = size.bits(axis);
    let mut differences: Vec<Vec<f32>> = Vec::with_capacity(bits as usize);
    let mut shape = None;
    for bit in 0..bits {
        let mut read = |inverted| -> Result<Vec<f32>, RigcalError> {
            let path = folder.join(graycode_file(axis, bit, inverted));
            let photo = read_shot(&path)?;
            match shape {
                Some(s) if s != (photo.width, photo.height) => Err(RigcalError::GrayCode {
                    path: path.clone(),
                    reason: format!(
                        "{}x{} pixels, unlike the other Gray-code photos",
                        photo.width, photo.height
                    ),
                }),
                _ => Ok(photo.data.iter().map(luminance).collect()),
            }
            .inspect(|_| shape = Some((photo.width, photo.height)))
        };
        let on = read(false)?;
        let off = read(true)?;
        differences.push(on.iter().zip(&off).map(|(a, b)| a - b).collect());
    }
    let (width, height) = shape.unwrap_or((0, 0));
    let pixels = width as usize * height as usize;
    let strongest: Vec<f32> = (0..pixels)
        .map(|i| differences.iter().map(|d| d[i].abs()).fold(0.0, f32::max))
        .collect();
    let floor = 0.2 * percentile(&strongest, 0.99);
    let lit: Vec<usize> = (0..pixels)
        .filter(|&i| strongest[i] > floor && floor > 0.0)
        .collect();
    if lit.is_empty() {
        return Err(RigcalError::GrayCode {
            path: folder.to_path_buf(),
            reason: format!(
                "no pixel changes between the {} codes and their inverses",
                axis.name()
            ),
        });
    }
    let trusted = |bit: usize, i: usize| differences[bit][i].abs() >= TRUST * strongest[i];
    // The finest bit that at least 90 % of lit pixels read.
    let finest = (0..bits)
        .find(|&b| {
            let read = lit.iter().filter(|&&i| trusted(b as usize, i)).count();
            read as f64 >= 0.9 * lit.len() as f64
        })
        .unwrap_or(bits);
    let mut index = vec![None; pixels];
    for &i in &lit {
        let mut gray = 0u64;
        let mut ok = true;
        for b in finest..bits {
            if !trusted(b as usize, i) {
                ok = false;
                break;
            }
            if differences[b as usize][i] > 0.0 {
                gray |= 1 << (b - finest);
            }
        }
        if ok && finest < bits {
            index[i] = Some(gray_decode(gray) as u32);
        }
    }
    Ok(Decoded {
        width: width as usize,
        index,
        finest,
    })
}
