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

use std::fmt;

/// One of the five networks, named for the BSDF parameter it infers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ParamKind {
    /// Roughness plus the per-view local illumination (section 3.2.3.1).
    Roughness,
    /// Transmission (section 3.2.3.2).
    Transmission,
    /// Subsurface (section 3.2.3.3).
    Subsurface,
    /// Metallic and its inverse (section 3.2.3.4).
    Metallic,
    /// The mixed subsurface basecolor in YCbCr (section 3.2.3.5).
    Basecolor,
}

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

impl ParamKind {
    /// All five, in the order the pipeline runs them (figure 3.14: metallic,
    /// transmission and subsurface feed roughness, which feeds basecolor).
    pub const ALL: [ParamKind; 5] = [
        ParamKind::Metallic,
        ParamKind::Transmission,
        ParamKind::Subsurface,
        ParamKind::Roughness,
        ParamKind::Basecolor,
    ];

    /// Lower-case name, as used in weight files and messages.
    pub fn name(self) -> &'static str {
        match self {
            ParamKind::Roughness => "roughness",
            ParamKind::Transmission => "transmission",
            ParamKind::Subsurface => "subsurface",
            ParamKind::Metallic => "metallic",
            ParamKind::Basecolor => "basecolor",
        }
    }

    /// The kind with this [`name`](Self::name), if any.
    pub fn from_name(name: &str) -> Option<ParamKind> {
        Self::ALL.into_iter().find(|kind| kind.name() == name)
    }

    /// The input channels, in the order the network's input tensor stacks them.
    pub fn inputs(self) -> &'static [InputChannel] {
        match self {
            ParamKind::Roughness => &ROUGHNESS_INPUTS,
            ParamKind::Transmission => &TRANSMISSION_INPUTS,
            ParamKind::Subsurface => &SUBSURFACE_INPUTS,
            ParamKind::Metallic => &METALLIC_INPUTS,
            ParamKind::Basecolor => &BASECOLOR_INPUTS,
        }
    }

    /// The outputs that are the same for every view (fused), in order.
    pub fn fused_outputs(self) -> &'static [OutputChannel] {
        match self {
            ParamKind::Roughness => &[OutputChannel::Roughness],
            ParamKind::Transmission => &[OutputChannel::Transmission],
            ParamKind::Subsurface => &[OutputChannel::Subsurface],
            ParamKind::Metallic => &[OutputChannel::Metallic, OutputChannel::MetallicInverse],
            ParamKind::Basecolor => &[
                OutputChannel::BasecolorY,
                OutputChannel::BasecolorCb,
                OutputChannel::BasecolorCr,
            ],
        }
    }

    /// The outputs computed separately for every view (only roughness's
    /// illumination, section 3.2.3.1).
    pub fn per_view_outputs(self) -> &'static [OutputChannel] {
        match self {
            ParamKind::Roughness => &[OutputChannel::Illumination],
            _ => &[],
        }
    }

    /// Whether the features are split into a fused half and a per-view half
    /// (roughness only: its illumination depends on the view).
    pub fn splits_features(self) -> bool {
        !self.per_view_outputs().is_empty()
    }
}

impl fmt::Display for ParamKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn input_counts_match_the_thesis() {
        let counts: Vec<(ParamKind, usize)> = ParamKind::ALL
            .iter()
            .map(|kind| (*kind, kind.inputs().len()))
            .collect();
        assert_eq!(
            counts,
            vec![
                (ParamKind::Metallic, 10),
                (ParamKind::Transmission, 5),
                (ParamKind::Subsurface, 7),
                (ParamKind::Roughness, 12),
                (ParamKind::Basecolor, 21),
            ]
        );
    }

    #[test]
    fn every_network_starts_with_the_mask_and_the_ambient_image() {
        for kind in ParamKind::ALL {
            assert_eq!(&kind.inputs()[..2], &[I::MappedMask, I::AmbientY], "{kind}");
        }
    }

    #[test]
    fn no_network_lists_a_channel_twice() {
        for kind in ParamKind::ALL {
            let unique: HashSet<_> = kind.inputs().iter().collect();
            assert_eq!(unique.len(), kind.inputs().len(), "{kind}");
        }
    }

    #[test]
    fn output_counts_match_the_thesis() {
        let fused: Vec<usize> = ParamKind::ALL
            .iter()
            .map(|k| k.fused_outputs().len())
            .collect();
        assert_eq!(fused, vec![2, 1, 1, 1, 3]);
        assert_eq!(
            ParamKind::Roughness.per_view_outputs(),
            &[OutputChannel::Illumination]
        );
        let splitting: Vec<ParamKind> = ParamKind::ALL
            .into_iter()
            .filter(|k| k.splits_features())
            .collect();
        assert_eq!(splitting, vec![ParamKind::Roughness]);
    }

    #[test]
    fn names_round_trip() {
        for kind in ParamKind::ALL {
            assert_eq!(ParamKind::from_name(kind.name()), Some(kind));
        }
        assert_eq!(ParamKind::from_name("sheen"), None);
    }
}
