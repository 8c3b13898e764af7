//! Training samples cut from scenes prepared with truth dependencies
//! ([`SceneData`], see `truth_fed`).
//!
//! A [`Sample`] is cut from a scene on the CPU side (plain `Vec<f32>`): a
//! random crop, a choice of views, optional mean-pooling down to the
//! stems-only size, and the "dropout-like removal of input pixels" (every
//! channel of a dropped pixel, mapped mask included, is set to 0: a hole).
//! Doing this before any tensor exists keeps it backend-independent and
//! cheap at the training crop sizes.
//!
//! Out of scope: losses (see `loss`), the loop (see the module root).

use crate::pipeline::truth_fed::SceneData;
use rand::Rng;

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
