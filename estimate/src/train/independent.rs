//! The thesis's *independent* evaluation (section 4.5, Tables 4.1 to 4.3):
//! one network at a time, fed the **truth** of the parameters it depends on
//! (metallic, the effective transmission and subsurface, roughness and the
//! per-view illumination truth) instead of the other networks' estimates.
//!
//! This is how the thesis's reference figures were measured, so comparing
//! with them needs it; the chained path (`pipeline::estimate`, every network
//! fed by the estimates before it, the thesis's section 4.8) is what a user
//! gets and is reported separately. The inputs are the training path's own
//! [`SceneData`] (built by the inference code's `SceneInputs`), so the two
//! evaluations differ only in where the dependencies come from.
//!
//! Out of scope: metrics and tables (the caller's), loading scenes (see
//! `data`).

use super::data::SceneData;
use super::TrainError;
use crate::inputs::{rgb_of_ycbcr, uncentre};
use crate::network::ParamNet;
use crate::spec::ParamKind;
use burn::tensor::{Device, Tensor, TensorData};

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
/// truth dependencies by [`super::data::load_scene`].
pub fn predict(
    net: &ParamNet,
    scene: &SceneData,
    views: usize,
    device: &Device,
) -> Result<IndependentMap, TrainError> {
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
        .map_err(|e| TrainError::Backend(format!("{kind}: {e}")))?;
    let fused = out
        .fused
        .into_data()
        .try_to_vec::<f32>()
        .map_err(|e| TrainError::Backend(format!("{e:?}")))?;
    if fused.len() < n * kind.fused_outputs().len() {
        return Err(TrainError::Backend(format!(
            "{kind}: {} output values for {n} pixels",
            fused.len()
        )));
    }
    let on = |i: usize| scene.mask[i] > 0.5;
    Ok(if kind == ParamKind::Basecolor {
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
    use crate::backend::cpu_device;
    use crate::network::NetConfig;

    fn net(kind: ParamKind, device: &Device) -> ParamNet {
        ParamNet::new(NetConfig::with_track(kind, 8, 2).expect("valid"), device)
    }
    use crate::train::data::ViewData;

    fn scene(kind: ParamKind, views: usize, mask: Vec<f32>) -> SceneData {
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
        let net = net(ParamKind::Basecolor, &device);
        let s = scene(ParamKind::Basecolor, 2, vec![1.0, 1.0, 0.0, 1.0]);
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
        let net = net(ParamKind::Metallic, &device);
        let s = scene(ParamKind::Metallic, 3, vec![1.0; 6]);
        let all = predict(&net, &s, 0, &device).expect("all");
        let many = predict(&net, &s, 9, &device).expect("capped");
        let one = predict(&net, &s, 1, &device).expect("one");
        assert_eq!(all, many);
        assert_eq!(all.channels, 1);
        assert_ne!(all, one, "fusing three views must differ from one view");
    }
}
