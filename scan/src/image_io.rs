//! Image files of a bundle: OpenEXR photos and truth maps, 16-bit PNG
//! photos and grey maps, 8-bit PNG masks and 8-bit sRGB previews.
//!
//! Reading is lenient about layout and strict about content: an EXR may hold
//! RGB, RGBA, luminance `Y` or a single channel, in half, float or uint; a
//! PNG may be grey or colour, 8 or 16 bits, with or without alpha. But every
//! value must be finite: a photo with NaN or infinity is malformed (no
//! camera produces one, and one such pixel would poison every mean the
//! estimator takes), so reading rejects it, naming the file and the count.
//! Writing refuses non-finite values for the same reason, and refuses values
//! beyond the half-float range when asked for half precision rather than
//! storing infinity.
//!
//! Every write is atomic ([`crate::atomic`]). Boundaries: pixels only; which
//! file holds what, and what size it must be, is [`crate::bundle`]'s job.

use crate::atomic::write_atomic_with;
use crate::error::ScanError;
use crate::manifest::Encoding;
use crate::raster::{MaskRaster, Raster, RgbRaster, ScalarRaster};
use exr::prelude::{
    f16, AnyChannel, AnyChannels, FlatSamples, Image, Layer, LayerAttributes, ReadChannels,
    ReadLayers, SmallVec, WritableImage,
};
use image::codecs::png::{PngDecoder, PngEncoder};
use image::{DynamicImage, ExtendedColorType, ImageEncoder};
use std::io::{BufReader, Cursor};
use std::path::Path;

/// Sample precision of a written EXR.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    /// 16-bit float: photos (the camera's own precision is lower).
    Half,
    /// 32-bit float: truth maps and estimates.
    Float,
}

/// Largest finite half-float value.
const HALF_MAX: f32 = 65504.0;

/// Reads a photo: EXR (always linear; `encoding` must be `None` or
/// `Linear`) or PNG decoded per `encoding` (required for PNG), chosen by the
/// file's extension.
pub fn read_rgb(path: &Path, encoding: Option<Encoding>) -> Result<RgbRaster, ScanError> {
    match extension(path).as_deref() {
        Some("exr") => match encoding {
            None | Some(Encoding::Linear) => read_rgb_exr(path),
            Some(Encoding::Srgb) => Err(ScanError::format(
                path,
                "EXR photos are linear; an sRGB encoding cannot apply",
            )),
        },
        Some("png") => match encoding {
            Some(e) => read_rgb_png(path, e),
            None => Err(ScanError::format(
                path,
                "a PNG photo needs its encoding (\"linear\" or \"srgb\") declared in scan.toml",
            )),
        },
        _ => Err(ScanError::format(path, "expected a .exr or .png image")),
    }
}

/// Reads an EXR as linear RGB: `R G B` (any alpha ignored), else `Y`, else
/// a lone channel, replicated to grey.
pub fn read_rgb_exr(path: &Path) -> Result<RgbRaster, ScanError> {
    let layer = read_exr_layer(path)?;
    let (w, h) = (layer.width, layer.height);
    let data: Vec<[f32; 3]> = match (layer.find("R"), layer.find("G"), layer.find("B")) {
        (Some(r), Some(g), Some(b)) => r
            .iter()
            .zip(g)
            .zip(b)
            .map(|((&r, &g), &b)| [r, g, b])
            .collect(),
        _ => layer.grey(path)?.iter().map(|&v| [v; 3]).collect(),
    };
    let raster = raster(path, w, h, data)?;
    check_finite(
        path,
        raster.data.iter().map(|p| p.iter().all(|v| v.is_finite())),
    )?;
    Ok(raster)
}

/// Reads a single-channel EXR map: `R` (the contract stores scalar truth
/// there), else `Y`, else a lone channel.
pub fn read_scalar_exr(path: &Path) -> Result<ScalarRaster, ScanError> {
    let layer = read_exr_layer(path)?;
    let (w, h) = (layer.width, layer.height);
    let data = match layer.find("R") {
        Some(r) => r.clone(),
        None => layer.grey(path)?.clone(),
    };
    let raster = raster(path, w, h, data)?;
    check_finite(path, raster.data.iter().map(|v| v.is_finite()))?;
    Ok(raster)
}

/// Writes linear RGB as an EXR with channels `R G B`.
pub fn write_rgb_exr(
    path: &Path,
    image: &RgbRaster,
    precision: Precision,
) -> Result<(), ScanError> {
    check_writable(path, image, precision, image.data.iter().flatten())?;
    let channel = |name: &str, c: usize| {
        AnyChannel::new(name, samples(image.data.iter().map(|p| p[c]), precision))
    };
    let channels = vec![channel("R", 0), channel("G", 1), channel("B", 2)];
    write_exr(path, image.width, image.height, channels)
}

/// Writes one channel as an EXR whose only channel is `R` (the contract's
/// layout for scalar truth maps).
pub fn write_scalar_exr(
    path: &Path,
    image: &ScalarRaster,
    precision: Precision,
) -> Result<(), ScanError> {
    check_writable(path, image, precision, image.data.iter())?;
    let channels = vec![AnyChannel::new(
        "R",
        samples(image.data.iter().copied(), precision),
    )];
    write_exr(path, image.width, image.height, channels)
}

/// Reads a PNG photo (8 or 16 bits, grey or colour, alpha ignored) as
/// linear RGB in `[0, 1]`, undoing the sRGB curve where `encoding` says so.
pub fn read_rgb_png(path: &Path, encoding: Encoding) -> Result<RgbRaster, ScanError> {
    let rgb = read_png(path)?.into_rgb16();
    let (w, h) = rgb.dimensions();
    let decode: Box<dyn Fn(u16) -> f32> = match encoding {
        Encoding::Linear => Box::new(|v| f32::from(v) / 65535.0),
        Encoding::Srgb => {
            let lut: Vec<f32> = (0..=u16::MAX)
                .map(|v| srgb_to_linear(f32::from(v) / 65535.0))
                .collect();
            Box::new(move |v| lut[usize::from(v)])
        }
    };
    let data = rgb
        .pixels()
        .map(|p| [decode(p[0]), decode(p[1]), decode(p[2])])
        .collect();
    raster(path, w as usize, h as usize, data)
}

/// Writes linear RGB as a 16-bit PNG photo, sRGB-encoded if asked; values
/// are clipped to `[0, 1]` as a camera's would be.
pub fn write_rgb_png16(
    path: &Path,
    image: &RgbRaster,
    encoding: Encoding,
) -> Result<(), ScanError> {
    check_writable(path, image, Precision::Float, image.data.iter().flatten())?;
    let encode = |v: f32| {
        let v = v.clamp(0.0, 1.0);
        let v = match encoding {
            Encoding::Linear => v,
            Encoding::Srgb => linear_to_srgb(v),
        };
        (v * 65535.0).round() as u16
    };
    let bytes: Vec<u8> = image
        .data
        .iter()
        .flatten()
        .flat_map(|&v| encode(v).to_ne_bytes())
        .collect();
    write_png(
        path,
        image.width,
        image.height,
        &bytes,
        ExtendedColorType::Rgb16,
    )
}

/// Reads a grey PNG (8 or 16 bits; colour is converted to luma, alpha
/// ignored) as linear values in `[0, 1]`.
pub fn read_scalar_png(path: &Path) -> Result<ScalarRaster, ScanError> {
    let grey = read_png(path)?.into_luma16();
    let (w, h) = grey.dimensions();
    let data = grey.pixels().map(|p| f32::from(p.0[0]) / 65535.0).collect();
    raster(path, w as usize, h as usize, data)
}

/// Writes a scalar map as a 16-bit linear grey PNG; values are clipped to
/// `[0, 1]`.
pub fn write_scalar_png16(path: &Path, image: &ScalarRaster) -> Result<(), ScanError> {
    check_writable(path, image, Precision::Float, image.data.iter())?;
    let bytes: Vec<u8> = image
        .data
        .iter()
        .flat_map(|&v| ((v.clamp(0.0, 1.0) * 65535.0).round() as u16).to_ne_bytes())
        .collect();
    write_png(
        path,
        image.width,
        image.height,
        &bytes,
        ExtendedColorType::L16,
    )
}

/// Reads a mask: a pixel is set where any colour channel is nonzero (alpha
/// ignored). Any bit depth is accepted; the contract writes 8-bit grey.
pub fn read_mask_png(path: &Path) -> Result<MaskRaster, ScanError> {
    let rgb = read_png(path)?.into_rgb16();
    let (w, h) = rgb.dimensions();
    let data = rgb.pixels().map(|p| p.0.iter().any(|&v| v != 0)).collect();
    raster(path, w as usize, h as usize, data)
}

/// Writes a mask as 8-bit grey, 255 where set.
pub fn write_mask_png(path: &Path, mask: &MaskRaster) -> Result<(), ScanError> {
    check_size(path, mask.width, mask.height, mask.data.len())?;
    let bytes: Vec<u8> = mask.data.iter().map(|&m| if m { 255 } else { 0 }).collect();
    write_png(path, mask.width, mask.height, &bytes, ExtendedColorType::L8)
}

/// Writes an 8-bit sRGB preview of linear RGB, clipped to `[0, 1]`; NaN
/// shows as black (a preview never fails on content).
pub fn write_preview_png(path: &Path, image: &RgbRaster) -> Result<(), ScanError> {
    check_size(path, image.width, image.height, image.data.len())?;
    let bytes: Vec<u8> = image.data.iter().flatten().map(|&v| preview(v)).collect();
    write_png(
        path,
        image.width,
        image.height,
        &bytes,
        ExtendedColorType::Rgb8,
    )
}

/// Writes an 8-bit grey preview of a scalar map in `[0, 1]` (roughness,
/// metallic, ...). Values are shown as they are, without the sRGB curve,
/// so that grey level 128 reads as 0.5.
pub fn write_scalar_preview_png(path: &Path, image: &ScalarRaster) -> Result<(), ScanError> {
    check_size(path, image.width, image.height, image.data.len())?;
    let bytes: Vec<u8> = image
        .data
        .iter()
        .map(|&v| to_u8(if v.is_nan() { 0.0 } else { v }))
        .collect();
    write_png(
        path,
        image.width,
        image.height,
        &bytes,
        ExtendedColorType::L8,
    )
}

/// The sRGB transfer curve, inverse direction (IEC 61966-2-1).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB transfer curve (IEC 61966-2-1), for `v` in `[0, 1]`.
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

fn preview(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    to_u8(linear_to_srgb(v))
}

fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
}

/// The first layer of an EXR, its channels converted to f32.
struct ExrLayer {
    width: usize,
    height: usize,
    /// (name without any layer prefix, samples)
    channels: Vec<(String, Vec<f32>)>,
}

impl ExrLayer {
    fn find(&self, name: &str) -> Option<&Vec<f32>> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
    }

    /// The channel to use as grey: `Y`, else `R`, else the only channel.
    fn grey(&self, path: &Path) -> Result<&Vec<f32>, ScanError> {
        if let Some(c) = self.find("Y").or_else(|| self.find("R")) {
            return Ok(c);
        }
        match self.channels.as_slice() {
            [(_, only)] => Ok(only),
            _ => Err(ScanError::format(
                path,
                format!(
                    "expected channels R G B, Y or a single channel, found {}",
                    self.channels
                        .iter()
                        .map(|(n, _)| n.as_str())
                        .collect::<Vec<_>>()
                        .join(" ")
                ),
            )),
        }
    }
}

/// The most bytes of decoded samples a file of `file_len` bytes may claim.
/// Decoders allocate what the header claims before reading the data, so a
/// corrupt header could ask for gigabytes; real files compress at most about
/// 1000:1 (deflate's limit), so a claim beyond 2048 times the file size
/// (with a floor for small files and a hard cap) is a corrupt header.
fn decode_budget(file_len: u64) -> u64 {
    const FLOOR: u64 = 64 << 20;
    const CAP: u64 = 2 << 30;
    file_len.saturating_mul(2048).clamp(FLOOR, CAP)
}

/// Decoded sizes from which EXR blocks are (de)compressed on several
/// threads. The `exr` crate builds a fresh thread pool for every parallel
/// read or write, which costs more than it saves on small images (and
/// callers often already run one image per thread).
const PARALLEL_FROM_BYTES: u128 = 16 << 20;

/// Checks the header's claimed size against [`decode_budget`] and returns
/// the decoded size in bytes.
fn check_exr_budget(path: &Path, bytes: &[u8]) -> Result<u128, ScanError> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), true)
        .map_err(|e| ScanError::format(path, format!("not a readable OpenEXR image: {e}")))?;
    let budget = decode_budget(bytes.len() as u64);
    let mut total = 0u128;
    for h in &meta.headers {
        let (w, ht, c) = (h.layer_size.0, h.layer_size.1, h.channels.list.len());
        let claimed = (w as u128) * (ht as u128) * (c as u128) * 4;
        if claimed > u128::from(budget) {
            return Err(ScanError::format(
                path,
                format!(
                    "header claims {w}x{ht} pixels of {c} channels, more than a file of {} \
                     bytes can hold; the file is corrupt",
                    bytes.len()
                ),
            ));
        }
        total += claimed;
    }
    Ok(total)
}

fn read_exr_layer(path: &Path) -> Result<ExrLayer, ScanError> {
    let bytes = std::fs::read(path).map_err(|e| ScanError::io(path, e))?;
    let decoded_bytes = check_exr_budget(path, &bytes)?;
    // Pedantic: a relaxed read accepts truncated files and fills the missing
    // blocks with zeros, which would pass a broken photo off as a dark one.
    let reader = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic();
    let reader = if decoded_bytes < PARALLEL_FROM_BYTES {
        reader.non_parallel()
    } else {
        reader
    };
    let image = reader
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| ScanError::format(path, format!("not a readable OpenEXR image: {e}")))?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let mut channels = Vec::new();
    for c in layer.channel_data.list {
        let full = c.name.to_string();
        let name = full.rsplit('.').next().unwrap_or(&full).to_string();
        let values: Vec<f32> = match c.sample_data {
            FlatSamples::F16(v) => v.into_iter().map(f16::to_f32).collect(),
            FlatSamples::F32(v) => v,
            FlatSamples::U32(v) => v.into_iter().map(|x| x as f32).collect(),
        };
        if values.len() != width * height {
            return Err(ScanError::format(
                path,
                format!("channel {full} is subsampled; expected one sample per pixel"),
            ));
        }
        channels.push((name, values));
    }
    Ok(ExrLayer {
        width,
        height,
        channels,
    })
}

fn samples(values: impl Iterator<Item = f32>, precision: Precision) -> FlatSamples {
    match precision {
        Precision::Half => FlatSamples::F16(values.map(f16::from_f32).collect()),
        Precision::Float => FlatSamples::F32(values.collect()),
    }
}

fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    channels: Vec<AnyChannel<FlatSamples>>,
) -> Result<(), ScanError> {
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::default(),
        // ZIP over scan lines: lossless, compact for float data, and read by
        // every OpenEXR implementation.
        exr::prelude::Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let image = Image::from_layer(layer);
    let decoded_bytes = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| c.sample_data.len() as u128 * 4)
        .sum::<u128>();
    write_atomic_with(path, |w| {
        let writer = image.write();
        let writer = if decoded_bytes < PARALLEL_FROM_BYTES {
            writer.non_parallel()
        } else {
            writer
        };
        writer
            .to_buffered(w)
            .map_err(|e| ScanError::format(path, format!("could not encode OpenEXR: {e}")))
    })
}

fn read_png(path: &Path) -> Result<DynamicImage, ScanError> {
    let file = std::fs::File::open(path).map_err(|e| ScanError::io(path, e))?;
    let len = file.metadata().map_err(|e| ScanError::io(path, e))?.len();
    let bad =
        |e: image::ImageError| ScanError::format(path, format!("not a readable PNG image: {e}"));
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(decode_budget(len));
    let decoder = PngDecoder::with_limits(BufReader::new(file), limits).map_err(bad)?;
    DynamicImage::from_decoder(decoder).map_err(bad)
}

fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    bytes: &[u8],
    color: ExtendedColorType,
) -> Result<(), ScanError> {
    write_atomic_with(path, |w| {
        PngEncoder::new(w)
            .write_image(bytes, width, height, color)
            .map_err(|e| ScanError::format(path, format!("could not encode PNG: {e}")))
    })
}

fn raster<T>(
    path: &Path,
    width: usize,
    height: usize,
    data: Vec<T>,
) -> Result<Raster<T>, ScanError> {
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(ScanError::format(
            path,
            format!("image of {width}x{height} pixels is too large"),
        ));
    };
    if w == 0 || h == 0 {
        return Err(ScanError::format(path, "image has no pixels"));
    }
    Raster::from_vec(w, h, data).ok_or_else(|| {
        ScanError::format(
            path,
            format!("pixel data does not fill {width}x{height} pixels"),
        )
    })
}

fn check_finite(path: &Path, finite: impl Iterator<Item = bool>) -> Result<(), ScanError> {
    let bad = finite.filter(|ok| !ok).count();
    if bad > 0 {
        return Err(ScanError::format(
            path,
            format!("{bad} pixels hold NaN or infinite values; images must be finite"),
        ));
    }
    Ok(())
}

/// Rasters have public fields, so their length is checked before encoders
/// (which assert on it) see them.
fn check_size(path: &Path, width: u32, height: u32, len: usize) -> Result<(), ScanError> {
    if width == 0 || height == 0 {
        return Err(ScanError::format(
            path,
            format!("cannot write an image of {width}x{height} pixels"),
        ));
    }
    if len != width as usize * height as usize {
        return Err(ScanError::format(
            path,
            format!("cannot write {len} pixels as a {width}x{height} image"),
        ));
    }
    Ok(())
}

fn check_writable<'v, T>(
    path: &Path,
    image: &Raster<T>,
    precision: Precision,
    values: impl Iterator<Item = &'v f32>,
) -> Result<(), ScanError> {
    check_size(path, image.width, image.height, image.data.len())?;
    let mut non_finite = 0usize;
    let mut beyond_half = 0usize;
    for &v in values {
        if !v.is_finite() {
            non_finite += 1;
        } else if precision == Precision::Half && v.abs() > HALF_MAX {
            beyond_half += 1;
        }
    }
    if non_finite > 0 {
        return Err(ScanError::format(
            path,
            format!("refusing to write {non_finite} NaN or infinite values"),
        ));
    }
    if beyond_half > 0 {
        return Err(ScanError::format(
            path,
            format!(
                "{beyond_half} values exceed the half-float range (+-{HALF_MAX}); write Float precision"
            ),
        ));
    }
    Ok(())
}
