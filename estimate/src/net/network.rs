//! One parameter network (section 3.2.1, figures 3.16 and 3.20 to 3.23):
//! the four blocks run coarse to fine over the input pyramid, one instance
//! per view with shared weights, features fused across views after every
//! refinement.
//!
//! The order, per the thesis: the input stem on the coarsest level (at most
//! 16x16), fuse; then for each finer level: upsample the fused features
//! (nearest), refine with *core* (features plus that level's inputs) and
//! *core'*, fuse; finally the output stem at full resolution. An image of
//! 16x16 or less thus runs the two stems only. Every block is one instance,
//! called at every level and for every view, so weights are shared by
//! construction (never by cloned fields, which would drift apart in training).
//!
//! Roughness (section 3.2.3.1, figure 3.23): only the first half of the
//! features is fused; the second half stays per view and feeds a second
//! output track, the view's local illumination.
//!
//! Views run one after another, each leaf of the fusion tree computed when
//! the tree walk needs it (see `fusion`); the 1x1 reduction of the fused
//! features, identical for all views, is computed once per level. Memory is
//! therefore a few feature maps, not one per view.
//!
//! Inputs are made safe before anything else: NaN becomes 0 and values are
//! clamped to +-[`INPUT_LIMIT`] (the networks are trained on [-1, 1]).
//!
//! Out of scope: assembling the input channels (see `spec`), weight files
//! (see `weights`).

use crate::net::blocks::{Conv, Core, InputStem, OutputStem};
use crate::net::fusion::FusionTree;
use crate::net::pyramid::{upsample_nearest, EmptyImage, PyramidPlan};
use crate::net::spec::NetworkSpec;
use burn::module::Module;
use burn::tensor::{Device, Tensor};
use matscan_scan::Param;
use std::convert::Infallible;

/// Inputs are clamped to +- this before they enter a network.
pub const INPUT_LIMIT: f32 = 4.0;
/// Feature width of the thesis.
pub const THESIS_WIDTH: usize = 128;
/// Channels per inception track in the thesis.
pub const THESIS_TRACK: usize = 32;
/// Shipped width and track of roughness and basecolor, the networks with
/// the most inputs and the most to model.
pub const SHIPPED_WIDTH_MAIN: usize = 64;
/// See [`SHIPPED_WIDTH_MAIN`].
pub const SHIPPED_TRACK_MAIN: usize = 16;
/// Shipped width and track of metallic, transmission and subsurface.
pub const SHIPPED_WIDTH_SMALL: usize = 32;
/// See [`SHIPPED_WIDTH_SMALL`].
pub const SHIPPED_TRACK_SMALL: usize = 8;
/// Largest feature width accepted (a guard against corrupt weight headers).
pub const MAX_WIDTH: usize = 4096;

/// A network configuration that cannot be built.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// Width or track of zero, or above [`MAX_WIDTH`].
    #[error("{what} must be between 1 and {MAX_WIDTH}, got {value}")]
    OutOfRange {
        /// "width" or "track".
        what: &'static str,
        /// The value given.
        value: usize,
    },
    /// The roughness network halves its features.
    #[error(
        "the {kind} network splits its features in half, so its width must be even, got {width}"
    )]
    OddSplit {
        /// The network.
        kind: Param,
        /// The width given.
        width: usize,
    },
}

/// The shape of one parameter network: which parameter, how wide.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NetConfig {
    kind: Param,
    width: usize,
    track: usize,
}

impl NetConfig {
    /// `width` features; tracks of a quarter of it (the thesis's 128/32), at least 1.
    pub fn new(kind: Param, width: usize) -> Result<Self, ConfigError> {
        Self::with_track(kind, width, (width / 4).max(1))
    }

    /// `width` features and `track` channels per inception track.
    pub fn with_track(kind: Param, width: usize, track: usize) -> Result<Self, ConfigError> {
        for (what, value) in [("width", width), ("track", track)] {
            if value == 0 || value > MAX_WIDTH {
                return Err(ConfigError::OutOfRange { what, value });
            }
        }
        if kind.splits_features() && width % 2 == 1 {
            return Err(ConfigError::OddSplit { kind, width });
        }
        Ok(NetConfig { kind, width, track })
    }

    /// The thesis's network: 128 features, 32-channel tracks.
    pub fn thesis(kind: Param) -> Self {
        NetConfig {
            kind,
            width: THESIS_WIDTH,
            track: THESIS_TRACK,
        }
    }

    /// The widths this crate ships, chosen to meet the CPU budget (five
    /// networks, nine views, 256x256 within 30 s on two cores; see the crate
    /// documentation for the measurements).
    pub fn shipped(kind: Param) -> Self {
        let (width, track) = match kind {
            Param::Roughness | Param::Basecolor => (SHIPPED_WIDTH_MAIN, SHIPPED_TRACK_MAIN),
            Param::Metallic | Param::Transmission | Param::Subsurface => {
                (SHIPPED_WIDTH_SMALL, SHIPPED_TRACK_SMALL)
            }
        };
        NetConfig { kind, width, track }
    }

    /// Which parameter.
    pub fn kind(&self) -> Param {
        self.kind
    }

    /// Feature channels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Channels per inception track.
    pub fn track(&self) -> usize {
        self.track
    }

    /// Input channels per view ([`Param::inputs`]).
    pub fn in_channels(&self) -> usize {
        self.kind.inputs().len()
    }

    /// Channels of the fused output map.
    pub fn fused_out_channels(&self) -> usize {
        self.kind.fused_outputs().len()
    }

    /// Channels of each per-view output map (0 unless roughness).
    pub fn per_view_out_channels(&self) -> usize {
        self.kind.per_view_outputs().len()
    }

    /// Leading feature channels that are fused (all, or half for roughness).
    pub fn fused_width(&self) -> usize {
        if self.kind.splits_features() {
            self.width / 2
        } else {
            self.width
        }
    }

    /// Floating-point operations (multiply and add counted apart) of the
    /// convolutions in one forward pass of `views` views at this size.
    pub fn forward_flops(
        &self,
        height: usize,
        width: usize,
        views: usize,
    ) -> Result<f64, EmptyImage> {
        let plan = PyramidPlan::new(height, width)?;
        let (w, t, c) = (
            self.width as f64,
            self.track as f64,
            self.in_channels() as f64,
        );
        let s = self.fused_width() as f64;
        let v = views as f64;
        let unit = |channels_in: f64, channels_out: f64| {
            3.0 * t * channels_in + 18.0 * t * t + 3.0 * t * channels_out
        };
        let pixels = |level: usize| {
            let [h, w] = plan.level_size(level);
            (h * w) as f64
        };
        let mut macs = pixels(plan.halvings()) * v * unit(c, w);
        for level in 0..plan.halvings() {
            let per_view_core = unit(w - s + c, w) + unit(w, w);
            macs += pixels(level) * (3.0 * t * s + v * per_view_core);
        }
        macs += pixels(0)
            * if self.kind.splits_features() {
                unit(s, 1.0) + v * unit(w - s, 1.0)
            } else {
                unit(w, self.fused_out_channels() as f64)
            };
        Ok(2.0 * macs)
    }
}

/// Views that do not fit the network.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// No view given.
    #[error("the {kind} network needs at least one view")]
    NoViews {
        /// The network.
        kind: Param,
    },
    /// A view's tensor is not `[1, inputs, height, width]`.
    #[error("view {view} of the {kind} network has shape {found:?}, expected [1, {channels}, height, width]")]
    Shape {
        /// The network.
        kind: Param,
        /// Index of the view.
        view: usize,
        /// Its shape.
        found: [usize; 4],
        /// The network's input channels.
        channels: usize,
    },
    /// Views of different image sizes.
    #[error(
        "view {view} is {found:?} pixels but view 0 is {first:?}; all views must share one size"
    )]
    SizeMismatch {
        /// Index of the view.
        view: usize,
        /// Its `[height, width]`.
        found: [usize; 2],
        /// View 0's `[height, width]`.
        first: [usize; 2],
    },
    /// A view on another device than the weights.
    #[error("view {view} is on {found}, the {kind} network's weights on {expected}")]
    Device {
        /// The network.
        kind: Param,
        /// Index of the view.
        view: usize,
        /// The view's device.
        found: String,
        /// The weights' device.
        expected: String,
    },
    /// Zero pixels.
    #[error(transparent)]
    Empty(#[from] EmptyImage),
}

/// What a network returns.
#[derive(Clone, Debug)]
pub struct NetOutput {
    /// The fused map `[1, fused outputs, height, width]`, the same for every view.
    pub fused: Tensor<4>,
    /// One map `[1, per-view outputs, height, width]` per view, in view order
    /// (roughness's illumination); empty for the other networks.
    pub per_view: Vec<Tensor<4>>,
}

/// One parameter network: input stem, core, core', output stem(s).
#[derive(Module, Debug)]
pub struct ParamNet {
    input_stem: InputStem,
    core: Core,
    core_prime: Core,
    /// The fused outputs, from the fused features (all, or roughness's first half).
    output_stem: OutputStem,
    /// Roughness only: the illumination track on the per-view half.
    illumination_stem: Option<OutputStem>,
    #[module(skip)]
    config: NetConfig,
}

impl ParamNet {
    /// A network with fresh random weights (burn's convolution default).
    pub fn new(config: NetConfig, device: &Device) -> Self {
        let (w, t, c) = (config.width, config.track, config.in_channels());
        let s = config.fused_width();
        let illumination_stem = config
            .kind
            .splits_features()
            .then(|| OutputStem::new(w - s, config.per_view_out_channels(), t, device));
        ParamNet {
            input_stem: InputStem::new(c, w, t, device),
            core: Core::new(w, c, t, device),
            core_prime: Core::new(w, 0, t, device),
            output_stem: OutputStem::new(s, config.fused_out_channels(), t, device),
            illumination_stem,
            config,
        }
    }

    /// Its configuration.
    pub fn config(&self) -> NetConfig {
        self.config
    }

    /// The device holding the weights.
    pub fn device(&self) -> Device {
        self.input_stem.unit.convs()[0].1.weight.val().device()
    }

    /// Runs the network on `views`, each `[1, inputs, height, width]` with the
    /// channels of [`Param::inputs`]; all views share one size.
    pub fn forward(&self, views: &[Tensor<4>]) -> Result<NetOutput, InputError> {
        let plan = self.check(views)?;
        let Some(tree) = FusionTree::balanced(views.len()) else {
            return Err(InputError::NoViews {
                kind: self.config.kind,
            });
        };
        // levels[l][v]: level l (0 = full size) of view v.
        let mut levels: Vec<Vec<Tensor<4>>> =
            vec![Vec::with_capacity(views.len()); plan.halvings() + 1];
        for view in views {
            for (level, image) in plan.build(sanitize(view.clone())).into_iter().enumerate() {
                levels[level].push(image);
            }
        }
        let Some(coarsest) = levels.pop() else {
            unreachable!("a pyramid has at least one level")
        };
        let fused_width = self.config.fused_width();
        let width = self.config.width;
        // The per-view feature half (roughness); None otherwise.
        let mut own: Vec<Option<Tensor<4>>> = vec![None; views.len()];
        let keep_own = |view: usize, features: Tensor<4>, own: &mut Vec<Option<Tensor<4>>>| {
            if fused_width < width {
                own[view] = Some(features.clone().narrow(1, fused_width, width - fused_width));
                features.narrow(1, 0, fused_width)
            } else {
                features
            }
        };
        // Leaves cannot fail: the views were checked above.
        let Ok(mut fused) = tree.fuse::<Infallible>(&mut |view| {
            let features = self.input_stem.forward(coarsest[view].clone());
            Ok(keep_own(view, features, &mut own))
        });
        drop(coarsest);
        while let Some(inputs) = levels.pop() {
            let up = upsample_nearest(fused);
            let shared = self.core.reduce_shared(up.clone());
            let Ok(refined) = tree.fuse::<Infallible>(&mut |view| {
                let features = match own[view].take() {
                    Some(mine) => Tensor::cat(vec![up.clone(), upsample_nearest(mine)], 1),
                    None => up.clone(),
                };
                let refined =
                    self.core
                        .forward_with_shared(features, &shared, Some(inputs[view].clone()));
                let refined = self.core_prime.forward(refined, None);
                Ok(keep_own(view, refined, &mut own))
            });
            fused = refined;
        }
        let per_view = match &self.illumination_stem {
            Some(stem) => own
                .into_iter()
                .flatten()
                .map(|mine| plan.crop(stem.forward(mine)))
                .collect(),
            None => Vec::new(),
        };
        Ok(NetOutput {
            fused: plan.crop(self.output_stem.forward(fused)),
            per_view,
        })
    }

    fn check(&self, views: &[Tensor<4>]) -> Result<PyramidPlan, InputError> {
        let kind = self.config.kind;
        let channels = self.config.in_channels();
        let Some(first) = views.first() else {
            return Err(InputError::NoViews { kind });
        };
        let [_, _, height, width] = first.dims();
        let device = self.device();
        for (view, tensor) in views.iter().enumerate() {
            let found = tensor.dims();
            if found[0] != 1 || found[1] != channels {
                return Err(InputError::Shape {
                    kind,
                    view,
                    found,
                    channels,
                });
            }
            if [found[2], found[3]] != [height, width] {
                return Err(InputError::SizeMismatch {
                    view,
                    found: [found[2], found[3]],
                    first: [height, width],
                });
            }
            if tensor.device() != device {
                return Err(InputError::Device {
                    kind,
                    view,
                    found: format!("{:?}", tensor.device()),
                    expected: format!("{device:?}"),
                });
            }
        }
        Ok(PyramidPlan::new(height, width)?)
    }

    /// Every convolution with a stable dotted name, in file order.
    pub(crate) fn named_convs(&self) -> Vec<(String, &Conv)> {
        self.blocks()
            .into_iter()
            .flat_map(|(block, unit)| {
                unit.convs()
                    .into_iter()
                    .map(move |(name, conv)| (format!("{block}.{name}"), conv))
            })
            .collect()
    }

    /// Every convolution, mutable, in the order of [`named_convs`](Self::named_convs).
    pub(crate) fn convs_mut(&mut self) -> Vec<&mut Conv> {
        let mut units = vec![
            &mut self.input_stem.unit,
            &mut self.core.unit,
            &mut self.core_prime.unit,
            &mut self.output_stem.unit,
        ];
        if let Some(stem) = &mut self.illumination_stem {
            units.push(&mut stem.unit);
        }
        units
            .into_iter()
            .flat_map(|unit| unit.convs_mut())
            .collect()
    }

    fn blocks(&self) -> Vec<(&'static str, &crate::net::blocks::InceptionUnit)> {
        let mut blocks = vec![
            ("input_stem", &self.input_stem.unit),
            ("core", &self.core.unit),
            ("core_prime", &self.core_prime.unit),
            ("output_stem", &self.output_stem.unit),
        ];
        if let Some(stem) = &self.illumination_stem {
            blocks.push(("illumination_stem", &stem.unit));
        }
        blocks
    }
}

/// NaN to 0, then clamped to +-[`INPUT_LIMIT`] (infinities included).
fn sanitize(view: Tensor<4>) -> Tensor<4> {
    let nan = view.clone().is_nan();
    view.mask_fill(nan, 0.0).clamp(-INPUT_LIMIT, INPUT_LIMIT)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_are_checked() {
        assert_eq!(
            NetConfig::new(Param::Roughness, 7),
            Err(ConfigError::OddSplit {
                kind: Param::Roughness,
                width: 7
            })
        );
        assert!(NetConfig::new(Param::Metallic, 7).is_ok());
        assert_eq!(
            NetConfig::new(Param::Metallic, 0),
            Err(ConfigError::OutOfRange {
                what: "width",
                value: 0
            })
        );
        assert_eq!(
            NetConfig::with_track(Param::Metallic, 8, MAX_WIDTH + 1),
            Err(ConfigError::OutOfRange {
                what: "track",
                value: MAX_WIDTH + 1
            })
        );
        let config = NetConfig::new(Param::Basecolor, 128).expect("valid");
        assert_eq!(config, NetConfig::thesis(Param::Basecolor));
        assert_eq!(
            (
                config.track(),
                config.in_channels(),
                config.fused_out_channels()
            ),
            (32, 21, 3)
        );
    }

    #[test]
    fn shipped_configurations_are_valid() {
        for kind in crate::net::spec::PIPELINE_ORDER {
            let shipped = NetConfig::shipped(kind);
            let checked = NetConfig::with_track(kind, shipped.width(), shipped.track());
            assert_eq!(checked, Ok(shipped), "{kind}");
        }
    }

    #[test]
    fn roughness_fuses_half_its_features() {
        let config = NetConfig::new(Param::Roughness, 16).expect("valid");
        assert_eq!(
            (config.fused_width(), config.per_view_out_channels()),
            (8, 1)
        );
        let config = NetConfig::new(Param::Subsurface, 16).expect("valid");
        assert_eq!(
            (config.fused_width(), config.per_view_out_channels()),
            (16, 0)
        );
    }

    #[test]
    fn the_operation_count_follows_the_blocks() {
        // 16x16 runs the stems only. Width 4, track 1, transmission (5 in, 1 out):
        // input stem 3*5 + 18 + 3*4 = 45 and output stem 3*4 + 18 + 3*1 = 33
        // multiply-adds per pixel.
        let config = NetConfig::with_track(Param::Transmission, 4, 1).expect("valid");
        let flops = config.forward_flops(16, 16, 1).expect("non-empty");
        assert_eq!(flops, 2.0 * 256.0 * (45.0 + 33.0));
        // Views multiply the per-view work; the output stem runs once.
        let nine = config.forward_flops(16, 16, 9).expect("non-empty");
        assert_eq!(nine, 2.0 * 256.0 * (9.0 * 45.0 + 33.0));
    }
}
