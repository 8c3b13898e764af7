//! The truth fed to the estimator one piece at a time: the error budget
//! (`matscan eval --oracle`) measures how much of each parameter's error
//! each piece costs by handing the estimator that piece from a simulated
//! scan's truth maps and watching the other parameters' error fall.
//!
//! Pieces ([`Oracle`]):
//!
//! - a parameter (roughness, metallic, transmission, subsurface): its truth
//!   map in the reference camera's image, given as a user would give a map
//!   (`--given PARAM=FILE`), so the plan skips its network and every stage
//!   after it (the networks it feeds, the physical fit's `Known`) reads the
//!   truth;
//! - the segmentation: the physical fit's materials are the truth's regions
//!   instead of its own split of the pixels' colours (see
//!   [`truth_labels`]).
//!
//! Basecolor is no piece: nothing downstream reads it (its network runs
//! last and the fit solves it in closed form under everything else). The
//! light's scale and the direct/global split are no pieces either: a
//! simulated scan's manifest carries the renderer's own intensities, so its
//! calibrated light is already the truth, and its truth maps hold no
//! direct-only photo to split against.
//!
//! Boundaries: reads truth maps, nothing else; an estimate a user gets
//! never has an oracle.

use super::plan::Given;
use matscan_scan::estimate_maps::MapValues;
use matscan_scan::{Bundle, Param, ScanError, TruthMap};
use std::collections::{BTreeSet, HashMap};
use std::fmt;
use std::str::FromStr;

/// One piece of truth the estimator can be fed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Oracle {
    /// The physical fit's materials are the truth's regions.
    Segmentation,
    Roughness,
    Metallic,
    Transmission,
    Subsurface,
}

impl Oracle {
    pub const ALL: [Oracle; 5] = [
        Oracle::Segmentation,
        Oracle::Roughness,
        Oracle::Metallic,
        Oracle::Transmission,
        Oracle::Subsurface,
    ];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Oracle::Segmentation => "segmentation",
            Oracle::Roughness => "roughness",
            Oracle::Metallic => "metallic",
            Oracle::Transmission => "transmission",
            Oracle::Subsurface => "subsurface",
        }
    }

    /// The parameter this piece gives, if it is one.
    pub fn param(self) -> Option<Param> {
        match self {
            Oracle::Segmentation => None,
            Oracle::Roughness => Some(Param::Roughness),
            Oracle::Metallic => Some(Param::Metallic),
            Oracle::Transmission => Some(Param::Transmission),
            Oracle::Subsurface => Some(Param::Subsurface),
        }
    }
}

impl fmt::Display for Oracle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The pieces of truth one estimate is fed; empty for every estimate a
/// user gets.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Oracles(BTreeSet<Oracle>);

impl Oracles {
    pub fn new(pieces: impl IntoIterator<Item = Oracle>) -> Oracles {
        Oracles(pieces.into_iter().collect())
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn contains(&self, piece: Oracle) -> bool {
        self.0.contains(&piece)
    }

    pub fn iter(&self) -> impl Iterator<Item = Oracle> + '_ {
        self.0.iter().copied()
    }

    /// The truth maps of the parameters among the pieces, as given maps in
    /// the image of `reference`.
    pub fn given(
        &self,
        bundle: &Bundle,
        reference: &str,
    ) -> Result<Vec<(Param, Given)>, OracleError> {
        self.iter()
            .filter_map(Oracle::param)
            .map(|param| {
                let map = TruthMap::Param(param);
                let path = bundle.root.join(map.relative_path(reference));
                if path.is_file() {
                    Ok((param, Given::Map(path)))
                } else {
                    Err(OracleError::no_truth(bundle, &map, reference))
                }
            })
            .collect()
    }

    /// The truth's material labels in the image of `reference` when the
    /// segmentation is among the pieces (see [`truth_labels`]).
    pub fn labels(
        &self,
        bundle: &Bundle,
        reference: &str,
    ) -> Result<Option<Vec<Option<usize>>>, OracleError> {
        if !self.contains(Oracle::Segmentation) {
            return Ok(None);
        }
        truth_labels(bundle, reference).map(Some)
    }
}

impl fmt::Display for Oracles {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            return f.write_str("none");
        }
        let names: Vec<&str> = self.iter().map(Oracle::name).collect();
        f.write_str(&names.join(","))
    }
}

impl FromStr for Oracles {
    type Err = OracleError;

    /// `none`, or pieces joined by commas (`roughness,metallic`).
    fn from_str(s: &str) -> Result<Oracles, OracleError> {
        if s.trim() == "none" {
            return Ok(Oracles::default());
        }
        let mut set = BTreeSet::new();
        for word in s.split(',').map(str::trim) {
            let piece = Oracle::ALL
                .into_iter()
                .find(|o| o.name() == word)
                .ok_or_else(|| OracleError::Unknown(word.to_string()))?;
            if !set.insert(piece) {
                return Err(OracleError::Twice(piece));
            }
        }
        Ok(Oracles(set))
    }
}

/// A piece of truth that cannot be fed.
#[derive(Debug, thiserror::Error)]
pub enum OracleError {
    #[error(
        "unknown oracle piece `{0}`: expected none, or a comma-separated list of \
         segmentation, roughness, metallic, transmission, subsurface"
    )]
    Unknown(String),
    #[error("oracle piece `{0}` appears twice")]
    Twice(Oracle),
    #[error("{scan} has no truth map {map}: an oracle needs a simulated scan")]
    NoTruth { scan: String, map: String },
    #[error(transparent)]
    Scan(#[from] ScanError),
}

impl OracleError {
    fn no_truth(bundle: &Bundle, map: &TruthMap, reference: &str) -> OracleError {
        OracleError::NoTruth {
            scan: bundle.root.display().to_string(),
            map: map.relative_path(reference).display().to_string(),
        }
    }
}

/// The step in which roughness, transmission and subsurface count as one
/// value for the truth's regions: finer than any difference the fit's
/// roughness grid resolves between materials, coarse enough that the
/// `realworld` kinds' per-texel roughness streaks stay in their material.
const REGION_STEP: f32 = 0.1;

/// The truth's materials in the image of `reference`: the truth mask's
/// pixels grouped by their truth metallic (metal or not) and their
/// roughness, transmission and subsurface in steps of [`REGION_STEP`]. A
/// region shares what the fit solves per material (roughness, metallic)
/// and the fixed inputs it solves under; basecolor is solved per pixel, so
/// it does not split a region. Kinds whose parameters vary per pixel
/// (`multimat`) get as many regions as their noise maps have steps.
pub fn truth_labels(bundle: &Bundle, reference: &str) -> Result<Vec<Option<usize>>, OracleError> {
    let scalar = |param: Param| -> Result<Vec<f32>, OracleError> {
        match bundle.truth_param(reference, param)? {
            Some(MapValues::Scalar(r)) => Ok(r.data),
            _ => Err(OracleError::no_truth(
                bundle,
                &TruthMap::Param(param),
                reference,
            )),
        }
    };
    let mask = bundle
        .truth_mask(reference)?
        .ok_or_else(|| OracleError::no_truth(bundle, &TruthMap::Mask, reference))?
        .data;
    let roughness = scalar(Param::Roughness)?;
    let metallic = scalar(Param::Metallic)?;
    let transmission = scalar(Param::Transmission)?;
    let subsurface = scalar(Param::Subsurface)?;
    let step = |v: f32| (v.clamp(0.0, 1.0) / REGION_STEP).round() as i32;
    let mut index: HashMap<[i32; 4], usize> = HashMap::new();
    Ok((0..mask.len())
        .map(|i| {
            if !mask[i] {
                return None;
            }
            let key = [
                i32::from(metallic[i] >= 0.5),
                step(roughness[i]),
                step(transmission[i]),
                step(subsurface[i]),
            ];
            let next = index.len();
            Some(*index.entry(key).or_insert(next))
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn oracle_sets_parse_as_comma_lists_or_none() {
        let set: Oracles = "metallic, roughness".parse().unwrap();
        assert_eq!(set, Oracles::new([Oracle::Roughness, Oracle::Metallic]));
        assert_eq!(set.to_string(), "roughness,metallic");
        assert!("none".parse::<Oracles>().unwrap().is_empty());
        assert!(matches!(
            "basecolor".parse::<Oracles>(),
            Err(OracleError::Unknown(w)) if w == "basecolor"
        ));
        assert!(matches!(
            "roughness,roughness".parse::<Oracles>(),
            Err(OracleError::Twice(Oracle::Roughness))
        ));
    }
}
