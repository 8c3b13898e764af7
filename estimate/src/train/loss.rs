//! The five training losses of sections 3.2.3.1 to 3.2.3.5, on one sample
//! (batch size b = 1, so the thesis's `/ b` drops out).
//!
//! Every loss is computed in parameter units, `[0, 1]`: the network's
//! centred output `y` is mapped back by `(y + 1) / 2` (without the clamp of
//! `inputs::uncentre`, so gradients flow everywhere). Channel errors of
//! basecolor's three YCbCr outputs are averaged, so every network's loss is
//! a per-pixel mean squared error.
//!
//! - Roughness (eqs. 3.7 to 3.9): illumination MSE over each view's mapped
//!   mask, plus roughness MSE weighted by `M_illum`, the illumination truth
//!   max-fused over the sample's views (the thesis fuses the truth with the
//!   features' max).
//! - Transmission (eq. 3.10): MSE over the mask plus 0.5 times the false
//!   positive share. The thesis's indicator `[y > 0 and Y = 0]` has no
//!   gradient, so it is replaced by the hinge `max(y, 0)` where `Y = 0`
//!   (`Y <= ZERO_TRUTH`): it is 0 exactly where the indicator is 0, at most 1
//!   on the training range, and pulls false positives down at a constant
//!   rate however small they are (a sigmoid would stop pulling near 0).
//! - Subsurface (eq. 3.11): as transmission, with the MSE weighted by
//!   `M_illum` instead of the mask.
//! - Metallic (eq. 3.12, the thesis's recommendation over 3.13): MSE with
//!   `W = M_illum (1 + luminance(lit - ambient))`; the second output
//!   (the inverse) is not trained, and the pipeline never reads it.
//! - Basecolor (eq. 3.15): the same `W`, on the mixed subsurface-basecolor
//!   in YCbCr. Where several views are fused, `luminance(lit - ambient)` is
//!   their maximum, like `M_illum`.
//!
//! Weights are constants (plain tensors without gradient). Out of scope:
//! cutting samples (see `data`), the loop (see the module root).

use super::data::Sample;
use crate::net::network::NetOutput;
use crate::net::spec::NetworkSpec;
use burn::tensor::{Device, Tensor, TensorData};
use matscan_scan::Param;

/// Truth values at or below this count as "zero" for the false-positive term.
pub const ZERO_TRUTH: f32 = 1.0e-3;
/// Weight of the false-positive term (eqs. 3.10 and 3.11).
pub const FALSE_POSITIVE_WEIGHT: f32 = 0.5;
/// Guard against empty masks.
const EPS: f32 = 1.0e-6;

/// A sample's tensors on the training device.
pub struct Batch {
    /// One `[1, inputs, h, w]` per view.
    pub views: Vec<Tensor<4>>,
    kind: Param,
    size: [usize; 2],
    target: Tensor<4>,
    /// `[fused outputs][pixels]`, kept for the false-positive mask.
    target_host: Vec<f32>,
    mask: Vec<f32>,
    view_masks: Vec<Vec<f32>>,
    illum: Vec<Tensor<4>>,
    illum_host: Vec<Vec<f32>>,
    lit_diff: Vec<Vec<f32>>,
    device: Device,
}

fn tensor(data: Vec<f32>, channels: usize, [h, w]: [usize; 2], device: &Device) -> Tensor<4> {
    Tensor::<4>::from_data(TensorData::new(data, [1, channels, h, w]), device)
}

impl Batch {
    /// Moves `sample` of `kind`'s network onto `device`.
    pub fn new(kind: Param, sample: Sample, device: &Device) -> Batch {
        let size = sample.size;
        let inputs = kind.inputs().len();
        // Targets carry what is trained: metallic's one map, basecolor's three.
        let outputs = sample.target.len() / (size[0] * size[1]).max(1);
        let views = sample
            .inputs
            .into_iter()
            .map(|v| tensor(v, inputs, size, device))
            .collect();
        let illum = sample
            .illum
            .iter()
            .map(|v| tensor(v.clone(), 1, size, device))
            .collect();
        Batch {
            views,
            kind,
            size,
            target: tensor(sample.target.clone(), outputs, size, device),
            target_host: sample.target,
            mask: sample.mask,
            view_masks: sample.view_masks,
            illum,
            illum_host: sample.illum,
            lit_diff: sample.lit_diff,
            device: device.clone(),
        }
    }

    fn plane(&self, data: Vec<f32>) -> Tensor<4> {
        tensor(data, 1, self.size, &self.device)
    }

    /// Max over the views of `planes`, per pixel.
    fn max_over(planes: &[Vec<f32>], pixels: usize) -> Vec<f32> {
        (0..pixels)
            .map(|i| planes.iter().map(|p| p[i]).fold(0.0, f32::max))
            .collect()
    }

    /// `M_illum`, masked.
    fn illum_weight(&self) -> Vec<f32> {
        let fused = Self::max_over(&self.illum_host, self.mask.len());
        fused.iter().zip(&self.mask).map(|(a, m)| a * m).collect()
    }

    /// `M_illum (1 + luminance(lit - ambient))`, masked.
    fn highlight_weight(&self) -> Vec<f32> {
        let diff = Self::max_over(&self.lit_diff, self.mask.len());
        self.illum_weight()
            .iter()
            .zip(&diff)
            .map(|(w, d)| w * (1.0 + d))
            .collect()
    }

    /// Per-pixel squared error averaged over channels, weighted by `weight`
    /// and divided by its sum.
    fn weighted_mse(
        &self,
        prediction: Tensor<4>,
        target: Tensor<4>,
        weight: Vec<f32>,
    ) -> Tensor<1> {
        let channels = prediction.dims()[1] as f32;
        let total: f32 = weight.iter().sum();
        let squared = (prediction - target).powi_scalar(2).sum_dim(1);
        (squared * self.plane(weight))
            .sum()
            .div_scalar(channels * total.max(EPS))
    }

    /// `0.5 * sum(max(y, 0) where Y = 0) / sum(mask)`.
    fn false_positives(&self, prediction: Tensor<4>) -> Tensor<1> {
        let n: f32 = self.mask.iter().sum();
        let zero: Vec<f32> = self
            .target_host
            .iter()
            .zip(&self.mask)
            .map(|(t, m)| if *t <= ZERO_TRUTH { *m } else { 0.0 })
            .collect();
        (prediction.clamp_min(0.0) * self.plane(zero))
            .sum()
            .mul_scalar(FALSE_POSITIVE_WEIGHT / n.max(EPS))
    }

    /// The network's loss on this batch (see the module documentation).
    pub fn loss(&self, out: &NetOutput) -> Tensor<1> {
        let fused = unit(out.fused.clone());
        let target = self.target.clone();
        match self.kind {
            Param::Roughness => {
                let mut squared: Option<Tensor<1>> = None;
                let mut count = 0.0;
                for ((pred, truth), mask) in
                    out.per_view.iter().zip(&self.illum).zip(&self.view_masks)
                {
                    count += mask.iter().sum::<f32>();
                    let e = ((unit(pred.clone()) - truth.clone()).powi_scalar(2)
                        * self.plane(mask.clone()))
                    .sum();
                    squared = Some(match squared {
                        Some(s) => s + e,
                        None => e,
                    });
                }
                let rough = self.weighted_mse(fused, target, self.illum_weight());
                match squared {
                    Some(s) => rough + s.div_scalar(count.max(EPS)),
                    None => rough,
                }
            }
            Param::Transmission => {
                let mse = self.weighted_mse(fused.clone(), target, self.mask.clone());
                mse + self.false_positives(fused)
            }
            Param::Subsurface => {
                let mse = self.weighted_mse(fused.clone(), target, self.illum_weight());
                mse + self.false_positives(fused)
            }
            Param::Metallic => {
                // Eq. 3.12: only the metallic channel (the first output).
                let metallic = fused.narrow(1, 0, 1);
                self.weighted_mse(metallic, target, self.highlight_weight())
            }
            Param::Basecolor => self.weighted_mse(fused, target, self.highlight_weight()),
        }
    }
}

/// Network units to parameter units, unclamped.
fn unit(t: Tensor<4>) -> Tensor<4> {
    t.add_scalar(1.0).mul_scalar(0.5)
}
