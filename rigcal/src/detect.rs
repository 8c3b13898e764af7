//! Finding the board's inner corners in a photo, labelled by their place on
//! the print.
//!
//! The detector (`calib-targets`: ChESS corners, grid growth and
//! validation, subpixel positions) works on 8-bit grey, so the linear photo
//! is brought to display levels first: luminance over its 99.5th
//! percentile, then a 1/2.2 power, which gives the black and white squares
//! the contrast a printed board has in an ordinary photo whatever the
//! exposure. Only a complete board is accepted: a missing corner would
//! shift the labels of a plain chessboard, and a labelling shifted by one
//! square calibrates a wrong camera without any error to show for it.

use crate::error::RigcalError;
use calib_targets::chessboard::ChessboardParams;
use calib_targets::detect::{default_chess_config, detect_chessboard_best};
use glam::DVec2;
use matscan_scan::calib_bundle::Chessboard;
use matscan_scan::raster::RgbRaster;
use std::path::Path;

/// Where the detector's pixel (0, 0) centre lies in the contract's pixel
/// coordinates (centres at integer + 0.5).
const DETECTOR_TO_CONTRACT: f64 = 0.5;

/// One inner corner: its label on the board and where the photo shows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corner {
    /// Column and row of the inner corner on the board.
    pub i: u32,
    pub j: u32,
    /// Pixel position, contract convention.
    pub pixel: DVec2,
}

/// Rec. 709 luminance of a linear RGB pixel; 0 where it is not finite, so
/// a bad pixel reads as dark rather than poisoning a sum.
pub(crate) fn luminance(p: &[f32; 3]) -> f32 {
    let y = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    if y.is_finite() {
        y
    } else {
        0.0
    }
}

/// A float ordered totally (NaN included), so that selection never sees
/// an inconsistent order.
pub(crate) trait TotalOrder: Copy + Default {
    fn total(&self, other: &Self) -> std::cmp::Ordering;
}

impl TotalOrder for f32 {
    fn total(&self, other: &Self) -> std::cmp::Ordering {
        self.total_cmp(other)
    }
}

impl TotalOrder for f64 {
    fn total(&self, other: &Self) -> std::cmp::Ordering {
        self.total_cmp(other)
    }
}

/// The `q`-quantile of `values` (0 for none), by selection rather than a
/// full sort: the photos have a million pixels.
pub(crate) fn percentile<T: TotalOrder>(values: &[T], q: f64) -> T {
    if values.is_empty() {
        return T::default();
    }
    let mut v = values.to_vec();
    let k = ((v.len() as f64 * q) as usize).min(v.len() - 1);
    *v.select_nth_unstable_by(k, T::total).1
}

/// The photo's display-level grey image (see the module doc).
pub fn grey_levels(photo: &RgbRaster) -> image::GrayImage {
    let luminance: Vec<f32> = photo.data.iter().map(|p| luminance(p).max(0.0)).collect();
    let top = percentile(&luminance, 0.995).max(1e-12);
    let pixels = luminance
        .iter()
        .map(|&y| ((y / top).clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8)
        .collect();
    image::GrayImage::from_raw(photo.width, photo.height, pixels)
        .unwrap_or_else(|| image::GrayImage::new(photo.width, photo.height))
}

/// The board's inner corners in `photo`, every one of them, labelled so
/// that corner (0, 0) is the one the photo shows top left; `path` names the
/// photo in errors.
pub fn find_board(
    photo: &RgbRaster,
    board: &Chessboard,
    path: &Path,
) -> Result<Vec<Corner>, RigcalError> {
    find_board_in(photo, &grey_levels(photo), board, path)
}

/// [`find_board`] with the photo's [`grey_levels`] already made.
pub fn find_board_in(
    photo: &RgbRaster,
    grey: &image::GrayImage,
    board: &Chessboard,
    path: &Path,
) -> Result<Vec<Corner>, RigcalError> {
    let not_found = |reason: String| RigcalError::BoardNotFound {
        path: path.to_path_buf(),
        reason,
    };
    let detection = detect_chessboard_best(
        grey,
        &default_chess_config(),
        &ChessboardParams::sweep_default(),
    )
    .map_err(|e| not_found(format!("no chessboard found ({e})")))?;
    let labels = || detection.corners.iter().map(|c| (c.grid.u, c.grid.v));
    let (min_u, max_u) = bounds(labels().map(|l| l.0));
    let (min_v, max_v) = bounds(labels().map(|l| l.1));
    let (span_u, span_v) = (max_u - min_u + 1, max_v - min_v + 1);
    let (cols, rows) = (board.cols as i32, board.rows as i32);
    if (span_u, span_v) == (rows, cols) && detection.corners.len() == board.corner_count() {
        return Err(not_found(format!(
            "the board is turned a quarter: its {cols} corner columns run down the photo"
        )));
    }
    let found: std::collections::HashMap<(i32, i32), DVec2> = detection
        .corners
        .iter()
        .map(|c| {
            (
                (c.grid.u, c.grid.v),
                DVec2::new(
                    f64::from(c.position.x) + DETECTOR_TO_CONTRACT,
                    f64::from(c.position.y) + DETECTOR_TO_CONTRACT,
                ),
            )
        })
        .collect();
    let origin = if (span_u, span_v) == (cols, rows)
        && 10 * detection.corners.len() >= 9 * board.corner_count()
    {
        // The whole board's outline, a few inner corners missed (a square
        // too foreshortened or blurred to show its saddle): the labels are
        // still the board's, and the solver uses the corners it has.
        Some((min_u, min_v))
    } else if span_u >= cols && span_v >= rows {
        // More than the board: a row or column of false corners along its
        // outline (where the margin meets the background). The board is
        // the window of its size whose corners a plane's homography fits.
        best_window(&found, board, (min_u, max_u), (min_v, max_v))
    } else {
        None
    };
    let Some((u0, v0)) = origin else {
        return Err(not_found(format!(
            "found {} corners spanning {span_u} x {span_v}, expected all {} of the \
             board's {cols} x {rows}",
            detection.corners.len(),
            board.corner_count()
        )));
    };
    let mut corners: Vec<Corner> = (0..rows)
        .flat_map(|j| (0..cols).map(move |i| (i, j)))
        .filter_map(|(i, j)| {
            found.get(&(u0 + i, v0 + j)).map(|&pixel| Corner {
                i: i as u32,
                j: j as u32,
                pixel,
            })
        })
        .collect();
    let luminance = Luminance::of(photo);
    let spacing = corner_spacing(&corners);
    for (corner, gap) in corners.iter_mut().zip(spacing) {
        // The window stays inside the four squares that meet here.
        let radius = (0.35 * gap).clamp(2.0, 12.0);
        if let Some(p) = refine_saddle(&luminance, corner.pixel, radius) {
            corner.pixel = p;
        }
    }
    Ok(corners)
}

/// Per corner, the distance to its nearest labelled neighbour, pixels (8
/// for a corner without one).
pub(crate) fn corner_spacing(corners: &[Corner]) -> Vec<f64> {
    corners
        .iter()
        .map(|c| {
            corners
                .iter()
                .filter(|o| o.i.abs_diff(c.i) + o.j.abs_diff(c.j) == 1)
                .map(|o| (o.pixel - c.pixel).length())
                .fold(f64::INFINITY, f64::min)
        })
        .map(|d| if d.is_finite() { d } else { 8.0 })
        .collect()
}

/// Linear luminance, finite and non-negative, for the subpixel step.
struct Luminance {
    width: usize,
    height: usize,
    values: Vec<f64>,
}

impl Luminance {
    fn of(photo: &RgbRaster) -> Luminance {
        Luminance {
            width: photo.width as usize,
            height: photo.height as usize,
            values: photo
                .data
                .iter()
                .map(|p| f64::from(luminance(p).max(0.0)))
                .collect(),
        }
    }

    fn at(&self, x: usize, y: usize) -> f64 {
        self.values[y * self.width + x]
    }
}

/// The saddle point of the corner near `start` by gradient orthogonality
/// (OpenCV's `cornerSubPix`, Foerstner's operator): every edge pixel's
/// gradient is orthogonal to the line from the corner to it, so the corner
/// solves `sum(g g^T) q = sum(g g^T p)` over a Gaussian-weighted window.
/// `None` when the window leaves the image or holds no edge.
fn refine_saddle(image: &Luminance, start: DVec2, radius: f64) -> Option<DVec2> {
    let r = radius.ceil() as i64;
    let sigma2 = 2.0 * (0.5 * radius).powi(2);
    let mut q = start;
    for _ in 0..20 {
        // Pixel (x, y) has its centre at (x + 0.5, y + 0.5).
        let (cx, cy) = ((q.x - 0.5).round() as i64, (q.y - 0.5).round() as i64);
        if cx - r < 1
            || cy - r < 1
            || cx + r + 1 >= image.width as i64
            || cy + r + 1 >= image.height as i64
        {
            return None;
        }
        let (mut a, mut b, mut c, mut bx, mut by) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for y in (cy - r)..=(cy + r) {
            for x in (cx - r)..=(cx + r) {
                let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                let d2 = (p - q).length_squared();
                if d2 > radius * radius {
                    continue;
                }
                let (xu, yu) = (x as usize, y as usize);
                let gx = 0.5 * (image.at(xu + 1, yu) - image.at(xu - 1, yu));
                let gy = 0.5 * (image.at(xu, yu + 1) - image.at(xu, yu - 1));
                let w = (-d2 / sigma2).exp();
                let (gxx, gxy, gyy) = (w * gx * gx, w * gx * gy, w * gy * gy);
                a += gxx;
                b += gxy;
                c += gyy;
                bx += gxx * p.x + gxy * p.y;
                by += gxy * p.x + gyy * p.y;
            }
        }
        let det = a * c - b * b;
        if !(det.is_finite() && det > 1e-12 * (a + c).powi(2)) {
            return None;
        }
        let next = DVec2::new((c * bx - b * by) / det, (a * by - b * bx) / det);
        if !next.is_finite() || (next - start).length() > radius {
            return None;
        }
        let moved = (next - q).length();
        q = next;
        if moved < 1e-4 {
            break;
        }
    }
    Some(q)
}

/// Largest RMS, pixels, of the detector's corners of a board window about
/// the homography fitted to them; the detector's positions are good to a
/// few tenths of a pixel, a false row lies half a square off.
const WINDOW_FIT_PX: f64 = 1.0;

/// The grid origin of the board-sized window of `found` corners that a
/// plane's homography fits best, when it fits within [`WINDOW_FIT_PX`].
pub(crate) fn best_window(
    found: &std::collections::HashMap<(i32, i32), DVec2>,
    board: &Chessboard,
    (min_u, max_u): (i32, i32),
    (min_v, max_v): (i32, i32),
) -> Option<(i32, i32)> {
    let (cols, rows) = (board.cols as i32, board.rows as i32);
    let mut best: Option<(f64, (i32, i32))> = None;
    for u0 in min_u..=(max_u - cols + 1) {
        for v0 in min_v..=(max_v - rows + 1) {
            let pairs: Option<Vec<(DVec2, DVec2)>> = (0..rows)
                .flat_map(|j| (0..cols).map(move |i| (i, j)))
                .map(|(i, j)| {
                    found
                        .get(&(u0 + i, v0 + j))
                        .map(|&px| (board.corner(i as u32, j as u32).truncate(), px))
                })
                .collect();
            let Some(pairs) = pairs else { continue };
            let (plane, pixels): (Vec<DVec2>, Vec<DVec2>) = pairs.into_iter().unzip();
            let Some(h) = crate::zhang::homography(&plane, &pixels) else {
                continue;
            };
            let rms = (plane
                .iter()
                .zip(&pixels)
                .map(|(p, px)| {
                    let q = h * p.extend(1.0);
                    (q.truncate() / q.z - *px).length_squared()
                })
                .sum::<f64>()
                / plane.len() as f64)
                .sqrt();
            if rms.is_finite() && best.is_none_or(|(b, _)| rms < b) {
                best = Some((rms, (u0, v0)));
            }
        }
    }
    best.filter(|(rms, _)| *rms <= WINDOW_FIT_PX)
        .map(|(_, o)| o)
}

fn bounds(values: impl Iterator<Item = i32>) -> (i32, i32) {
    values.fold((i32::MAX, i32::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)))
}
