//! The camera calibrated from a calibration bundle: corners found in every
//! shot, Zhang's closed form as the start, the joint refinement, then a
//! verdict on whether the result is good enough to scan with.

use crate::detect::{find_board_in, grey_levels, Corner};
use crate::error::RigcalError;
use crate::model::{project, Pose};
use crate::refine::{noise_weights, refine, ShotPoints};
use crate::sheet::thumbnail;
use crate::zhang;
use glam::{DMat4, DVec2};
use image::GrayImage;
use matscan_scan::calib_bundle::{BoardPlacement, CalibManifest};
use matscan_scan::camera::Intrinsics;
use matscan_scan::image_io::read_rgb;
use matscan_scan::raster::RgbRaster;
use matscan_scan::Encoding;
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// When a calibration is refused.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Acceptance {
    /// Largest reprojection RMS over all corners, pixels.
    pub max_rms_px: f64,
    /// Largest reprojection RMS of one shot, pixels: a shot above it is
    /// named for a retake (blurred, moved, or mislabelled).
    pub max_shot_rms_px: f64,
    /// Smallest share of the image's [`COVERAGE_GRID`]^2 cells that must
    /// hold a corner of some shot: distortion is only known where corners
    /// were seen.
    pub min_coverage: f64,
    /// Largest angle between the board's normal and the line of sight.
    pub max_tilt_deg: f64,
    /// Fewest shots in all.
    pub min_shots: usize,
}

impl Default for Acceptance {
    fn default() -> Self {
        Acceptance {
            max_rms_px: 0.5,
            max_shot_rms_px: 1.0,
            min_coverage: 0.5,
            max_tilt_deg: 70.0,
            min_shots: 4,
        }
    }
}

/// Cells along each image side for the coverage figure.
pub const COVERAGE_GRID: u32 = 6;

/// One shot's figures.
#[derive(Debug, Clone, Serialize)]
pub struct ShotReport {
    pub position: String,
    pub file: PathBuf,
    pub reference: bool,
    /// The mount's seat the board rested on, if a further one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seat: Option<String>,
    pub corners: usize,
    pub rms_px: f64,
    pub max_px: f64,
    /// Board normal against the line of sight, degrees.
    pub tilt_deg: f64,
    /// Board origin's distance from the camera, bundle units.
    pub distance: f64,
    /// The weight of its corners in the fit: the pooled corner noise's
    /// variance over its own ([`crate::refine::noise_weights`]); below 1
    /// for a shot noisier than the rest.
    pub weight: f64,
}

/// What the calibration found and how well it explains the photos.
#[derive(Debug, Clone, Serialize)]
pub struct CameraReport {
    #[serde(flatten)]
    pub lens: Intrinsics,
    /// One standard deviation of fx fy cx cy k1 k2 p1 p2 k3 (absent where
    /// the shots leave the system singular).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma: Option<[f64; 9]>,
    /// Reprojection RMS over every corner of every shot, pixels.
    pub rms_px: f64,
    /// Share of the image's cells (a 6 x 6 grid) with a corner in some shot.
    pub coverage: f64,
    pub iterations: usize,
    pub accepted: bool,
    /// Why the calibration is refused (empty when accepted).
    pub problems: Vec<String>,
    /// Shots to take again.
    pub retake: Vec<PathBuf>,
    /// Hand-held shots left out because the detector found no complete
    /// board in them, each with the detector's reason.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub skipped: Vec<SkippedShot>,
    pub shots: Vec<ShotReport>,
    /// Where each further seat of the mount holds the board.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seats: Vec<SeatReport>,
}

/// A hand-held shot the calibration left out.
#[derive(Debug, Clone, Serialize)]
pub struct SkippedShot {
    pub file: PathBuf,
    pub reason: String,
    /// The Gray-code folder of the pose, where it had one: the projector
    /// lost that pose too.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub graycode: Option<PathBuf>,
}

/// Where a seat of the mount holds the board, as the calibration found it.
#[derive(Debug, Clone, Serialize)]
pub struct SeatReport {
    pub name: String,
    /// The seat's board frame to the reference placement's board frame,
    /// row-major.
    pub to_reference: [f64; 16],
    /// The angle between the seat's board and the reference's, degrees.
    pub turn_deg: f64,
}

/// The camera and its pose at every position.
#[derive(Debug, Clone)]
pub struct CameraCalibration {
    pub camera: Intrinsics,
    /// Per position of the bundle, in order: its name and camera-to-world.
    pub camera_to_world: Vec<(String, DMat4)>,
    pub report: CameraReport,
    /// Corners found and reprojected per shot, in the report's order (for
    /// the contact sheet).
    pub corners: Vec<(Vec<Corner>, Vec<DVec2>)>,
    /// Each shot's board-to-camera pose, in the report's order.
    pub poses: Vec<Pose>,
    /// Each shot's grey image, [`crate::sheet::TILE`] wide, in the
    /// report's order (none when solved from corners alone).
    pub thumbnails: Vec<GrayImage>,
    /// The bundle's manifest less the skipped shots: the shots the report,
    /// `corners` and `poses` follow, which the projector's calibration
    /// reads beside them.
    pub manifest: CalibManifest,
}

/// Every shot with its position's index, positions in order.
fn shots_of(manifest: &CalibManifest) -> Vec<(usize, &matscan_scan::calib_bundle::Shot)> {
    manifest
        .positions
        .iter()
        .enumerate()
        .flat_map(|(p, pos)| pos.shots.iter().map(move |s| (p, s)))
        .collect()
}

/// An error naming `path` unless `photo` has `camera`'s size: every photo
/// of a bundle comes from the one camera.
pub(crate) fn check_size(
    photo: &RgbRaster,
    camera: &Intrinsics,
    path: &Path,
) -> Result<(), RigcalError> {
    if (photo.width, photo.height) != (camera.width, camera.height) {
        return Err(RigcalError::SizeMismatch {
            path: path.to_path_buf(),
            width: camera.width,
            height: camera.height,
            found_width: photo.width,
            found_height: photo.height,
        });
    }
    Ok(())
}

/// Reads a shot: EXR photos are linear; PNG photos are taken as sRGB, as
/// cameras write them (the detector does not need linear light).
pub fn read_shot(path: &Path) -> Result<RgbRaster, RigcalError> {
    let encoding = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        .then_some(Encoding::Srgb);
    Ok(read_rgb(path, encoding)?)
}

/// Calibrates the camera from the bundle in `dir` (its `calib.toml` is
/// `manifest`). A hand-held shot without a complete board is left out and
/// named in `report.skipped`: the other hand-held shots stand for it, as
/// long as enough remain. Fails on a resting board's photo (the reference
/// or a seat, on which a position's pose rests) without a complete board,
/// on too few or edge-on shots, or when the shots do not determine the
/// camera; a calibration that explains the photos poorly is returned with
/// `report.accepted` false and the reasons.
pub fn calibrate_camera(
    dir: &Path,
    manifest: &CalibManifest,
    acceptance: &Acceptance,
) -> Result<CameraCalibration, RigcalError> {
    let board = manifest.board;
    let shots = shots_of(manifest);
    if shots.len() < acceptance.min_shots {
        return Err(RigcalError::TooFewShots {
            found: shots.len(),
            needed: acceptance.min_shots,
        });
    }
    type Found = Result<((u32, u32), Vec<Corner>, GrayImage), RigcalError>;
    let found: Vec<Found> = shots
        .par_iter()
        .map(|(_, shot)| {
            let path = dir.join(&shot.file);
            let photo = read_shot(&path)?;
            let grey = grey_levels(&photo);
            let corners = find_board_in(&photo, &grey, &board, &path)?;
            Ok(((photo.width, photo.height), corners, thumbnail(&grey)))
        })
        .collect();
    let mut detections = Vec::with_capacity(found.len());
    let mut skipped = Vec::new();
    let mut kept = manifest.clone();
    for position in &mut kept.positions {
        position.shots.clear();
    }
    for (r, (p, shot)) in found.into_iter().zip(&shots) {
        match r {
            Ok(d) => {
                detections.push(d);
                kept.positions[*p].shots.push((*shot).clone());
            }
            Err(RigcalError::BoardNotFound { reason, .. })
                if shot.placement == BoardPlacement::Held =>
            {
                skipped.push(SkippedShot {
                    file: shot.file.clone(),
                    reason,
                    graycode: shot.graycode.clone(),
                });
            }
            Err(e) => return Err(e),
        }
    }
    let Some(&((width, height), _, _)) = detections.first() else {
        return Err(RigcalError::TooFewShots {
            found: 0,
            needed: acceptance.min_shots.max(1),
        });
    };
    for ((size, _, _), (_, shot)) in detections.iter().zip(shots_of(&kept)) {
        if *size != (width, height) {
            return Err(RigcalError::SizeMismatch {
                path: dir.join(&shot.file),
                width,
                height,
                found_width: size.0,
                found_height: size.1,
            });
        }
    }
    let (corners, thumbnails) = detections.into_iter().map(|(_, c, t)| (c, t)).unzip();
    let mut calibration = solve_camera(dir, &kept, corners, (width, height), acceptance)?;
    calibration.thumbnails = thumbnails;
    calibration.report.skipped = skipped;
    Ok(calibration)
}

/// The camera from corners already found: one list per shot, in the
/// manifest's order (positions, then shots); `dir` names photos in errors.
///
/// A position's shots of a resting board (the reference and any further
/// seat) share that position's one camera pose; a seat's own placement is
/// unknown and shared by every position that photographed it, so the
/// reference and a seat at another angle make a target with depth, which
/// parts a camera's distance from its focal length.
pub fn solve_camera(
    dir: &Path,
    manifest: &CalibManifest,
    detections: Vec<Vec<Corner>>,
    (width, height): (u32, u32),
    acceptance: &Acceptance,
) -> Result<CameraCalibration, RigcalError> {
    let board = manifest.board;
    let shots: Vec<(usize, &matscan_scan::calib_bundle::Shot)> = shots_of(manifest);
    if shots.len() < acceptance.min_shots || detections.len() != shots.len() {
        return Err(RigcalError::TooFewShots {
            found: detections.len().min(shots.len()),
            needed: acceptance.min_shots,
        });
    }
    let points: Vec<ShotPoints> = detections
        .iter()
        .enumerate()
        .map(|(k, corners)| ShotPoints {
            board: corners.iter().map(|c| board.corner(c.i, c.j)).collect(),
            pixels: corners.iter().map(|c| c.pixel).collect(),
            pose: k,
            placement: None,
            weight: 1.0,
        })
        .collect();
    let homographies = points
        .iter()
        .zip(&shots)
        .map(|(sp, (_, shot))| {
            let plane: Vec<DVec2> = sp.board.iter().map(|x| x.truncate()).collect();
            zhang::homography(&plane, &sp.pixels).ok_or_else(|| {
                RigcalError::Degenerate(format!(
                    "{}: the corners do not define a plane's image",
                    dir.join(&shot.file).display()
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let start = zhang::intrinsics(&homographies, width, height)?;
    let mut shot_poses = Vec::with_capacity(shots.len());
    for (h, (_, shot)) in homographies.iter().zip(&shots) {
        let path = dir.join(&shot.file);
        let pose = zhang::pose(h, &start).ok_or_else(|| {
            RigcalError::Degenerate(format!("{}: no board pose fits", path.display()))
        })?;
        if pose.tilt_deg() > acceptance.max_tilt_deg {
            return Err(RigcalError::EdgeOn {
                path,
                tilt_deg: pose.tilt_deg(),
                limit_deg: acceptance.max_tilt_deg,
            });
        }
        shot_poses.push(pose);
    }
    let Unknowns {
        poses,
        points: fit_points,
        position_pose,
        seats,
    } = unknowns(dir, manifest, &shots, &points, &shot_poses)?;
    // Equal weights first; then each shot weighted by its own corners'
    // noise, read from that fit's residuals, and the fit run again from
    // there. Corner noise differs per shot (an averaged resting photo
    // against a steep hand-held one), and weighting by it took the
    // camera's position error on `calib board`'s rigs from 1.05 / 0.77 /
    // 0.16 mm to 0.89 / 0.68 / 0.16 (docs/results.md).
    let mut fit_points = fit_points;
    let first = refine(&start, &poses, &fit_points, crate::refine::CAMERA_FIXED);
    let weights = noise_weights(&first.camera, &first.poses, &fit_points);
    for (sp, w) in fit_points.iter_mut().zip(weights) {
        sp.weight = w;
    }
    let mut refined = refine(
        &first.camera,
        &first.poses,
        &fit_points,
        crate::refine::CAMERA_FIXED,
    );
    let camera_to_world = manifest
        .positions
        .iter()
        .zip(&position_pose)
        .map(|(position, index)| {
            let reference = index.map_or(DMat4::IDENTITY, |i| refined.poses[i].matrix());
            (
                position.name.clone(),
                manifest.reference_to_world * reference.inverse(),
            )
        })
        .collect();
    let seats: Vec<SeatReport> = seats
        .into_iter()
        .map(|(name, i)| SeatReport {
            name,
            to_reference: matscan_scan::camera::mat4_to_row_major(&refined.poses[i].matrix()),
            turn_deg: refined.poses[i].rotation.length().to_degrees(),
        })
        .collect();
    // Each shot's own board-to-camera pose, for the report and the projector.
    refined.poses = fit_points
        .iter()
        .map(|sp| {
            let pose = refined.poses[sp.pose];
            sp.placement.map_or(pose, |seat| {
                Pose::from_matrix(&(pose.matrix() * refined.poses[seat].matrix()))
            })
        })
        .collect();
    Ok(judge(
        manifest,
        &shots,
        detections,
        &fit_points,
        refined,
        (camera_to_world, seats),
        acceptance,
    ))
}

/// What the joint refinement moves, and which shot hangs on what.
struct Unknowns {
    poses: Vec<Pose>,
    /// Each shot's points, in the frame of its pose (or its seat's).
    points: Vec<ShotPoints>,
    /// Per position, the index of its pose (the reference board's frame
    /// to the camera); `None` for a position without a resting board.
    position_pose: Vec<Option<usize>>,
    /// Per seat, its name and the index of its pose (its board's frame to
    /// the reference board's).
    seats: Vec<(String, usize)>,
}

/// One pose per position, per held shot and per seat, each started from
/// the closed-form shot poses: a position's from its view of the
/// reference, a seat's from the first position that saw it.
fn unknowns(
    dir: &Path,
    manifest: &CalibManifest,
    shots: &[(usize, &matscan_scan::calib_bundle::Shot)],
    points: &[ShotPoints],
    shot_poses: &[Pose],
) -> Result<Unknowns, RigcalError> {
    fn own(poses: &mut Vec<Pose>, pose: Pose) -> usize {
        poses.push(pose);
        poses.len() - 1
    }
    let mut poses: Vec<Pose> = Vec::new();
    let mut position_pose: Vec<Option<usize>> = vec![None; manifest.positions.len()];
    let mut seats: Vec<(String, usize)> = Vec::new();
    // Reference shots first, so that every position's pose exists when its
    // seat shots come.
    let is_reference = |k: &usize| shots[*k].1.placement == BoardPlacement::Reference;
    let order = (0..points.len())
        .filter(is_reference)
        .chain((0..points.len()).filter(|k| !is_reference(k)));
    let mut assigned: Vec<Option<ShotPoints>> = vec![None; points.len()];
    for k in order {
        let (p, shot) = shots[k];
        let (pose, placement) = match &shot.placement {
            BoardPlacement::Held => (own(&mut poses, shot_poses[k]), None),
            BoardPlacement::Reference => (
                *position_pose[p].get_or_insert_with(|| own(&mut poses, shot_poses[k])),
                None,
            ),
            BoardPlacement::Seat(name) => {
                let Some(index) = position_pose[p] else {
                    return Err(RigcalError::Degenerate(format!(
                        "{}: a board on seat {name} needs the reference photographed from the \
                         same position",
                        dir.join(&shot.file).display()
                    )));
                };
                let seat = match seats.iter().find(|(n, _)| n == name) {
                    Some(&(_, i)) => i,
                    None => {
                        let start = poses[index].matrix().inverse() * shot_poses[k].matrix();
                        let i = own(&mut poses, Pose::from_matrix(&start));
                        seats.push((name.clone(), i));
                        i
                    }
                };
                (index, Some(seat))
            }
        };
        assigned[k] = Some(ShotPoints {
            board: points[k].board.clone(),
            pixels: points[k].pixels.clone(),
            pose,
            placement,
            weight: 1.0,
        });
    }
    Ok(Unknowns {
        poses,
        points: assigned.into_iter().flatten().collect(),
        position_pose,
        seats,
    })
}

fn judge(
    manifest: &CalibManifest,
    shots: &[(usize, &matscan_scan::calib_bundle::Shot)],
    detections: Vec<Vec<Corner>>,
    points: &[ShotPoints],
    refined: crate::refine::Refined,
    (camera_to_world, seats): (Vec<(String, DMat4)>, Vec<SeatReport>),
    acceptance: &Acceptance,
) -> CameraCalibration {
    let camera = refined.camera;
    let mut reports = Vec::with_capacity(shots.len());
    let mut reprojected = Vec::with_capacity(shots.len());
    let (mut sum, mut count) = (0.0, 0usize);
    let mut cells = vec![false; (COVERAGE_GRID * COVERAGE_GRID) as usize];
    for ((sp, pose), (p, shot)) in points.iter().zip(&refined.poses).zip(shots) {
        let projected: Vec<DVec2> = sp
            .board
            .iter()
            .map(|&x| project(&camera, pose, x))
            .collect();
        let errors: Vec<f64> = projected
            .iter()
            .zip(&sp.pixels)
            .map(|(a, b)| (*a - *b).length())
            .collect();
        let squares: f64 = errors.iter().map(|e| e * e).sum();
        sum += squares;
        count += errors.len();
        for px in &sp.pixels {
            let cx = ((px.x / f64::from(camera.width)) * f64::from(COVERAGE_GRID)) as i64;
            let cy = ((px.y / f64::from(camera.height)) * f64::from(COVERAGE_GRID)) as i64;
            let g = i64::from(COVERAGE_GRID);
            if (0..g).contains(&cx) && (0..g).contains(&cy) {
                cells[(cy * g + cx) as usize] = true;
            }
        }
        reports.push(ShotReport {
            position: manifest.positions[*p].name.clone(),
            file: shot.file.clone(),
            reference: shot.placement == BoardPlacement::Reference,
            seat: match &shot.placement {
                BoardPlacement::Seat(name) => Some(name.clone()),
                _ => None,
            },
            corners: errors.len(),
            rms_px: (squares / errors.len().max(1) as f64).sqrt(),
            max_px: errors.iter().copied().fold(0.0, f64::max),
            tilt_deg: pose.tilt_deg(),
            distance: pose.translation.length(),
            weight: sp.weight,
        });
        reprojected.push(projected);
    }
    let rms_px = (sum / count.max(1) as f64).sqrt();
    let coverage = cells.iter().filter(|c| **c).count() as f64 / cells.len() as f64;
    let mut problems = Vec::new();
    let retake: Vec<PathBuf> = reports
        .iter()
        .filter(|r| r.rms_px.is_nan() || r.rms_px > acceptance.max_shot_rms_px)
        .map(|r| r.file.clone())
        .collect();
    if rms_px.is_nan() || rms_px > acceptance.max_rms_px {
        problems.push(format!(
            "reprojection RMS {rms_px:.3} px is above {:.2} px",
            acceptance.max_rms_px
        ));
    }
    if !retake.is_empty() {
        problems.push(format!(
            "{} shot(s) reproject worse than {:.2} px RMS (blur, a moved board, or glare): \
             retake them",
            retake.len(),
            acceptance.max_shot_rms_px
        ));
    }
    if coverage < acceptance.min_coverage {
        problems.push(format!(
            "corners cover {:.0} % of the image, at least {:.0} % is needed: add shots with \
             the board near the image's edges and corners",
            100.0 * coverage,
            100.0 * acceptance.min_coverage
        ));
    }
    CameraCalibration {
        camera,
        camera_to_world,
        report: CameraReport {
            lens: camera,
            sigma: refined.sigma,
            rms_px,
            coverage,
            iterations: refined.iterations,
            accepted: problems.is_empty(),
            problems,
            retake,
            skipped: Vec::new(),
            shots: reports,
            seats,
        },
        corners: detections.into_iter().zip(reprojected).collect(),
        poses: refined.poses,
        thumbnails: Vec::new(),
        manifest: manifest.clone(),
    }
}
