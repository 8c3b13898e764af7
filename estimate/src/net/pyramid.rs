//! The input pyramid of section 3.2.1: inputs average-pooled by halves down
//! to a coarsest level of at most 16x16, nearest-neighbour upsampling of the
//! features between levels, and the padding that lets any image size halve
//! evenly.
//!
//! Padding: zeros, appended at the bottom and right, up to the next multiple
//! of 2^halvings (the thesis's footnote 4: "the inputs can be zero padded").
//! Zeros are what a hole looks like to the networks (the mapped mask, the
//! first input of every network, is 0 there), so no extra mask channel is
//! needed; the outputs are cropped back to exactly the input size.
//!
//! Out of scope: what runs at each level (see `network`).

use burn::tensor::module::{avg_pool2d, interpolate};
use burn::tensor::ops::{AvgPoolOptions, InterpolateMode, InterpolateOptions, PadMode};
use burn::tensor::Tensor;

/// The coarsest level's largest side (thesis: 16x16).
pub const COARSEST_MAX: usize = 16;

/// An image size of zero pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("image size {height}x{width} has no pixels")]
pub struct EmptyImage {
    /// Rows.
    pub height: usize,
    /// Columns.
    pub width: usize,
}

/// How an image of a given size is padded and halved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PyramidPlan {
    size: [usize; 2],
    padded: [usize; 2],
    halvings: usize,
}

impl PyramidPlan {
    /// The plan for a `height` x `width` image: the fewest halvings that bring
    /// both sides to [`COARSEST_MAX`] or less.
    pub fn new(height: usize, width: usize) -> Result<Self, EmptyImage> {
        if height == 0 || width == 0 {
            return Err(EmptyImage { height, width });
        }
        let mut halvings = 0;
        while height.div_ceil(1 << halvings) > COARSEST_MAX
            || width.div_ceil(1 << halvings) > COARSEST_MAX
        {
            halvings += 1;
        }
        let step = 1usize << halvings;
        Ok(PyramidPlan {
            size: [height, width],
            padded: [height.div_ceil(step) * step, width.div_ceil(step) * step],
            halvings,
        })
    }

    /// The image size `[height, width]`.
    pub fn size(&self) -> [usize; 2] {
        self.size
    }

    /// The padded size `[height, width]`, divisible by 2^halvings.
    pub fn padded_size(&self) -> [usize; 2] {
        self.padded
    }

    /// How many times the padded image is halved; the pyramid has one level more.
    pub fn halvings(&self) -> usize {
        self.halvings
    }

    /// Size of `level` (0 = full resolution, [`halvings`](Self::halvings) = coarsest).
    pub fn level_size(&self, level: usize) -> [usize; 2] {
        [self.padded[0] >> level, self.padded[1] >> level]
    }

    /// Zero-pads `[n, c, height, width]` at the bottom and right to the padded size.
    pub fn pad(&self, image: Tensor<4>) -> Tensor<4> {
        let extra_rows = self.padded[0] - self.size[0];
        let extra_cols = self.padded[1] - self.size[1];
        if extra_rows == 0 && extra_cols == 0 {
            return image;
        }
        image.pad([(0, extra_rows), (0, extra_cols)], PadMode::Constant(0.0))
    }

    /// Crops a padded-size `[n, c, h, w]` back to the image size.
    pub fn crop(&self, image: Tensor<4>) -> Tensor<4> {
        if self.padded == self.size {
            return image;
        }
        image.narrow(2, 0, self.size[0]).narrow(3, 0, self.size[1])
    }

    /// The pyramid of `image` `[n, c, height, width]`: padded, then halved
    /// [`halvings`](Self::halvings) times; element 0 is full resolution.
    pub fn build(&self, image: Tensor<4>) -> Vec<Tensor<4>> {
        let mut levels = Vec::with_capacity(self.halvings + 1);
        levels.push(self.pad(image));
        for _ in 0..self.halvings {
            let finer = levels[levels.len() - 1].clone();
            levels.push(downsample_mean(finer));
        }
        levels
    }
}

/// Averages 2x2 blocks: `[n, c, 2h, 2w]` to `[n, c, h, w]`.
pub fn downsample_mean(image: Tensor<4>) -> Tensor<4> {
    avg_pool2d(image, AvgPoolOptions::new([2, 2]))
}

/// Nearest-neighbour doubling: `[n, c, h, w]` to `[n, c, 2h, 2w]`.
pub fn upsample_nearest(image: Tensor<4>) -> Tensor<4> {
    let [_, _, h, w] = image.dims();
    let options =
        InterpolateOptions::new(InterpolateMode::Nearest).with_output_size([2 * h, 2 * w]);
    interpolate(image, options)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::backend::cpu_device;
    use burn::tensor::TensorData;

    fn values(t: Tensor<4>) -> Vec<f32> {
        t.into_data().try_to_vec::<f32>().expect("f32 tensor")
    }

    #[test]
    fn plans_stop_at_sixteen_or_less() {
        let cases = [
            ((256, 256), 4, [256, 256], [16, 16]),
            ((512, 512), 5, [512, 512], [16, 16]),
            ((768, 768), 6, [768, 768], [12, 12]),
            ((97, 61), 3, [104, 64], [13, 8]),
            ((16, 16), 0, [16, 16], [16, 16]),
            ((1, 1), 0, [1, 1], [1, 1]),
            ((17, 3), 1, [18, 4], [9, 2]),
        ];
        for ((h, w), halvings, padded, coarsest) in cases {
            let plan = PyramidPlan::new(h, w).expect("non-empty");
            assert_eq!(plan.halvings(), halvings, "{h}x{w}");
            assert_eq!(plan.padded_size(), padded, "{h}x{w}");
            assert_eq!(plan.level_size(halvings), coarsest, "{h}x{w}");
        }
    }

    #[test]
    fn an_empty_image_has_no_plan() {
        assert_eq!(
            PyramidPlan::new(0, 5),
            Err(EmptyImage {
                height: 0,
                width: 5
            })
        );
    }

    #[test]
    fn padding_is_zero_and_crop_restores_the_image() {
        let device = cpu_device();
        let plan = PyramidPlan::new(17, 3).expect("non-empty");
        let data: Vec<f32> = (0..51).map(|i| i as f32 + 1.0).collect();
        let image = Tensor::<4>::from_data(TensorData::new(data.clone(), [1, 1, 17, 3]), &device);
        let padded = plan.pad(image);
        assert_eq!(padded.dims(), [1, 1, 18, 4]);
        let padded_values = values(padded.clone());
        assert_eq!(padded_values[3], 0.0, "right column");
        assert!(
            padded_values[17 * 4..].iter().all(|v| *v == 0.0),
            "bottom row"
        );
        assert_eq!(values(plan.crop(padded)), data);
    }

    #[test]
    fn pyramid_levels_are_block_means() {
        let device = cpu_device();
        let plan = PyramidPlan::new(20, 4).expect("non-empty");
        assert_eq!(plan.halvings(), 1);
        let data: Vec<f32> = (0..80).map(|i| i as f32).collect();
        let image = Tensor::<4>::from_data(TensorData::new(data, [1, 1, 20, 4]), &device);
        let levels = plan.build(image);
        assert_eq!(levels.len(), 2);
        assert_eq!(levels[1].dims(), [1, 1, 10, 2]);
        let coarse = values(levels[1].clone());
        // Top-left block: rows 0-1, columns 0-1 of a row-major ramp.
        assert_eq!(coarse[0], (0.0 + 1.0 + 4.0 + 5.0) / 4.0);
        assert_eq!(coarse[3], (10.0 + 11.0 + 14.0 + 15.0) / 4.0);
    }

    #[test]
    fn upsampling_repeats_each_pixel_in_a_2x2_block() {
        let device = cpu_device();
        let image = Tensor::<4>::from_data(
            TensorData::new(vec![1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0], [1, 1, 2, 3]),
            &device,
        );
        let up = upsample_nearest(image);
        assert_eq!(up.dims(), [1, 1, 4, 6]);
        assert_eq!(
            values(up),
            vec![
                1.0, 1.0, 2.0, 2.0, 3.0, 3.0, //
                1.0, 1.0, 2.0, 2.0, 3.0, 3.0, //
                4.0, 4.0, 5.0, 5.0, 6.0, 6.0, //
                4.0, 4.0, 5.0, 5.0, 6.0, 6.0,
            ]
        );
    }
}
