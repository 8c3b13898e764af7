//! The five Principled BSDF parameters matscan estimates.

use std::fmt;
use std::str::FromStr;

/// A parameter of the Principled BSDF that matscan estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Param {
    Basecolor,
    Roughness,
    Metallic,
    Transmission,
    Subsurface,
}

impl Param {
    pub const ALL: [Param; 5] = [
        Param::Basecolor,
        Param::Roughness,
        Param::Metallic,
        Param::Transmission,
        Param::Subsurface,
    ];

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Param::Basecolor => "basecolor",
            Param::Roughness => "roughness",
            Param::Metallic => "metallic",
            Param::Transmission => "transmission",
            Param::Subsurface => "subsurface",
        }
    }

    /// The value the parameter takes where nothing measured or gave it:
    /// no metal, no transmission, no subsurface, medium roughness, mid
    /// grey (every channel of basecolor). A skipped parameter feeds this to
    /// the networks that read it, and a texture set without it renders so.
    pub fn default_value(self) -> f32 {
        match self {
            Param::Metallic | Param::Transmission | Param::Subsurface => 0.0,
            Param::Roughness | Param::Basecolor => 0.5,
        }
    }

    /// Number of channels of the parameter's map (3 for basecolor, else 1).
    pub fn channels(self) -> usize {
        match self {
            Param::Basecolor => 3,
            _ => 1,
        }
    }
}

impl fmt::Display for Param {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown parameter `{0}`: expected one of basecolor, roughness, metallic, transmission, subsurface")]
pub struct UnknownParam(pub String);

impl FromStr for Param {
    type Err = UnknownParam;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Param::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| UnknownParam(s.to_string()))
    }
}
