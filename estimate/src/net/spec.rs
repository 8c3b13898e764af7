//! What each of the five parameter networks reads and writes (thesis
//! sections 3.2.3.1 to 3.2.3.5), as named channels in their fixed order.
//!
//! This module only names and orders channels; assembling the images (mask
//! mapping, square-root differences, angle cosines, YCbCr conversion,
//! zero-centring) is the pipeline's job. Every input channel is expected in
//! the thesis's training range, [-1, 1] ("zero-centering in [-1..1]").
//!
//! Choices where the thesis text leaves room:
//! - "Grayscale" images are the luma (Y) of the colour image, so the gray
//!   networks and the YCbCr networks share `AmbientY`.
//! - The "square root of the clipped difference" is `LitSqrtDiffLuma`
//!   (sqrt(max(Y(lit) - Y(ambient), 0))) in the gray networks and the YCbCr of
//!   the per-RGB sqrt(max(lit - ambient, 0)) in the colour networks.
//! - Metallic: "the first nine channels are the same as in transmission ...
//!   encoded in four more channels" is transmission's five with the ambient
//!   and the lit difference in YCbCr; the tenth, "additionally ... a
//!   difference image ... [with] the square-root", is `LitSqrtDiffLuma`.
//! - Metallic has two outputs, the map and its inverse (section 3.2.3.4).
//!   The thesis recommends training with equation 3.12 (the map's loss only)
//!   over 3.13; the pipeline reads [`OutputChannel::Metallic`] either way.

/// The networks are named by the one parameter type, [`Param`]; each
/// network's channel tables are [`NetworkSpec`]'s methods on it.
pub use matscan_scan::Param;

/// One input channel of a network.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum InputChannel {
    /// The object mask seen from this view ("mapped-mask"); 0 in holes.
    MappedMask,
    /// Luma of the ambient-only photo (the gray ambient image).
    AmbientY,
    /// Blue-difference chroma of the ambient-only photo.
    AmbientCb,
    /// Red-difference chroma of the ambient-only photo.
    AmbientCr,
    /// sqrt(max(Y(ambient + light) - Y(ambient), 0)) for this view's light.
    LitSqrtDiffLuma,
    /// Luma of the per-RGB sqrt(max(ambient + light - ambient, 0)).
    LitSqrtDiffY,
    /// Blue-difference chroma of the per-RGB square-root difference.
    LitSqrtDiffCb,
    /// Red-difference chroma of the per-RGB square-root difference.
    LitSqrtDiffCr,
    /// sqrt(max(Y(ambient + backlight) - Y(ambient), 0)).
    BacklightSqrtDiffLuma,
    /// Luma of the photo with the projector showing a checkerboard.
    CheckerLuma,
    /// Cosine of the normal-to-light angle.
    CosNormalLight,
    /// Cosine of the normal-to-view angle.
    CosNormalView,
    /// Cosine of the view-to-light angle.
    CosViewLight,
    /// Constant layer: mean luma of the white diffuse reference, ambient only.
    WhiteAmbientLuma,
    /// Constant layer: the reference's mean luma with the light minus without.
    WhiteLitDiffLuma,
    /// Constant layer: the white reference under ambient light, Y.
    WhiteAmbientY,
    /// Constant layer: the white reference under ambient light, Cb.
    WhiteAmbientCb,
    /// Constant layer: the white reference under ambient light, Cr.
    WhiteAmbientCr,
    /// Constant layer: the white reference under ambient plus the light, Y.
    WhiteLitY,
    /// Constant layer: the white reference under ambient plus the light, Cb.
    WhiteLitCb,
    /// Constant layer: the white reference under ambient plus the light, Cr.
    WhiteLitCr,
    /// The depth map (far is bright).
    Depth,
    /// The metallic map (estimated, or ground truth in training).
    Metallic,
    /// The rendered transmission T_final = T (1 - M) (equation 3.5).
    TransmissionFinal,
    /// The rendered subsurface S_out = S (1 - M) (1 - T) (equation 3.6).
    SubsurfaceFinal,
    /// The roughness map.
    Roughness,
    /// The local illumination map (the roughness network's second output).
    Illumination,
    /// The inverted illumination map.
    IlluminationInverted,
}

/// One output channel of a network.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OutputChannel {
    /// Roughness, fused over the views.
    Roughness,
    /// The render of a white diffuse object: local illumination, per view.
    Illumination,
    /// Transmission.
    Transmission,
    /// Subsurface.
    Subsurface,
    /// Metallic.
    Metallic,
    /// The inverse of metallic, learnt alongside it (equation 3.13).
    MetallicInverse,
    /// Mixed subsurface basecolor, luma.
    BasecolorY,
    /// Mixed subsurface basecolor, blue-difference chroma.
    BasecolorCb,
    /// Mixed subsurface basecolor, red-difference chroma.
    BasecolorCr,
}

use InputChannel as I;

const ROUGHNESS_INPUTS: [InputChannel; 12] = [
    I::MappedMask,
    I::AmbientY,
    I::LitSqrtDiffLuma,
    I::CosNormalLight,
    I::CosNormalView,
    I::CosViewLight,
    I::WhiteAmbientLuma,
    I::WhiteLitDiffLuma,
    I::Depth,
    I::Metallic,
    I::TransmissionFinal,
    I::SubsurfaceFinal,
];

const TRANSMISSION_INPUTS: [InputChannel; 5] = [
    I::MappedMask,
    I::AmbientY,
    I::LitSqrtDiffLuma,
    I::BacklightSqrtDiffLuma,
    I::CosNormalView,
];

const SUBSURFACE_INPUTS: [InputChannel; 7] = [
    I::MappedMask,
    I::AmbientY,
    I::LitSqrtDiffLuma,
    I::BacklightSqrtDiffLuma,
    I::CosNormalView,
    I::TransmissionFinal,
    I::CheckerLuma,
];

const METALLIC_INPUTS: [InputChannel; 10] = [
    I::MappedMask,
    I::AmbientY,
    I::AmbientCb,
    I::AmbientCr,
    I::LitSqrtDiffY,
    I::LitSqrtDiffCb,
    I::LitSqrtDiffCr,
    I::BacklightSqrtDiffLuma,
    I::CosNormalView,
    I::LitSqrtDiffLuma,
];

const BASECOLOR_INPUTS: [InputChannel; 21] = [
    I::MappedMask,
    I::AmbientY,
    I::AmbientCb,
    I::AmbientCr,
    I::LitSqrtDiffY,
    I::LitSqrtDiffCb,
    I::LitSqrtDiffCr,
    I::CosNormalLight,
    I::CosNormalView,
    I::CosViewLight,
    I::WhiteAmbientY,
    I::WhiteAmbientCb,
    I::WhiteAmbientCr,
    I::WhiteLitY,
    I::WhiteLitCb,
    I::WhiteLitCr,
    I::Metallic,
    I::TransmissionFinal,
    I::Roughness,
    I::Illumination,
    I::IlluminationInverted,
];

/// The five networks in the order the pipeline runs them (figure 3.14:
/// metallic, transmission and subsurface feed roughness, which feeds
/// basecolor). [`Param::ALL`] is the order of files and tables; this is
/// the order of inference.
pub const PIPELINE_ORDER: [Param; 5] = [
    Param::Metallic,
    Param::Transmission,
    Param::Subsurface,
    Param::Roughness,
    Param::Basecolor,
];

/// What the network of a parameter reads and writes.
pub trait NetworkSpec: Copy {
    /// The network's input channels, in order (section 3.2.3).
    fn inputs(self) -> &'static [InputChannel];
    /// Outputs fused over views.
    fn fused_outputs(self) -> &'static [OutputChannel];
    /// Outputs produced per view, not fused.
    fn per_view_outputs(self) -> &'static [OutputChannel];
    /// Whether the output stem splits features into fused and per-view.
    fn splits_features(self) -> bool;
}

impl NetworkSpec for Param {
    fn inputs(self) -> &'static [InputChannel] {
        match self {
            Param::Roughness => &ROUGHNESS_INPUTS,
            Param::Transmission => &TRANSMISSION_INPUTS,
            Param::Subsurface => &SUBSURFACE_INPUTS,
            Param::Metallic => &METALLIC_INPUTS,
            Param::Basecolor => &BASECOLOR_INPUTS,
        }
    }
    fn fused_outputs(self) -> &'static [OutputChannel] {
        match self {
            Param::Roughness => &[OutputChannel::Roughness],
            Param::Transmission => &[OutputChannel::Transmission],
            Param::Subsurface => &[OutputChannel::Subsurface],
            Param::Metallic => &[OutputChannel::Metallic, OutputChannel::MetallicInverse],
            Param::Basecolor => &[
                OutputChannel::BasecolorY,
                OutputChannel::BasecolorCb,
                OutputChannel::BasecolorCr,
            ],
        }
    }
    fn per_view_outputs(self) -> &'static [OutputChannel] {
        match self {
            Param::Roughness => &[OutputChannel::Illumination],
            _ => &[],
        }
    }
    fn splits_features(self) -> bool {
        !self.per_view_outputs().is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn input_counts_match_the_thesis() {
        let counts: Vec<(Param, usize)> = PIPELINE_ORDER
            .iter()
            .map(|kind| (*kind, kind.inputs().len()))
            .collect();
        assert_eq!(
            counts,
            vec![
                (Param::Metallic, 10),
                (Param::Transmission, 5),
                (Param::Subsurface, 7),
                (Param::Roughness, 12),
                (Param::Basecolor, 21),
            ]
        );
    }

    #[test]
    fn every_network_starts_with_the_mask_and_the_ambient_image() {
        for kind in PIPELINE_ORDER {
            assert_eq!(&kind.inputs()[..2], &[I::MappedMask, I::AmbientY], "{kind}");
        }
    }

    #[test]
    fn no_network_lists_a_channel_twice() {
        for kind in PIPELINE_ORDER {
            let unique: HashSet<_> = kind.inputs().iter().collect();
            assert_eq!(unique.len(), kind.inputs().len(), "{kind}");
        }
    }

    #[test]
    fn output_counts_match_the_thesis() {
        let fused: Vec<usize> = PIPELINE_ORDER
            .iter()
            .map(|k| k.fused_outputs().len())
            .collect();
        assert_eq!(fused, vec![2, 1, 1, 1, 3]);
        assert_eq!(
            Param::Roughness.per_view_outputs(),
            &[OutputChannel::Illumination]
        );
        let splitting: Vec<Param> = PIPELINE_ORDER
            .into_iter()
            .filter(|k| k.splits_features())
            .collect();
        assert_eq!(splitting, vec![Param::Roughness]);
    }

    #[test]
    fn names_round_trip() {
        for kind in PIPELINE_ORDER {
            assert_eq!(kind.name().parse::<Param>().ok(), Some(kind));
        }
        assert_eq!("sheen".parse::<Param>().ok(), None);
    }
}
