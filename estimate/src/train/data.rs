//! Training samples: one simulated scan bundle becomes, for one network,
//! its input planes per view (built by the inference path's own
//! [`SceneInputs`], so training and inference encode inputs identically),
//! the ground truth in the reference camera image, and the per-view
//! illumination truth (`illum_<capture>`, warped into the reference image).
//!
//! Dependencies are the **truth**, as in the thesis: metallic, the effective
//! transmission `T (1 - M)` and effective subsurface `S (1 - M) (1 - T)`
//! (the bundle's truth maps are already effective, see docs/scan-format.md),
//! roughness, and the per-view illumination truth in network units.
//!
//! A [`Sample`] is cut from a scene on the CPU side (plain `Vec<f32>`): a
//! random crop, a choice of views, optional mean-pooling down to the
//! stems-only size, and the "dropout-like removal of input pixels" (every
//! channel of a dropped pixel, mapped mask included, is set to 0: a hole).
//! Doing this before any tensor exists keeps it backend-independent and
//! cheap at the training crop sizes.
//!
//! Out of scope: losses (see `loss`), the loop (see the module root).

use crate::inputs::{centre, uncentre, Dependencies, SceneInputs};
use crate::spec::{InputChannel, ParamKind};
use crate::views::{select_views, ViewFilter};
use burn::tensor::Device;
use matscan_calib::photos::luma;
use matscan_calib::white_reference::ycbcr;
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_scan::{Bundle, Param, TruthImage, TruthMap};
use rand::Rng;
use std::path::{Path, PathBuf};

use super::TrainError;

/// One view of a scene, in the reference camera image.
#[derive(Clone, Debug)]
pub struct ViewData {
    /// `[channels][pixels]`, centred, the network's input channel order.
    pub input: Vec<f32>,
    /// This view's mapped mask (0 or 1).
    pub mask: Vec<f32>,
    /// Luma of the illumination truth (white diffuse render of the lit
    /// capture), scaled like the photos, clamped to [0, 1], 0 off the mask.
    pub illum: Vec<f32>,
    /// `luminance(lit - ambient)`, clamped to [0, 1] (from the input's
    /// square-root difference channel, squared).
    pub lit_diff: Vec<f32>,
}

/// One scene prepared for one network.
#[derive(Clone, Debug)]
pub struct SceneData {
    /// The bundle folder.
    pub path: PathBuf,
    /// The reference position: the camera image everything is in.
    pub reference: String,
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The views this network fuses at inference (see `pipeline`).
    pub views: Vec<ViewData>,
    /// `[fused outputs][pixels]` in [0, 1] (basecolor as YCbCr).
    pub target: Vec<f32>,
    /// Reference object mask and truth mask, 0 or 1.
    pub mask: Vec<f32>,
}

/// Every bundle folder (one with a `scan.toml`) at `dir`, directly under
/// it, or one level further down (a folder of datasets), sorted by path.
pub fn bundle_dirs(dir: &Path) -> Result<Vec<PathBuf>, TrainError> {
    let mut out = Vec::new();
    collect_bundles(dir, 2, &mut out)?;
    out.sort();
    Ok(out)
}

fn collect_bundles(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) -> Result<(), TrainError> {
    if dir.join(matscan_scan::bundle::MANIFEST_FILE).is_file() {
        out.push(dir.to_path_buf());
        return Ok(());
    }
    if depth == 0 {
        return Ok(());
    }
    let io = |source| TrainError::Io {
        path: dir.to_path_buf(),
        source,
    };
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        if path.is_dir() {
            collect_bundles(&path, depth - 1, out)?;
        }
    }
    Ok(())
}

/// Whether a view of `kind` is used (the same rule as the pipeline's).
fn uses_view(kind: ParamKind, backlit: bool, checker: bool) -> bool {
    match kind {
        ParamKind::Transmission => backlit,
        ParamKind::Subsurface => checker,
        _ => true,
    }
}

fn scalar_truth(bundle: &Bundle, position: &str, param: Param) -> Result<Vec<f32>, TrainError> {
    let what = format!("truth {}", param.name());
    match bundle.read_truth(position, &TruthMap::Param(param))? {
        Some(TruthImage::Scalar(r)) => Ok(r.data.iter().map(|v| unit(*v)).collect()),
        _ => Err(TrainError::NoTruth {
            path: bundle.root.clone(),
            what,
        }),
    }
}

fn unit(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Reads one bundle and prepares it for `kind`. `Ok(None)` when the scene
/// has no view this network uses (transmission without a backlit capture).
pub fn load_scene(path: &Path, kind: ParamKind) -> Result<Option<SceneData>, TrainError> {
    Ok(load_scenes(path, &[kind])?.pop().flatten())
}

/// [`load_scene`] for each of `kinds`, in order, reading, calibrating and
/// assembling the bundle once for all of them.
pub fn load_scenes(path: &Path, kinds: &[ParamKind]) -> Result<Vec<Option<SceneData>>, TrainError> {
    let device: Device = crate::backend::cpu_device();
    let bundle = Bundle::open(path)?;
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())?;
    let set = select_views(&bundle.manifest, &calibration, &ViewFilter::default())?;
    let inputs = SceneInputs::assemble(&bundle, &calibration, &set)?;
    let reference = set.reference.clone();
    let n = inputs.pixels();
    let no_truth = |what: &str| TrainError::NoTruth {
        path: path.to_path_buf(),
        what: what.to_string(),
    };

    let truth_mask = match bundle.read_truth(&reference, &TruthMap::Mask)? {
        Some(TruthImage::Mask(m)) => m.data,
        Some(TruthImage::Scalar(s)) => s.data.iter().map(|v| *v > 0.5).collect(),
        _ => return Err(no_truth("truth mask")),
    };
    let mask: Vec<f32> = (0..n)
        .map(|i| f32::from(u8::from(inputs.mask.data[i] && truth_mask[i])))
        .collect();
    let metallic = scalar_truth(&bundle, &reference, Param::Metallic)?;
    let transmission = scalar_truth(&bundle, &reference, Param::Transmission)?;
    let subsurface = scalar_truth(&bundle, &reference, Param::Subsurface)?;
    let roughness = scalar_truth(&bundle, &reference, Param::Roughness)?;
    // Illumination truth per view, in the reference image.
    let mut illum_all = Vec::with_capacity(inputs.views.len());
    for planes in &inputs.views {
        let view = &planes.view;
        let map = TruthMap::Illum(view.capture.clone());
        let Some(TruthImage::Rgb(image)) = bundle.read_truth(&view.position, &map)? else {
            return Err(no_truth(&format!(
                "illum_{} of {}",
                view.capture, view.position
            )));
        };
        let image = if view.position == reference {
            image
        } else {
            let c = calibration
                .correspondence(&reference, &view.position)
                .ok_or_else(|| no_truth("correspondence for the illumination truth"))?;
            c.warp_rgb(&image, &format!("illum_{}", view.capture))?
        };
        let position = bundle.position(&view.position)?;
        let ambient = position.ambient().map_or(1.0, |c| c.exposure_s);
        let lit = bundle.capture(&view.position, &view.capture)?.exposure_s;
        let k = if lit > 0.0 && ambient.is_finite() {
            (ambient / lit) as f32
        } else {
            1.0
        };
        let illum: Vec<f32> = image
            .data
            .iter()
            .zip(&planes.mask)
            .map(|(c, m)| unit(luma(c.map(|v| v * k))) * m)
            .collect();
        illum_all.push(illum);
    }
    let illum_units: Vec<Vec<f32>> = illum_all
        .iter()
        .map(|v| v.iter().map(|&x| centre(x)).collect())
        .collect();
    let deps = Dependencies {
        metallic: Some(&metallic),
        transmission_final: Some(&transmission),
        subsurface_final: Some(&subsurface),
        roughness: Some(&roughness),
        illumination: Some(&illum_units),
    };
    let prepare = |kind: ParamKind| -> Result<Option<SceneData>, TrainError> {
        let which: Vec<usize> = (0..inputs.views.len())
            .filter(|&i| {
                let v = &inputs.views[i];
                uses_view(kind, v.has_backlit(), v.has_checker())
            })
            .collect();
        if which.is_empty() {
            return Ok(None);
        }
        let tensors = inputs.tensors(kind, &which, &deps, &device)?;
        let diff_channel = kind
            .inputs()
            .iter()
            .position(|c| *c == InputChannel::LitSqrtDiffLuma)
            .or_else(|| {
                kind.inputs()
                    .iter()
                    .position(|c| *c == InputChannel::LitSqrtDiffY)
            });
        let mut views = Vec::with_capacity(which.len());
        for (tensor, &index) in tensors.into_iter().zip(&which) {
            let input = tensor
                .into_data()
                .try_to_vec::<f32>()
                .map_err(|e| TrainError::Backend(format!("{e:?}")))?;
            let lit_diff = match diff_channel {
                Some(c) => input[c * n..(c + 1) * n]
                    .iter()
                    .map(|&v| uncentre(v).powi(2))
                    .collect(),
                None => vec![0.0; n],
            };
            views.push(ViewData {
                input,
                mask: inputs.views[index].mask.clone(),
                illum: illum_all[index].clone(),
                lit_diff,
            });
        }
        let target = match kind {
            ParamKind::Roughness => roughness.clone(),
            ParamKind::Metallic => metallic.clone(),
            ParamKind::Transmission => transmission.clone(),
            ParamKind::Subsurface => subsurface.clone(),
            ParamKind::Basecolor => {
                let Some(TruthImage::Rgb(rgb)) =
                    bundle.read_truth(&reference, &TruthMap::Param(Param::Basecolor))?
                else {
                    return Err(no_truth("truth basecolor"));
                };
                let ycc: Vec<[f32; 3]> = rgb.data.iter().map(|c| ycbcr(c.map(unit))).collect();
                (0..3)
                    .flat_map(|ch| ycc.iter().map(move |p| unit(p[ch])))
                    .collect()
            }
        };
        Ok(Some(SceneData {
            path: path.to_path_buf(),
            reference: reference.clone(),
            width: inputs.width,
            height: inputs.height,
            views,
            target,
            mask: mask.clone(),
        }))
    };
    kinds.iter().map(|&kind| prepare(kind)).collect()
}

/// How a sample is cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cut {
    /// Crop side (clamped to the image).
    pub crop: usize,
    /// Mean-pool the crop down to at most this side (the stems-only phase);
    /// `None` keeps full resolution.
    pub pool_to: Option<usize>,
    /// Fraction of input pixels dropped, in thousandths.
    pub dropout_permille: u32,
}

/// A crop of one scene, ready to become tensors.
#[derive(Clone, Debug)]
pub struct Sample {
    /// Side lengths `[height, width]`.
    pub size: [usize; 2],
    /// Per chosen view: its input `[channels][pixels]`.
    pub inputs: Vec<Vec<f32>>,
    /// Per chosen view: mapped mask.
    pub view_masks: Vec<Vec<f32>>,
    /// Per chosen view: illumination truth in [0, 1].
    pub illum: Vec<Vec<f32>>,
    /// Per chosen view: `luminance(lit - ambient)`.
    pub lit_diff: Vec<Vec<f32>>,
    /// `[fused outputs][pixels]` in [0, 1].
    pub target: Vec<f32>,
    /// Reference and truth mask.
    pub mask: Vec<f32>,
}

/// Copies the `[y0, y0 + h) x [x0, x0 + w)` window of each `width`-wide
/// plane of `planes` (all planes stacked), then mean-pools by `factor`.
fn window(
    planes: &[f32],
    width: usize,
    height: usize,
    [y0, x0, h, w]: [usize; 4],
    factor: usize,
) -> Vec<f32> {
    let plane = width * height;
    let count = planes.len() / plane.max(1);
    let (ph, pw) = (h / factor, w / factor);
    let mut out = Vec::with_capacity(count * ph * pw);
    let scale = 1.0 / (factor * factor) as f32;
    for c in 0..count {
        let base = c * plane;
        for y in 0..ph {
            for x in 0..pw {
                let mut sum = 0.0;
                for dy in 0..factor {
                    for dx in 0..factor {
                        let (yy, xx) = (y0 + y * factor + dy, x0 + x * factor + dx);
                        sum += planes[base + yy * width + xx];
                    }
                }
                out.push(sum * scale);
            }
        }
    }
    out
}

impl SceneData {
    /// Cuts a sample from `views` (indices into [`views`](Self::views)).
    /// The crop is re-drawn (up to 8 times) until it holds at least 5 % of
    /// object pixels.
    pub fn sample(&self, views: &[usize], cut: Cut, rng: &mut impl Rng) -> Sample {
        let (h, w) = (cut.crop.min(self.height), cut.crop.min(self.width));
        let mut origin = [0, 0];
        for _ in 0..8 {
            origin = [
                rng.gen_range(0..=self.height - h),
                rng.gen_range(0..=self.width - w),
            ];
            let m = window(
                &self.mask,
                self.width,
                self.height,
                [origin[0], origin[1], h, w],
                1,
            );
            if m.iter().sum::<f32>() >= 0.05 * (h * w) as f32 {
                break;
            }
        }
        let factor = match cut.pool_to {
            Some(side) if side > 0 => h.max(w).div_ceil(side).max(1),
            _ => 1,
        };
        // Pooling needs whole blocks: trim the crop to a multiple of the factor.
        let (h, w) = ((h / factor).max(1) * factor, (w / factor).max(1) * factor);
        let rect = [origin[0], origin[1], h, w];
        let cut_planes = |p: &[f32]| window(p, self.width, self.height, rect, factor);
        let size = [h / factor, w / factor];
        let pixels = size[0] * size[1];
        let mut inputs = Vec::with_capacity(views.len());
        let mut view_masks = Vec::with_capacity(views.len());
        let mut illum = Vec::with_capacity(views.len());
        let mut lit_diff = Vec::with_capacity(views.len());
        let p = cut.dropout_permille.min(1000);
        for &v in views {
            let view = &self.views[v];
            let mut input = cut_planes(&view.input);
            if p > 0 {
                let channels = input.len() / pixels.max(1);
                for i in 0..pixels {
                    if rng.gen_range(0..1000) < p {
                        for c in 0..channels {
                            input[c * pixels + i] = 0.0;
                        }
                    }
                }
            }
            inputs.push(input);
            view_masks.push(cut_planes(&view.mask));
            illum.push(cut_planes(&view.illum));
            lit_diff.push(cut_planes(&view.lit_diff));
        }
        Sample {
            size,
            inputs,
            view_masks,
            illum,
            lit_diff,
            target: cut_planes(&self.target),
            mask: cut_planes(&self.mask),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_crop_and_pool_every_plane() {
        // Two 4x4 planes: values 0..16 and 16..32.
        let planes: Vec<f32> = (0..32).map(|v| v as f32).collect();
        let crop = window(&planes, 4, 4, [1, 1, 2, 2], 1);
        assert_eq!(crop, vec![5.0, 6.0, 9.0, 10.0, 21.0, 22.0, 25.0, 26.0]);
        let pooled = window(&planes, 4, 4, [0, 0, 4, 4], 2);
        assert_eq!(pooled, vec![2.5, 4.5, 10.5, 12.5, 18.5, 20.5, 26.5, 28.5]);
    }
}
