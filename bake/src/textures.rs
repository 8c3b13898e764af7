//! The UV texture set of a scan and its file layout in
//! `estimate/texture/`: `<param>.png` for each baked parameter plus
//! `coverage.png`.
//!
//! Layout (fixed between the engineers, see the README): 16-bit PNG, row 0
//! is the top of the image, which is v = 1 (the mesh's UV origin is bottom
//! left, as `matscan_sim::scene::Texture::sample` samples), so a texture's
//! [`Raster`] can be used as a UV map as it is. `basecolor.png` is RGB with
//! the sRGB transfer curve (what glTF's baseColorTexture expects); the four
//! scalar maps are linear grey in `[0, 1]`; `coverage.png` is 8-bit grey,
//! 255 where some camera measured the texel and 0 where hole filling made
//! the value up (texels outside every UV chart included).
//!
//! In memory every value is linear. Writing clips to `[0, 1]` (the range of
//! every Principled parameter matscan estimates) and maps NaN to 0, so a
//! file is always valid; every file is written atomically. The files are
//! read and written by `matscan_scan::image_io` (reading takes any nonzero
//! coverage value as measured, as it does for every mask).
//!
//! Boundaries: only the files; baking is [`crate::bake`]'s job.

use crate::error::BakeError;
use glam::Vec2;
use matscan_scan::image_io::{
    read_mask_png, read_rgb_png, read_scalar_png, write_mask_png, write_rgb_png16,
    write_scalar_png16,
};
use matscan_scan::manifest::Encoding;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::{Param, ScanError};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The folder of the textures inside an estimate folder.
pub const TEXTURE_DIR: &str = "texture";
/// File name of the coverage map inside the texture folder.
pub const COVERAGE_FILE: &str = "coverage.png";

/// `estimate_dir/texture`.
pub fn texture_dir(estimate_dir: &Path) -> PathBuf {
    estimate_dir.join(TEXTURE_DIR)
}

/// `texture_dir/<param>.png`.
pub fn texture_path(texture_dir: &Path, param: Param) -> PathBuf {
    texture_dir.join(format!("{}.png", param.name()))
}

/// UV (origin bottom left) of the centre of texel (`x`, `y`) of a
/// `width` x `height` texture whose row 0 is v = 1.
pub fn texel_uv(x: u32, y: u32, width: u32, height: u32) -> Vec2 {
    Vec2::new(
        (x as f32 + 0.5) / width.max(1) as f32,
        1.0 - (y as f32 + 0.5) / height.max(1) as f32,
    )
}

/// Baked UV textures: any subset of the five parameters, all the size of
/// the coverage map (the setters refuse anything else).
#[derive(Debug, Clone, PartialEq)]
pub struct BakedTextures {
    coverage: MaskRaster,
    basecolor: Option<RgbRaster>,
    /// Roughness, metallic, transmission, subsurface; never basecolor.
    scalars: BTreeMap<Param, ScalarRaster>,
}

impl BakedTextures {
    /// An empty set of `coverage`'s size: `true` = measured texel.
    pub fn new(coverage: MaskRaster) -> Self {
        Self {
            coverage,
            basecolor: None,
            scalars: BTreeMap::new(),
        }
    }

    pub fn width(&self) -> u32 {
        self.coverage.width
    }

    pub fn height(&self) -> u32 {
        self.coverage.height
    }

    /// `true` where some camera measured the texel, `false` where hole
    /// filling made it up.
    pub fn coverage(&self) -> &MaskRaster {
        &self.coverage
    }

    /// Linear basecolor.
    pub fn basecolor(&self) -> Option<&RgbRaster> {
        self.basecolor.as_ref()
    }

    /// A scalar parameter's texture; `None` for basecolor (see
    /// [`BakedTextures::basecolor`]) or a parameter not in the set.
    pub fn scalar(&self, param: Param) -> Option<&ScalarRaster> {
        self.scalars.get(&param)
    }

    /// The parameters in the set, in [`Param::ALL`] order.
    pub fn params(&self) -> Vec<Param> {
        Param::ALL
            .into_iter()
            .filter(|&p| match p {
                Param::Basecolor => self.basecolor.is_some(),
                p => self.scalars.contains_key(&p),
            })
            .collect()
    }

    /// Grey value of any parameter at a texel: the scalar itself, or the
    /// mean of basecolor's channels. For comparisons and previews.
    pub fn value(&self, param: Param, x: u32, y: u32) -> Option<f32> {
        match param {
            Param::Basecolor => self
                .basecolor
                .as_ref()
                .map(|r| r.get(x, y).iter().sum::<f32>() / 3.0),
            p => self.scalars.get(&p).map(|r| *r.get(x, y)),
        }
    }

    pub fn set_basecolor(&mut self, texture: RgbRaster) -> Result<(), BakeError> {
        self.check_size(Param::Basecolor, texture.width, texture.height)?;
        check_len(Param::Basecolor, texture.data.len(), &texture)?;
        self.basecolor = Some(texture);
        Ok(())
    }

    /// Sets a scalar parameter's texture; refuses basecolor (three
    /// channels, see [`BakedTextures::set_basecolor`]).
    pub fn set_scalar(&mut self, param: Param, texture: ScalarRaster) -> Result<(), BakeError> {
        if param == Param::Basecolor {
            return Err(BakeError::WrongParam {
                param,
                message: "basecolor has three channels; use set_basecolor".into(),
            });
        }
        self.check_size(param, texture.width, texture.height)?;
        check_len(param, texture.data.len(), &texture)?;
        self.scalars.insert(param, texture);
        Ok(())
    }

    fn check_size(&self, param: Param, width: u32, height: u32) -> Result<(), BakeError> {
        if (width, height) != (self.width(), self.height()) {
            return Err(BakeError::SizeMismatch {
                param: param.name().to_string(),
                expected_width: self.width(),
                expected_height: self.height(),
                found_width: width,
                found_height: height,
            });
        }
        Ok(())
    }
}

/// Writes every texture of `textures` and the coverage map into
/// `texture_dir` (created if needed), each file atomically. Files of
/// parameters not in the set are left alone.
pub fn write_textures(texture_dir: &Path, textures: &BakedTextures) -> Result<(), BakeError> {
    std::fs::create_dir_all(texture_dir).map_err(|e| BakeError::io(texture_dir, e))?;
    if let Some(rgb) = textures.basecolor() {
        let path = texture_path(texture_dir, Param::Basecolor);
        write_rgb_png16(&path, &finite_rgb(rgb), Encoding::Srgb)?;
    }
    for (&param, map) in &textures.scalars {
        write_scalar_png16(&texture_path(texture_dir, param), &finite_scalar(map))?;
    }
    write_mask_png(&texture_dir.join(COVERAGE_FILE), &textures.coverage)?;
    Ok(())
}

/// Reads the texture set in `texture_dir`: the coverage map (required) and
/// whichever parameter textures are there, decoded to linear values. Every
/// texture must be the coverage map's size.
pub fn read_textures(texture_dir: &Path) -> Result<BakedTextures, BakeError> {
    let coverage_path = texture_dir.join(COVERAGE_FILE);
    if !coverage_path.is_file() {
        return Err(ScanError::Missing {
            path: coverage_path,
            needed_by: "every baked texture set has a coverage map; run `matscan export` to bake"
                .into(),
        }
        .into());
    }
    let mut textures = BakedTextures::new(read_mask_png(&coverage_path)?);
    for param in Param::ALL {
        let path = texture_path(texture_dir, param);
        if !path.is_file() {
            continue;
        }
        let result = if param == Param::Basecolor {
            textures.set_basecolor(read_rgb_png(&path, Encoding::Srgb)?)
        } else {
            textures.set_scalar(param, read_scalar_png(&path)?)
        };
        result.map_err(|e| BakeError::format(&path, e.to_string()))?;
    }
    Ok(textures)
}

/// A raster's fields are public, so its data may not fill its size; the
/// glTF export indexes every texture by the set's size.
fn check_len<T>(
    param: Param,
    len: usize,
    raster: &matscan_scan::Raster<T>,
) -> Result<(), BakeError> {
    if len != raster.width as usize * raster.height as usize {
        return Err(BakeError::WrongParam {
            param,
            message: format!(
                "texture data has {len} texels, expected {}x{}",
                raster.width, raster.height
            ),
        });
    }
    Ok(())
}

/// The scan crate's writers refuse NaN and infinity (and clip the rest to
/// `[0, 1]`); a texture file is always written, so they are clipped here:
/// NaN to 0, infinities to the nearer end. Borrowed when all is finite.
fn finite_rgb(r: &RgbRaster) -> Cow<'_, RgbRaster> {
    if r.data.iter().flatten().all(|v| v.is_finite()) {
        Cow::Borrowed(r)
    } else {
        Cow::Owned(r.map(|p| p.map(clip)))
    }
}

/// [`finite_rgb`] for one channel.
fn finite_scalar(r: &ScalarRaster) -> Cow<'_, ScalarRaster> {
    if r.data.iter().all(|v| v.is_finite()) {
        Cow::Borrowed(r)
    } else {
        Cow::Owned(r.map(|&v| clip(v)))
    }
}

/// A value as written: NaN as 0, clipped to `[0, 1]`.
pub(crate) fn clip(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}
