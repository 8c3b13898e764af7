//! The four building blocks of every parameter network (thesis figures 3.17
//! to 3.19): input stem, core (used twice: as *core*, which also reads the
//! scanner inputs, and as *core'*, which reads only the features), and output
//! stem. All four wrap one inception unit.
//!
//! The inception unit: a 1x1 reduction to `track` channels for each of three
//! tracks (receptive fields 1x1; 3x3 as 3x1 then 1x3; 5x5 as two such pairs),
//! the tracks concatenated to 3 `track` channels, and a 1x1 expansion to the
//! block's output width. The thesis uses 128 features and 32-channel tracks.
//! The three reductions are stored as one 1x1 convolution with 3 `track`
//! outputs: the same function, one matrix product instead of three.
//!
//! Following section 3.2.1 literally, the only non-linearity of a block is
//! the leaky ReLU (slope 0.01) at its end, after the residual addition
//! (`features + 0.1 * residual`; scanner inputs feed the residual only). The
//! output stem ends linear: a leaky ReLU there would make negative outputs
//! (signed chroma, zero-centred maps) a hundred times harder to reach.
//! Dropout, used by the thesis for regularisation in training, is not part
//! of inference and is left to the trainer.
//!
//! 1x1 convolutions use the backend's convolution, whose pointwise fast
//! path measured 1.6x faster on flex than a reshape plus matrix product.
//!
//! Out of scope: the pyramid, fusion and which block runs when (see
//! `network`).

use burn::module::{Initializer, Module, Param};
use burn::tensor::activation::leaky_relu;
use burn::tensor::module::conv2d;
use burn::tensor::ops::ConvOptions;
use burn::tensor::{Device, Tensor};

/// Negative slope of the leaky ReLU closing each block.
pub const LEAKY_SLOPE: f64 = 0.01;
/// Scale of the residual before it is added to the features.
pub const RESIDUAL_SCALE: f64 = 0.1;

/// A 2D convolution with bias, weight `[out, in, kh, kw]`, "same" padding.
#[derive(Module, Debug)]
pub struct Conv {
    pub(crate) weight: Param<Tensor<4>>,
    pub(crate) bias: Param<Tensor<1>>,
}

impl Conv {
    fn new(channels_in: usize, channels_out: usize, kernel: [usize; 2], device: &Device) -> Self {
        let fan_in = channels_in * kernel[0] * kernel[1];
        let fan_out = channels_out * kernel[0] * kernel[1];
        // burn's own convolution default: uniform in +-1/sqrt(fan_in).
        let init = Initializer::KaimingUniform {
            gain: 1.0 / 3f64.sqrt(),
            fan_out_only: false,
        };
        Conv {
            weight: init.init_with(
                [channels_out, channels_in, kernel[0], kernel[1]],
                Some(fan_in),
                Some(fan_out),
                device,
            ),
            bias: init.init_with([channels_out], Some(fan_in), Some(fan_out), device),
        }
    }

    /// `[out, in, kh, kw]`.
    pub(crate) fn weight_shape(&self) -> [usize; 4] {
        self.weight.val().dims()
    }

    /// A 1x1 convolution with input channels `range` of the weight; adds
    /// the bias only when asked.
    fn pointwise(&self, x: Tensor<4>, range: std::ops::Range<usize>, with_bias: bool) -> Tensor<4> {
        let all_in = self.weight_shape()[1];
        let weight = if range.start == 0 && range.end == all_in {
            self.weight.val()
        } else {
            self.weight.val().narrow(1, range.start, range.len())
        };
        let bias = with_bias.then(|| self.bias.val());
        conv2d(x, weight, bias, ConvOptions::new([1, 1], [0, 0], [1, 1], 1))
    }

    /// A spatial convolution, zero padded to keep the image size.
    fn spatial(&self, x: Tensor<4>) -> Tensor<4> {
        let [_, _, kh, kw] = self.weight_shape();
        let options = ConvOptions::new([1, 1], [kh / 2, kw / 2], [1, 1], 1);
        conv2d(x, self.weight.val(), Some(self.bias.val()), options)
    }
}

/// The convolutional track shared by all four blocks.
#[derive(Module, Debug)]
pub struct InceptionUnit {
    /// The three tracks' 1x1 reductions, stacked: `in -> 3 track`.
    reduce: Conv,
    /// 3x3 track: 3x1 then 1x3.
    mid_3x1: Conv,
    mid_1x3: Conv,
    /// 5x5 track: two 3x1-then-1x3 pairs.
    wide_3x1_a: Conv,
    wide_1x3_a: Conv,
    wide_3x1_b: Conv,
    wide_1x3_b: Conv,
    /// 1x1 back from the concatenated tracks to the block's output width.
    expand: Conv,
    track: usize,
}

impl InceptionUnit {
    fn new(channels_in: usize, channels_out: usize, track: usize, device: &Device) -> Self {
        let tall = |d| Conv::new(track, track, [3, 1], d);
        let flat = |d| Conv::new(track, track, [1, 3], d);
        InceptionUnit {
            reduce: Conv::new(channels_in, 3 * track, [1, 1], device),
            mid_3x1: tall(device),
            mid_1x3: flat(device),
            wide_3x1_a: tall(device),
            wide_1x3_a: flat(device),
            wide_3x1_b: tall(device),
            wide_1x3_b: flat(device),
            expand: Conv::new(3 * track, channels_out, [1, 1], device),
            track,
        }
    }

    /// The unit on a full input.
    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let channels = x.dims()[1];
        self.after_reduction(self.reduce.pointwise(x, 0..channels, true))
    }

    /// The unit from the summed 1x1 reductions `[n, 3 track, h, w]` onwards.
    fn after_reduction(&self, reduced: Tensor<4>) -> Tensor<4> {
        let mut tracks = reduced.split(self.track, 1).into_iter();
        let (Some(point), Some(mid), Some(wide)) = (tracks.next(), tracks.next(), tracks.next())
        else {
            unreachable!("the reduction always has three tracks of `track` channels")
        };
        let mid = self.mid_1x3.spatial(self.mid_3x1.spatial(mid));
        let wide = self.wide_1x3_a.spatial(self.wide_3x1_a.spatial(wide));
        let wide = self.wide_1x3_b.spatial(self.wide_3x1_b.spatial(wide));
        let joined = Tensor::cat(vec![point, mid, wide], 1);
        let channels = joined.dims()[1];
        self.expand.pointwise(joined, 0..channels, true)
    }

    /// The convolutions with stable names, for weight files.
    pub(crate) fn convs(&self) -> [(&'static str, &Conv); 8] {
        [
            ("reduce", &self.reduce),
            ("mid_3x1", &self.mid_3x1),
            ("mid_1x3", &self.mid_1x3),
            ("wide_3x1_a", &self.wide_3x1_a),
            ("wide_1x3_a", &self.wide_1x3_a),
            ("wide_3x1_b", &self.wide_3x1_b),
            ("wide_1x3_b", &self.wide_1x3_b),
            ("expand", &self.expand),
        ]
    }

    /// Mutable access in the order of [`convs`](Self::convs).
    pub(crate) fn convs_mut(&mut self) -> [&mut Conv; 8] {
        [
            &mut self.reduce,
            &mut self.mid_3x1,
            &mut self.mid_1x3,
            &mut self.wide_3x1_a,
            &mut self.wide_1x3_a,
            &mut self.wide_3x1_b,
            &mut self.wide_1x3_b,
            &mut self.expand,
        ]
    }
}

/// Scanner inputs to features (figure 3.19, top); no residual.
#[derive(Module, Debug)]
pub struct InputStem {
    pub(crate) unit: InceptionUnit,
}

impl InputStem {
    /// `inputs` channels in, `width` features out, `track` channels per track.
    pub fn new(inputs: usize, width: usize, track: usize, device: &Device) -> Self {
        InputStem {
            unit: InceptionUnit::new(inputs, width, track, device),
        }
    }

    /// `[n, inputs, h, w]` to `[n, width, h, w]`.
    pub fn forward(&self, inputs: Tensor<4>) -> Tensor<4> {
        leaky_relu(self.unit.forward(inputs), LEAKY_SLOPE)
    }
}

/// The 1x1 reduction of the leading feature channels that are identical in
/// every view, computed once and reused by each view's [`Core`] pass.
#[derive(Clone, Debug)]
pub struct SharedReduction {
    value: Tensor<4>,
    channels: usize,
}

/// The residual refinement block (figure 3.18 with scanner inputs: *core*;
/// figure 3.17 without: *core'*).
#[derive(Module, Debug)]
pub struct Core {
    pub(crate) unit: InceptionUnit,
    width: usize,
    inputs: usize,
}

impl Core {
    /// `width` features refined with `inputs` scanner channels (0 for core').
    pub fn new(width: usize, inputs: usize, track: usize, device: &Device) -> Self {
        Core {
            unit: InceptionUnit::new(width + inputs, width, track, device),
            width,
            inputs,
        }
    }

    /// Number of scanner input channels this block reads.
    pub fn input_channels(&self) -> usize {
        self.inputs
    }

    /// Refines `features` `[n, width, h, w]`, reading `inputs` `[n, inputs,
    /// h, w]` when the block has inputs.
    pub fn forward(&self, features: Tensor<4>, inputs: Option<Tensor<4>>) -> Tensor<4> {
        let shared = self.reduce_shared(features.clone());
        self.forward_with_shared(features, &shared, inputs)
    }

    /// The reduction of the first `shared.dims()[1]` feature channels (with
    /// the bias), to be reused for every view that holds the same values there.
    pub fn reduce_shared(&self, shared: Tensor<4>) -> SharedReduction {
        let channels = shared.dims()[1].min(self.width);
        let shared = shared.narrow(1, 0, channels);
        SharedReduction {
            value: self.unit.reduce.pointwise(shared, 0..channels, true),
            channels,
        }
    }

    /// [`forward`](Self::forward) with the leading channels' reduction given:
    /// `features` must hold exactly the values `shared` was computed from in
    /// those channels.
    pub fn forward_with_shared(
        &self,
        features: Tensor<4>,
        shared: &SharedReduction,
        inputs: Option<Tensor<4>>,
    ) -> Tensor<4> {
        let mut reduced = shared.value.clone();
        if shared.channels < self.width {
            let own = features
                .clone()
                .narrow(1, shared.channels, self.width - shared.channels);
            reduced = reduced
                + self
                    .unit
                    .reduce
                    .pointwise(own, shared.channels..self.width, false);
        }
        if let (Some(inputs), true) = (inputs, self.inputs > 0) {
            let all = self.width + self.inputs;
            reduced = reduced + self.unit.reduce.pointwise(inputs, self.width..all, false);
        }
        let residual = self.unit.after_reduction(reduced);
        leaky_relu(features + residual.mul_scalar(RESIDUAL_SCALE), LEAKY_SLOPE)
    }
}

/// Features to parameter maps (figure 3.19, bottom); linear output.
#[derive(Module, Debug)]
pub struct OutputStem {
    pub(crate) unit: InceptionUnit,
}

impl OutputStem {
    /// `width` features in, `outputs` channels out.
    pub fn new(width: usize, outputs: usize, track: usize, device: &Device) -> Self {
        OutputStem {
            unit: InceptionUnit::new(width, outputs, track, device),
        }
    }

    /// `[n, width, h, w]` to `[n, outputs, h, w]`.
    pub fn forward(&self, features: Tensor<4>) -> Tensor<4> {
        self.unit.forward(features)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::backend::cpu_device;
    use burn::tensor::{Distribution, TensorData};

    fn random(shape: [usize; 4], device: &Device) -> Tensor<4> {
        Tensor::random(shape, Distribution::Uniform(-1.0, 1.0), device)
    }

    fn values(t: Tensor<4>) -> Vec<f32> {
        t.into_data().try_to_vec::<f32>().expect("f32 tensor")
    }

    #[test]
    fn pointwise_on_a_channel_range_equals_a_convolution_of_those_channels() {
        let device = cpu_device();
        let conv = Conv::new(5, 7, [1, 1], &device);
        let middle = random([2, 3, 6, 4], &device);
        // The same three channels, with zeros in the channels left out.
        let zeros = Tensor::<4>::zeros([2, 1, 6, 4], &device);
        let padded = Tensor::cat(vec![zeros.clone(), middle.clone(), zeros], 1);
        let by_range = values(conv.pointwise(middle, 1..4, false));
        let by_full = values(conv.pointwise(padded.clone(), 0..5, false));
        assert_eq!(by_range.len(), 2 * 7 * 6 * 4);
        for (a, b) in by_range.iter().zip(&by_full) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
        // With the bias, it is the spatial path's 1x1 convolution.
        let with_bias = values(conv.pointwise(padded.clone(), 0..5, true));
        for (a, b) in with_bias.iter().zip(&values(conv.spatial(padded))) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }

    #[test]
    fn blocks_keep_the_image_size_and_map_the_channels() {
        let device = cpu_device();
        let x = random([1, 5, 9, 7], &device);
        let stem = InputStem::new(5, 12, 4, &device);
        let f = stem.forward(x.clone());
        assert_eq!(f.dims(), [1, 12, 9, 7]);
        let core = Core::new(12, 5, 4, &device);
        assert_eq!(core.forward(f.clone(), Some(x)).dims(), [1, 12, 9, 7]);
        let core_prime = Core::new(12, 0, 4, &device);
        assert_eq!(core_prime.forward(f.clone(), None).dims(), [1, 12, 9, 7]);
        let out = OutputStem::new(12, 3, 4, &device);
        assert_eq!(out.forward(f).dims(), [1, 3, 9, 7]);
    }

    #[test]
    fn shared_reduction_gives_the_same_result_as_a_full_pass() {
        let device = cpu_device();
        let core = Core::new(8, 3, 2, &device);
        let features = random([1, 8, 5, 6], &device);
        let inputs = random([1, 3, 5, 6], &device);
        let full = values(core.forward(features.clone(), Some(inputs.clone())));
        // Half of the channels shared, as the roughness network does.
        let shared = core.reduce_shared(features.clone().narrow(1, 0, 4));
        let split = values(core.forward_with_shared(features, &shared, Some(inputs)));
        for (a, b) in full.iter().zip(&split) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }

    #[test]
    fn core_is_residual_with_scaled_update_and_leaky_relu() {
        let device = cpu_device();
        let mut core = Core::new(2, 1, 1, &device);
        // Zero expansion: the residual is exactly zero, so the block is the
        // leaky ReLU of its features.
        let expand = &mut core.unit.expand;
        expand.weight = Param::from_tensor(Tensor::zeros([2, 3, 1, 1], &device));
        expand.bias = Param::from_tensor(Tensor::zeros([2], &device));
        let features = Tensor::<4>::from_data(
            TensorData::new(vec![2.0f32, -3.0, 0.5, -1.0], [1, 2, 1, 2]),
            &device,
        );
        let inputs = random([1, 1, 1, 2], &device);
        let out = values(core.forward(features, Some(inputs)));
        for (v, want) in out.iter().zip([2.0f32, -0.03, 0.5, -0.01]) {
            assert!((v - want).abs() < 1e-7, "{v} vs {want}");
        }
        // A constant bias of 1 in the expansion adds exactly 0.1.
        core.unit.expand.bias = Param::from_tensor(Tensor::ones([2], &device));
        let features = Tensor::<4>::from_data(
            TensorData::new(vec![1.0f32, 1.0, 1.0, 1.0], [1, 2, 1, 2]),
            &device,
        );
        let out = values(core.forward(features, None));
        for v in out {
            assert!((v - 1.1).abs() < 1e-6, "{v}");
        }
    }
}
