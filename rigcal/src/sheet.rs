//! The contact sheet: every shot small, its found corners marked and each
//! corner's reprojection error drawn as a line magnified [`MAGNIFY`] times,
//! so a user sees at a glance which shot is off and where.

use crate::camera::CameraCalibration;
use crate::error::RigcalError;
use image::{GrayImage, Rgb, RgbImage};
use matscan_scan::atomic::write_atomic;
use std::path::{Path, PathBuf};

/// Width of one shot's tile, pixels.
pub const TILE: u32 = 320;
/// Error lines are this many times their length.
pub const MAGNIFY: f64 = 50.0;
/// The sheet's file name in the output folder.
pub const SHEET_FILE: &str = "contact-sheet.png";
const COLUMNS: u32 = 4;

/// A shot's grey image scaled to [`TILE`] wide, as the sheet shows it.
pub fn thumbnail(grey: &GrayImage) -> GrayImage {
    let (w, h) = (grey.width().max(1), grey.height());
    let tile_h = ((f64::from(h) * f64::from(TILE) / f64::from(w)).round() as u32).max(1);
    image::imageops::resize(grey, TILE, tile_h, image::imageops::FilterType::Triangle)
}

/// Draws the sheet of `calibration` from its shots' thumbnails (a shot
/// without one gets a black tile).
pub fn contact_sheet(calibration: &CameraCalibration) -> RgbImage {
    let (w, h) = (
        calibration.camera.width.max(1),
        calibration.camera.height.max(1),
    );
    let scale = f64::from(TILE) / f64::from(w);
    let tile_h = ((f64::from(h) * scale).round() as u32).max(1);
    let shots = calibration.corners.len() as u32;
    let rows = shots.div_ceil(COLUMNS).max(1);
    let mut sheet = RgbImage::new(TILE * COLUMNS, tile_h * rows);
    for (k, (corners, reprojected)) in calibration.corners.iter().enumerate() {
        let (ox, oy) = ((k as u32 % COLUMNS) * TILE, (k as u32 / COLUMNS) * tile_h);
        if let Some(small) = calibration.thumbnails.get(k) {
            for (x, y, p) in small.enumerate_pixels() {
                if x < TILE && y < tile_h {
                    let v = p.0[0] / 2 + 64;
                    sheet.put_pixel(ox + x, oy + y, Rgb([v, v, v]));
                }
            }
        }
        let mut plot = |x: f64, y: f64, colour: Rgb<u8>| {
            let (x, y) = (x * scale, y * scale);
            if x >= 0.0 && y >= 0.0 && x < f64::from(TILE) && y < f64::from(tile_h) {
                sheet.put_pixel(ox + x as u32, oy + y as u32, colour);
            }
        };
        for (c, r) in corners.iter().zip(reprojected) {
            let error = (*r - c.pixel) * MAGNIFY;
            let steps = (error.length() * scale).ceil().max(1.0) as usize;
            for s in 0..=steps {
                let p = c.pixel + error * (s as f64 / steps as f64);
                plot(p.x, p.y, Rgb([255, 40, 40]));
            }
            for d in -2..=2 {
                let d = f64::from(d) / scale;
                plot(c.pixel.x + d, c.pixel.y, Rgb([40, 255, 40]));
                plot(c.pixel.x, c.pixel.y + d, Rgb([40, 255, 40]));
            }
        }
    }
    sheet
}

/// Draws the sheet and writes it to `out_dir` atomically.
pub fn write_contact_sheet(
    calibration: &CameraCalibration,
    out_dir: &Path,
) -> Result<PathBuf, RigcalError> {
    let sheet = contact_sheet(calibration);
    let path = out_dir.join(SHEET_FILE);
    let mut bytes = Vec::new();
    sheet
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| {
            RigcalError::Scan(matscan_scan::ScanError::Format {
                path: path.clone(),
                message: e.to_string(),
            })
        })?;
    write_atomic(&path, &bytes)?;
    Ok(path)
}
