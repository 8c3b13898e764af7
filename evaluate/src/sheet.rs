//! Contact sheets: one PNG showing a bundle at a glance, the way the
//! thesis's figure 3.4 shows a scene — every capture of every position, the
//! mask, the truth maps and estimates where present. Renderer bugs are
//! easiest seen here.
//!
//! Where the scan has an estimate, the sheet opens with it, at the
//! estimate's reference position: the photo under the first flash beside
//! the estimated material re-rendered under a light the rig never had
//! (`key-left` of [`crate::rerender`]) and, for a simulated scan, the true
//! material under the same light; then per parameter the truth, the
//! estimate and the error map `|estimate - truth|` (0 black, 0.5 and above
//! white, through red and yellow), its MAD in the label.
//!
//! Photos are shown as radiance (divided by exposure) with one exposure per
//! position, so the relative brightness of captures stays comparable: the
//! 99.5th percentile of luminance over all of a position's photos maps to
//! white. Maps in [0, 1] are shown as they are, in sRGB; re-renders
//! through the Reinhard curve of [`crate::image_metrics`].

use crate::image_metrics::{compare, reinhard};
use crate::plot::font;
use crate::render::{estimated_textures, reference_position, true_textures};
use crate::rerender::{material_from_textures, LightName, Lighting, RenderSettings, ScanObject};
use anyhow::{Context, Result};
use matscan_calib::{calibrate_bundle, CalibOptions, PixelMaps, ScanCalibration};
use matscan_estimate::pipeline::metrics::error_metrics;
use matscan_scan::bundle::TruthImage;
use matscan_scan::estimate_maps::{read_position_maps, MapValues, ESTIMATE_DIR};
use matscan_scan::raster::{MaskRaster, Raster, RgbRaster, ScalarRaster};
use matscan_scan::{Bundle, Param, TruthMap};
use std::path::Path;

/// One labelled picture on the sheet.
struct Tile {
    label: String,
    width: u32,
    height: u32,
    /// Linear RGB, clamped to [0, 1].
    rgb: Vec<f32>,
}

/// Label text size, pixels.
const TEXT_PX: f32 = 11.0;
const GAP: u32 = 4;
const MAX_TILE: u32 = 256;
/// The error that maps to white on an error map.
const ERROR_WHITE: f32 = 0.5;
/// Samples per pixel of the sheet's re-renders, and their texture side.
const RERENDER_SAMPLES: u32 = 16;
const RERENDER_TEXELS: u32 = 256;

/// Draws the contact sheet of the bundle at `scan` into `out` (PNG).
pub fn draw_contact_sheet(scan: &Path, out: &Path) -> Result<()> {
    let bundle = Bundle::open(scan).with_context(|| format!("opening scan {}", scan.display()))?;
    // Calibration maps are drawn too: a pose or light mix-up shows as maps
    // that disagree with the photos above them. A scan that cannot be
    // calibrated still gets its sheet, with the reason on stderr.
    let calibration = match calibrate_bundle(&bundle, &CalibOptions::default()) {
        Ok(c) => Some(c),
        Err(e) => {
            eprintln!("warning: no calibration rows on the sheet: {e}");
            None
        }
    };
    let mut rows: Vec<(String, Vec<Tile>)> = Vec::new();
    let estimate_dir = scan.join(ESTIMATE_DIR);
    let estimated_at = if estimate_dir.is_dir() {
        let reference = reference_position(&bundle, &estimate_dir)?;
        let estimate = estimate_rows(&bundle, &estimate_dir, &reference, calibration.as_ref())?;
        let has_rows = !estimate.is_empty();
        rows.extend(estimate);
        has_rows.then_some(reference)
    } else {
        None
    };
    for position in &bundle.manifest.positions {
        let mut photos = Vec::new();
        for capture in &position.captures {
            let img = bundle
                .read_photo(&position.name, &capture.name)
                .with_context(|| format!("position {} capture {}", position.name, capture.name))?;
            let scale = 1.0 / capture.exposure_s.max(1e-12) as f32;
            photos.push((capture.name.clone(), img.map(|p| p.map(|c| c * scale))));
        }
        let white = white_point(photos.iter().map(|(_, r)| r));
        let mut tiles: Vec<Tile> = photos
            .iter()
            .map(|(name, r)| tile_rgb(name, &r.map(|p| p.map(|c| c / white))))
            .collect();
        if let Some(mask) = bundle.read_mask(&position.name)? {
            tiles.push(tile_mask("mask", &mask));
        }
        rows.push((format!("{} captures", position.name), tiles));

        let mut truth = Vec::new();
        for param in Param::ALL {
            let label = format!("true {param}");
            match bundle.read_truth(&position.name, &TruthMap::Param(param))? {
                Some(TruthImage::Rgb(map)) => truth.push(tile_rgb(&label, &map)),
                Some(TruthImage::Scalar(map)) => truth.push(tile_scalar(&label, &map)),
                Some(TruthImage::Mask(map)) => truth.push(tile_mask(&label, &map)),
                None => {}
            }
        }
        for capture in &position.captures {
            let illum = TruthMap::Illum(capture.name.clone());
            if let Some(TruthImage::Rgb(map)) = bundle.read_truth(&position.name, &illum)? {
                let w = white_point(std::iter::once(&map));
                truth.push(tile_rgb(
                    &format!("illum {}", capture.name),
                    &map.map(|p| p.map(|c| c / w)),
                ));
            }
        }
        if !truth.is_empty() {
            rows.push((format!("{} truth", position.name), truth));
        }

        if let Some(pc) = calibration
            .as_ref()
            .and_then(|c| c.position(&position.name))
        {
            rows.push((format!("{} calib", position.name), calib_tiles(&pc.maps)));
        }

        if estimated_at.as_deref() == Some(position.name.as_str()) {
            continue;
        }
        let mut estimates = Vec::new();
        for param in Param::ALL {
            let path = scan
                .join(matscan_estimate::pipeline::output::ESTIMATE_DIR)
                .join(&position.name)
                .join(format!("{param}.exr"));
            if path.exists() {
                let map = matscan_scan::image_io::read_rgb(&path, None)
                    .with_context(|| format!("reading estimate {}", path.display()))?;
                estimates.push(tile_rgb(&format!("est {param}"), &map));
            }
        }
        if !estimates.is_empty() {
            rows.push((format!("{} estimate", position.name), estimates));
        }
    }
    let title = format!("{}  {}", bundle.manifest.name, scan.display());
    compose(&title, &rows, out)
}

/// The estimate at `reference` against the truth (see the module doc);
/// empty when that position has no maps.
fn estimate_rows(
    bundle: &Bundle,
    estimate_dir: &Path,
    reference: &str,
    calibration: Option<&ScanCalibration>,
) -> Result<Vec<(String, Vec<Tile>)>> {
    let Some(maps) = read_position_maps(estimate_dir, reference)
        .with_context(|| format!("reading the estimate of position {reference}"))?
    else {
        return Ok(Vec::new());
    };
    let mut rows = vec![(
        format!("{reference} re-render"),
        rerender_tiles(bundle, estimate_dir, reference, calibration)?,
    )];
    let mask = match bundle.read_truth(reference, &TruthMap::Mask)? {
        Some(TruthImage::Mask(m)) => Some(m),
        _ => None,
    };
    for param in Param::ALL {
        let Some(map) = maps.get(param) else {
            continue;
        };
        let truth = bundle.truth_param(reference, param)?;
        let mut tiles = Vec::new();
        if let Some(truth) = &truth {
            tiles.push(tile_values(&format!("true {param}"), truth));
        }
        tiles.push(tile_values(&format!("estimated {param}"), map.values()));
        if let (Some(truth), Some(mask)) = (&truth, &mask) {
            if let Some((error, mad)) = error_map(map.values(), truth, mask) {
                tiles.push(tile_rgb(&format!("|error| MAD {mad:.3}"), &error));
            }
        }
        rows.push((format!("{reference} {param}"), tiles));
    }
    Ok(rows)
}

/// The photo under the first flash at `reference`, the estimated material
/// re-rendered under a novel light from the same camera and, with truth
/// maps, the true material under that light (PSNR of the estimate's render
/// against the truth's in its label). A scan whose estimate cannot be
/// re-rendered (a mesh without UVs) gets the photo alone, the reason on
/// stderr.
fn rerender_tiles(
    bundle: &Bundle,
    estimate_dir: &Path,
    reference: &str,
    calibration: Option<&ScanCalibration>,
) -> Result<Vec<Tile>> {
    let mut tiles = Vec::new();
    let position = bundle.position(reference)?;
    let width = bundle.manifest.camera.width;
    let lit: Vec<_> = position.lit_captures().collect();
    if let Some((capture, _)) = lit
        .iter()
        .find(|(_, light)| light == "flash0")
        .or_else(|| lit.first())
    {
        let photo = bundle.read_photo(reference, &capture.name)?;
        let scale = 1.0 / capture.exposure_s.max(1e-12) as f32;
        let photo = photo.map(|p| p.map(|c| c * scale));
        let white = white_point(std::iter::once(&photo));
        tiles.push(tile_rgb(
            &format!("photo {}", capture.name),
            &photo.map(|p| p.map(|c| c / white)),
        ));
    }
    let lighting = Lighting {
        light: LightName::KeyLeft,
        environment: false,
    };
    let rendered = (|| -> Result<_> {
        let object = ScanObject::new(bundle, reference)?;
        let shots = object.shots(&[lighting], None);
        let settings = RenderSettings::new(width.clamp(8, 4096), RERENDER_SAMPLES);
        let (estimated, _) =
            estimated_textures(bundle, estimate_dir, RERENDER_TEXELS, calibration)?;
        let mine = object.render(&material_from_textures(&estimated), &shots, settings)?;
        let truth = match true_textures(bundle, &estimated, calibration)? {
            Some(t) => Some(object.render(&material_from_textures(&t), &shots, settings)?),
            None => None,
        };
        Ok((mine, truth))
    })();
    let (mine, truth) = match rendered {
        Ok((mine, truth)) => (mine, truth),
        Err(e) => {
            eprintln!("warning: no re-render on the sheet: {e:#}");
            return Ok(tiles);
        }
    };
    let (Some(mine), truth) = (mine.first(), truth.as_ref().and_then(|t| t.first())) else {
        return Ok(tiles);
    };
    let shown = |r: &RgbRaster| r.map(|p| p.map(reinhard));
    let score = truth
        .and_then(|t| compare(&mine.image, &t.image, &t.mask))
        .map_or(String::new(), |s| format!(", {:.1} dB", s.psnr));
    tiles.push(tile_rgb(
        &format!("estimate under {lighting}{score}"),
        &shown(&mine.image),
    ));
    if let Some(t) = truth {
        tiles.push(tile_rgb(
            &format!("truth under {lighting}"),
            &shown(&t.image),
        ));
    }
    Ok(tiles)
}

/// `|estimate - truth|` per pixel of `mask` (the mean over a colour's
/// channels) as a heat map, and the MAD `result.toml` reports
/// (`error_metrics`); `None` when the sizes or channels differ or the mask
/// holds no finite pixel.
fn error_map(
    estimate: &MapValues,
    truth: &MapValues,
    mask: &MaskRaster,
) -> Option<(RgbRaster, f64)> {
    let ((e, channels), (t, truth_channels)) = (estimate.flat(), truth.flat());
    if channels != truth_channels {
        return None;
    }
    let mad = error_metrics(e, t, &mask.data, channels)?.mad;
    let data = e
        .chunks_exact(channels)
        .zip(t.chunks_exact(channels))
        .zip(&mask.data)
        .map(|((e, t), &m)| {
            let d = e.iter().zip(t).map(|(a, b)| (a - b).abs()).sum::<f32>() / channels as f32;
            if m && d.is_finite() {
                heat(d / ERROR_WHITE)
            } else {
                [0.08; 3]
            }
        })
        .collect();
    Some((
        Raster {
            width: mask.width,
            height: mask.height,
            data,
        },
        mad,
    ))
}

/// Black through red and yellow to white over [0, 1].
fn heat(t: f32) -> [f32; 3] {
    let t = 3.0 * unit(t);
    [unit(t), unit(t - 1.0), unit(t - 2.0)]
}

/// Normal and view as colours (`0.5 + 0.5 v`), depth normalized over the
/// object, cosines as grey (negative as black), shadows per light.
fn calib_tiles(maps: &PixelMaps) -> Vec<Tile> {
    let g = &maps.geometry;
    let as_colour = |r: &RgbRaster| {
        let data = r
            .data
            .iter()
            .zip(&g.mask.data)
            .map(|(v, &m)| {
                // sRGB previews expect linear values: undo the curve so the
                // encoded colour reads as the vector.
                let c = v.map(|x| 0.5 + 0.5 * x);
                if m {
                    c.map(matscan_scan::image_io::srgb_to_linear)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        Raster {
            width: r.width,
            height: r.height,
            data,
        }
    };
    let (lo, hi) = g
        .depth
        .data
        .iter()
        .zip(&g.mask.data)
        .filter(|(_, &m)| m)
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), (&d, _)| {
            (lo.min(d), hi.max(d))
        });
    let span = (hi - lo).max(1e-12);
    let depth = g.depth.map(|&d| {
        if d > 0.0 {
            ((d - lo) / span).clamp(0.0, 1.0)
        } else {
            0.0
        }
    });
    let mut tiles = vec![
        tile_rgb("normal", &as_colour(&g.normal)),
        tile_scalar("depth", &depth),
        tile_scalar("cos nv", &g.cos_nv),
    ];
    for l in &maps.lights {
        tiles.push(tile_scalar(&format!("cos nl {}", l.light), &l.cos_nl));
        tiles.push(tile_scalar(
            &format!("shadow {}", l.light),
            &l.shadow(&g.mask),
        ));
    }
    tiles
}

/// The luminance that maps to white: a high percentile, so a few specular
/// spikes do not darken everything else.
fn white_point<'a>(images: impl Iterator<Item = &'a RgbRaster>) -> f32 {
    let mut lum: Vec<f32> = images
        .flat_map(|r| r.data.iter())
        .map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])
        .filter(|l| l.is_finite() && *l > 0.0)
        .collect();
    if lum.is_empty() {
        return 1.0;
    }
    let k = ((lum.len() - 1) as f32 * 0.995) as usize;
    let (_, v, _) = lum.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    v.max(1e-12)
}

fn unit(linear: f32) -> f32 {
    if linear.is_finite() {
        linear.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Box-downscales by an integer factor so tiles stay at most `MAX_TILE`.
fn tile_rgb(label: &str, img: &RgbRaster) -> Tile {
    let f = img.width.max(img.height).div_ceil(MAX_TILE).max(1);
    let (w, h) = (img.width.div_ceil(f), img.height.div_ceil(f));
    let mut rgb = Vec::with_capacity((w * h * 3) as usize);
    for ty in 0..h {
        for tx in 0..w {
            let mut acc = [0.0f32; 3];
            let mut n = 0.0;
            for y in ty * f..((ty + 1) * f).min(img.height) {
                for x in tx * f..((tx + 1) * f).min(img.width) {
                    let p = img.get(x, y);
                    for c in 0..3 {
                        acc[c] += p[c];
                    }
                    n += 1.0;
                }
            }
            rgb.extend(acc.map(|a| unit(a / n)));
        }
    }
    Tile {
        label: label.to_string(),
        width: w,
        height: h,
        rgb,
    }
}

/// A parameter map: RGB as it is, one channel as grey.
fn tile_values(label: &str, values: &MapValues) -> Tile {
    match values {
        MapValues::Rgb(r) => tile_rgb(label, r),
        MapValues::Scalar(r) => tile_scalar(label, r),
    }
}

fn tile_mask(label: &str, mask: &MaskRaster) -> Tile {
    tile_rgb(label, &mask.map(|&m| if m { [1.0; 3] } else { [0.0; 3] }))
}

fn tile_scalar(label: &str, map: &ScalarRaster) -> Tile {
    tile_rgb(label, &map.map(|&v| [v; 3]))
}

fn compose(title: &str, rows: &[(String, Vec<Tile>)], out: &Path) -> Result<()> {
    let label_h = font::line_height(TEXT_PX) + 4;
    let row_label_w = rows
        .iter()
        .map(|(l, _)| font::text_width(l, TEXT_PX))
        .max()
        .unwrap_or(0)
        + 2 * GAP;
    let row_w = |tiles: &[Tile]| tiles.iter().map(|t| t.width + GAP).sum::<u32>();
    let row_h = |tiles: &[Tile]| tiles.iter().map(|t| t.height).max().unwrap_or(0) + label_h;
    let width = (row_label_w + rows.iter().map(|(_, t)| row_w(t)).max().unwrap_or(0) + GAP)
        .max(font::text_width(title, TEXT_PX) + 2 * GAP);
    let height = label_h + GAP + rows.iter().map(|(_, t)| row_h(t) + GAP).sum::<u32>();
    let mut buf = vec![0.015f32; (width * height * 3) as usize];
    font::draw_text(
        &mut buf,
        width,
        height,
        GAP,
        2,
        TEXT_PX,
        [1.0, 1.0, 1.0],
        title,
    );
    let mut y = label_h + GAP;
    for (label, tiles) in rows {
        font::draw_text(
            &mut buf,
            width,
            height,
            GAP,
            y + label_h,
            TEXT_PX,
            [0.6, 0.6, 0.6],
            label,
        );
        let mut x = row_label_w;
        for t in tiles {
            font::draw_text(
                &mut buf,
                width,
                height,
                x,
                y + 2,
                TEXT_PX,
                [0.8, 0.8, 0.2],
                &t.label,
            );
            for ty in 0..t.height {
                let src = (ty * t.width * 3) as usize;
                let dst = (((y + label_h + ty) * width + x) * 3) as usize;
                buf[dst..dst + (t.width * 3) as usize]
                    .copy_from_slice(&t.rgb[src..src + (t.width * 3) as usize]);
            }
            x += t.width + GAP;
        }
        y += row_h(tiles) + GAP;
    }
    let img = Raster::from_vec(
        width,
        height,
        buf.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    )
    .context("sheet buffer size")?;
    matscan_scan::image_io::write_preview_png(out, &img)
        .with_context(|| format!("writing contact sheet {}", out.display()))?;
    Ok(())
}
