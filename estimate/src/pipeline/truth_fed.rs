//! Scenes prepared for one network with the **truth** of what it reads:
//! metallic, the effective transmission `T (1 - M)` and effective
//! subsurface `S (1 - M) (1 - T)` (the bundle's truth maps are already
//! effective, see docs/scan-format.md), roughness, and the per-view
//! illumination truth (`illum_<capture>`, warped into the reference image)
//! in network units, as the thesis trained and evaluated each network on
//! its own (section 4.5).
//!
//! Each view's input planes are built by the inference path's own
//! [`SceneInputs`], so training, the truth-fed evaluation and inference
//! encode inputs identically; [`predict`] runs one network on such a
//! scene.
//!
//! Out of scope: sampling crops for training (`train::data`), metrics and
//! tables (the evaluation's).

use crate::net::spec::InputChannel;
use crate::net::spec::NetworkSpec;
use crate::pipeline::inputs::{centre, uncentre, Dependencies, SceneInputs};
use crate::pipeline::views::{select_views, ViewFilter};
use burn::tensor::Device;
use matscan_calib::photos::luma;
use matscan_calib::white_reference::ycbcr;
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_scan::estimate_maps::MapValues;
use matscan_scan::{Bundle, Param, TruthImage, TruthMap};
use std::path::{Path, PathBuf};

use crate::net::network::ParamNet;
use crate::pipeline::inputs::rgb_of_ycbcr;
use crate::pipeline::inputs::InputsError;
use crate::pipeline::views::ViewError;
use burn::tensor::{Tensor, TensorData};
use matscan_calib::CalibError;
use matscan_scan::ScanError;

/// A scene that could not be prepared.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A bundle could not be read.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// A bundle could not be calibrated.
    #[error("calibration: {0}")]
    Calib(#[from] CalibError),
    /// A bundle has no usable views.
    #[error(transparent)]
    Views(#[from] ViewError),
    /// Inputs could not be assembled.
    #[error(transparent)]
    Inputs(#[from] InputsError),
    /// A bundle lacks ground truth (only simulated scans have it).
    #[error("{}: no {what} (needs a simulated bundle with ground truth)", path.display())]
    NoTruth {
        /// The bundle.
        path: PathBuf,
        /// The missing map.
        what: String,
    },
    /// The network refused the scene or the backend failed to give data back.
    #[error("backend: {0}")]
    Backend(String),
}

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

fn scalar_truth(bundle: &Bundle, position: &str, param: Param) -> Result<Vec<f32>, SceneError> {
    let what = format!("truth {}", param.name());
    match bundle.truth_param(position, param)? {
        Some(MapValues::Scalar(r)) => Ok(r.data.iter().map(|v| unit(*v)).collect()),
        _ => Err(SceneError::NoTruth {
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
pub fn load_scene(path: &Path, kind: Param) -> Result<Option<SceneData>, SceneError> {
    Ok(load_scenes(path, &[kind])?.pop().flatten())
}

/// [`load_scene`] for each of `kinds`, in order, reading, calibrating and
/// assembling the bundle once for all of them.
pub fn load_scenes(path: &Path, kinds: &[Param]) -> Result<Vec<Option<SceneData>>, SceneError> {
    let device: Device = crate::device::backend::cpu_device();
    let bundle = Bundle::open(path)?;
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())?;
    let set = select_views(&bundle.manifest, &calibration, &ViewFilter::default())?;
    let inputs = SceneInputs::assemble(&bundle, &calibration, &set)?;
    let reference = set.reference.clone();
    let n = inputs.pixels();
    let no_truth = |what: &str| SceneError::NoTruth {
        path: path.to_path_buf(),
        what: what.to_string(),
    };

    let truth_mask = bundle
        .truth_mask(&reference)?
        .ok_or_else(|| no_truth("truth mask"))?
        .data;
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
    let prepare = |kind: Param| -> Result<Option<SceneData>, SceneError> {
        let which: Vec<usize> = (0..inputs.views.len())
            .filter(|&i| {
                let v = &inputs.views[i];
                v.serves(kind)
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
                .map_err(|e| SceneError::Backend(format!("{e:?}")))?;
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
            Param::Roughness => roughness.clone(),
            Param::Metallic => metallic.clone(),
            Param::Transmission => transmission.clone(),
            Param::Subsurface => subsurface.clone(),
            Param::Basecolor => {
                let Some(MapValues::Rgb(rgb)) = bundle.truth_param(&reference, Param::Basecolor)?
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

/// One network's map of a scene, in parameter units and the layout of the
/// pipeline's maps: pixel-major, one value per pixel, or RGB for basecolor;
/// 0 off the object.
#[derive(Clone, Debug, PartialEq)]
pub struct IndependentMap {
    /// Values per pixel (1, or 3 for basecolor).
    pub channels: usize,
    /// `pixels * channels` values.
    pub data: Vec<f32>,
}

/// Runs `net` on the first `views` views of `scene` (0 or more than the
/// scene has: all of them), the scene prepared for `net`'s parameter with
/// truth dependencies by [`load_scene`].
pub fn predict(
    net: &ParamNet,
    scene: &SceneData,
    views: usize,
    device: &Device,
) -> Result<IndependentMap, SceneError> {
    let kind = net.config().kind();
    let (h, w) = (scene.height, scene.width);
    let n = h * w;
    let count = match views {
        0 => scene.views.len(),
        k => k.min(scene.views.len()),
    };
    let channels_in = kind.inputs().len();
    let tensors: Vec<Tensor<4>> = scene.views[..count]
        .iter()
        .map(|v| {
            Tensor::<4>::from_data(
                TensorData::new(v.input.clone(), [1, channels_in, h, w]),
                device,
            )
        })
        .collect();
    let out = net
        .forward(&tensors)
        .map_err(|e| SceneError::Backend(format!("{kind}: {e}")))?;
    let fused = out
        .fused
        .into_data()
        .try_to_vec::<f32>()
        .map_err(|e| SceneError::Backend(format!("{e:?}")))?;
    if fused.len() < n * kind.fused_outputs().len() {
        return Err(SceneError::Backend(format!(
            "{kind}: {} output values for {n} pixels",
            fused.len()
        )));
    }
    let on = |i: usize| scene.mask[i] > 0.5;
    Ok(if kind == Param::Basecolor {
        let data = (0..n)
            .flat_map(|i| {
                if on(i) {
                    rgb_of_ycbcr([0, 1, 2].map(|c| uncentre(fused[c * n + i])))
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        IndependentMap { channels: 3, data }
    } else {
        let data = (0..n)
            .map(|i| if on(i) { uncentre(fused[i]) } else { 0.0 })
            .collect();
        IndependentMap { channels: 1, data }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::backend::cpu_device;
    use crate::net::network::NetConfig;

    fn net(kind: Param, device: &Device) -> ParamNet {
        ParamNet::new(NetConfig::with_track(kind, 8, 2).expect("valid"), device)
    }

    fn scene(kind: Param, views: usize, mask: Vec<f32>) -> SceneData {
        let n = mask.len();
        let c = kind.inputs().len();
        SceneData {
            path: "memory".into(),
            reference: "p0".into(),
            width: n,
            height: 1,
            views: (0..views)
                .map(|v| ViewData {
                    input: (0..c * n)
                        .map(|i| ((i + v) % 7) as f32 / 7.0 - 0.5)
                        .collect(),
                    mask: vec![1.0; n],
                    illum: vec![0.5; n],
                    lit_diff: vec![0.1; n],
                })
                .collect(),
            target: vec![0.0; n * kind.fused_outputs().len().min(3)],
            mask,
        }
    }

    #[test]
    fn basecolor_comes_back_as_rgb_in_the_unit_range_and_black_off_the_object() {
        let device = cpu_device();
        device.seed(3);
        let net = net(Param::Basecolor, &device);
        let s = scene(Param::Basecolor, 2, vec![1.0, 1.0, 0.0, 1.0]);
        let map = predict(&net, &s, 0, &device).expect("predicted");
        assert_eq!(map.channels, 3);
        assert_eq!(map.data.len(), 12);
        assert_eq!(&map.data[6..9], &[0.0; 3]);
        assert!(map.data.iter().all(|v| (0.0..=1.0).contains(v)));
    }

    #[test]
    fn fewer_views_than_asked_use_every_view_and_more_views_change_the_map() {
        let device = cpu_device();
        device.seed(5);
        let net = net(Param::Metallic, &device);
        let s = scene(Param::Metallic, 3, vec![1.0; 6]);
        let all = predict(&net, &s, 0, &device).expect("all");
        let many = predict(&net, &s, 9, &device).expect("capped");
        let one = predict(&net, &s, 1, &device).expect("one");
        assert_eq!(all, many);
        assert_eq!(all.channels, 1);
        assert_ne!(all, one, "fusing three views must differ from one view");
    }
}
