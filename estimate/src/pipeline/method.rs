//! Which estimator answers basecolor, roughness and metallic.
//!
//! Transmission and subsurface come from their networks, except where
//! under every fitting method the backlit and checker photos measure them
//! ([`crate::fit::backlight`]): 0 on a dielectric that passes no light, 0
//! subsurface where no light scatters inside, and the transmission of a
//! material that passes light straight through.

use matscan_scan::Param;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The estimator of basecolor, roughness and metallic.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The thesis's networks alone.
    Networks,
    /// The physical fit ([`crate::fit`]) alone: where the photos pin
    /// nothing, its own flat best guess.
    Fit,
    /// The physical fit, with the networks' answer where the photos pin
    /// nothing (no highlight in a material, no usable view of a pixel).
    Hybrid,
    /// Metallic as [`Method::Hybrid`] answers it (the fit's decision per
    /// material, the metallic network's where the photos pin nothing); the
    /// roughness and basecolor networks then run fed that metallic, as the
    /// thesis's chain feeds them the metallic network's. Subsurface stays
    /// fed the metallic network's answer, which measured better for it.
    #[serde(rename = "fit-metallic")]
    FitMetallic,
    /// [`Method::FitMetallic`], and then roughness as [`Method::Hybrid`]
    /// answers it: the specular lobe's parameters, metallic and roughness,
    /// are the fit's where the photos pin them. Basecolor is the
    /// `fit-metallic` chain's (its network fed the roughness network's
    /// answer): on `tune`, fed the fit's roughness instead, it measured
    /// worse (docs/results.md).
    ///
    #[serde(rename = "fit-specular")]
    FitSpecular,
    /// [`Method::FitSpecular`], and then basecolor too on the materials the
    /// fit reads as opaque dielectrics (dielectric, and no light scattered
    /// inside): such a material's basecolor is its diffuse albedo, which
    /// every lit view measures whatever the lobe. A metal's is its
    /// specular colour, which only its highlights show: a pinned metal
    /// whose pooled highlights measure it ([`crate::fit::highlight`]) takes
    /// that colour as its mean. A material that scatters light inside
    /// reflects it through a medium the surface model does not have: there
    /// the basecolor network's mean stands. Within every material whose
    /// metallic the photos pinned and whose basecolor is not the fit's own,
    /// the texture is the share of the fit's and the network's readings
    /// they agree on.
    ///
    /// The default: on the `tune` set, with the fit's light chosen per
    /// material, it lowers basecolor's MAD against `fit-specular` from
    /// 0.152 to 0.134 (realworld 0.134 to 0.058) with the same roughness
    /// and metallic (docs/results.md).
    #[default]
    #[serde(rename = "fit-dielectric")]
    FitDielectric,
}

impl Method {
    pub const ALL: [Method; 6] = [
        Method::Networks,
        Method::Fit,
        Method::Hybrid,
        Method::FitMetallic,
        Method::FitSpecular,
        Method::FitDielectric,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Method::Networks => "networks",
            Method::Fit => "fit",
            Method::Hybrid => "hybrid",
            Method::FitMetallic => "fit-metallic",
            Method::FitSpecular => "fit-specular",
            Method::FitDielectric => "fit-dielectric",
        }
    }

    /// Whether the physical fit runs.
    pub fn fits(self) -> bool {
        self != Method::Networks
    }

    /// Whether the networks answer where the photos pin nothing (every
    /// fitting method but `fit`, which keeps its own flat best guess).
    pub fn falls_back(self) -> bool {
        !matches!(self, Method::Networks | Method::Fit)
    }

    /// The networks that run before the fit (it reads their answers) and
    /// after it (they read the fit's), each in pipeline order; only those
    /// the plan runs do. Under `fit` only what the fit does not measure
    /// runs: transmission, which it renders under, before; subsurface,
    /// which reads metallic, after. Under `fit-metallic` subsurface stays
    /// fed the metallic network (on `tune` its MAD fed that is 0.154, fed
    /// the fit's 0.179), and roughness is fed the fit's metallic with
    /// basecolor (fed the metallic network's instead, it loses more on
    /// basecolor, whose network reads it, than it wins: docs/results.md).
    pub fn networks_around_fit(self) -> (&'static [Param], &'static [Param]) {
        const EVERY: &[Param] = &crate::net::spec::PIPELINE_ORDER;
        match self {
            Method::Networks | Method::Hybrid => (EVERY, &[]),
            Method::Fit => (&[Param::Transmission], &[Param::Subsurface]),
            Method::FitMetallic => (
                &[Param::Metallic, Param::Transmission, Param::Subsurface],
                &[Param::Roughness, Param::Basecolor],
            ),
            Method::FitSpecular | Method::FitDielectric => (
                &[Param::Metallic, Param::Transmission, Param::Subsurface],
                &[Param::Roughness, Param::Basecolor],
            ),
        }
    }

    /// Whether the fit's roughness, where the photos pin it, replaces the
    /// networks' after the networks that follow the fit have run.
    pub fn fit_roughness_last(self) -> bool {
        matches!(self, Method::FitSpecular | Method::FitDielectric)
    }

    /// Whether the fit's basecolor (on the materials it reads as opaque
    /// dielectrics, and the metals' highlight colours and the agreed
    /// textures) replaces the networks' after they have run.
    pub fn fit_basecolor_last(self) -> bool {
        self == Method::FitDielectric
    }

    /// Who answers `kind` under this method, as `result.toml` names it:
    /// the method itself where the fit's answer stands, else the networks.
    pub fn answering(self, kind: Param) -> Method {
        match (self, kind) {
            // Every fitting method reads the backlight and the checker:
            // transmission and subsurface where they measure them, the
            // networks' elsewhere.
            (Method::Networks | Method::Hybrid, Param::Transmission | Param::Subsurface) => {
                Method::Networks
            }
            (_, Param::Transmission | Param::Subsurface) => Method::Hybrid,
            (Method::FitMetallic, Param::Metallic) => Method::Hybrid,
            (Method::FitMetallic, _) => Method::Networks,
            (Method::FitSpecular, Param::Metallic | Param::Roughness) => Method::Hybrid,
            (Method::FitSpecular, _) => Method::Networks,
            // Every other parameter of fit-dielectric is basecolor,
            // roughness or metallic: the fit's where it pins them.
            (Method::FitDielectric, _) => Method::Hybrid,
            (m, _) => m,
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A method name that is not one.
#[derive(Debug, thiserror::Error)]
#[error(
    "unknown method {0:?}: expected networks, fit, hybrid, fit-metallic, fit-specular or \
     fit-dielectric"
)]
pub struct UnknownMethod(pub String);

impl FromStr for Method {
    type Err = UnknownMethod;

    fn from_str(s: &str) -> Result<Method, UnknownMethod> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| UnknownMethod(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_network_runs_once_and_only_fit_leaves_metallic_roughness_and_basecolor_out() {
        for m in Method::ALL {
            let (before, after) = m.networks_around_fit();
            let mut ran: Vec<Param> = before.iter().chain(after).copied().collect();
            let count = ran.len();
            ran.sort();
            ran.dedup();
            assert_eq!(ran.len(), count, "{m}: a network twice");
            let expected = if m == Method::Fit { 2 } else { 5 };
            assert_eq!(count, expected, "{m}");
        }
        assert_eq!(
            Method::FitMetallic.answering(Param::Metallic),
            Method::Hybrid
        );
        assert_eq!(
            Method::FitMetallic.answering(Param::Roughness),
            Method::Networks
        );
        assert_eq!(Method::Fit.answering(Param::Basecolor), Method::Fit);
        assert_eq!(
            Method::FitSpecular.answering(Param::Roughness),
            Method::Hybrid
        );
        assert_eq!(
            Method::FitSpecular.answering(Param::Basecolor),
            Method::Networks
        );
        assert_eq!(
            Method::Hybrid.answering(Param::Subsurface),
            Method::Networks
        );
        assert_eq!(
            Method::FitDielectric.answering(Param::Basecolor),
            Method::Hybrid
        );
        for m in [
            Method::Fit,
            Method::FitMetallic,
            Method::FitSpecular,
            Method::FitDielectric,
        ] {
            for kind in [Param::Transmission, Param::Subsurface] {
                assert_eq!(m.answering(kind), Method::Hybrid, "{m}: {kind}");
            }
        }
        assert_eq!(
            Method::Networks.answering(Param::Transmission),
            Method::Networks
        );
        assert!(Method::FitDielectric.fit_roughness_last());
        assert!(!Method::FitSpecular.fit_basecolor_last());
        assert_eq!(Method::default(), Method::FitDielectric);
    }

    #[test]
    fn names_round_trip_and_a_wrong_one_says_what_was_expected() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>().ok(), Some(m));
        }
        let e = "physics".parse::<Method>().err().map(|e| e.to_string());
        assert_eq!(
            e.as_deref(),
            Some(
                "unknown method \"physics\": expected networks, fit, hybrid, fit-metallic, \
                 fit-specular or fit-dielectric"
            )
        );
    }
}
