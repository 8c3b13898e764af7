//! Which views the networks see: every (position, lit capture) pair of the
//! scan that survives calibration's bad-light filter, narrowed by the user's
//! `--positions` and `--views`, plus the reference position whose camera
//! image every map is estimated in.
//!
//! The reference is the first selected position (in manifest order) whose
//! light is good, so it never depends on the order the user lists views in.
//! [`ViewSet::with_reference`] moves the same views into another usable
//! position's image (the pipeline's "every position as reference").
//! View order follows `--views` when given (manifest order otherwise); the
//! networks' max-fusion makes the fused maps independent of it.
//!
//! Out of scope: reading or warping photos (see `inputs`).

use matscan_calib::ScanCalibration;
use matscan_scan::Manifest;
use std::fmt;

/// The user's narrowing of the view set; empty lists select everything.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ViewFilter {
    /// Position names to use.
    pub positions: Vec<String>,
    /// Views to use: a capture name (that capture at every position) or
    /// `position/capture`.
    pub views: Vec<String>,
}

/// One view: a lit capture at a position.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct View {
    /// The position's name.
    pub position: String,
    /// The lit capture's name.
    pub capture: String,
    /// The light the capture switches on.
    pub light: String,
}

impl fmt::Display for View {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.position, self.capture)
    }
}

/// The selected views and the reference position.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ViewSet {
    /// The position every map is estimated in.
    pub reference: String,
    /// At least one view.
    pub views: Vec<View>,
    /// Why selected positions were left out (bad light).
    pub left_out: Vec<String>,
    /// Every selected position whose light is good, in manifest order (the
    /// positions that can serve as reference).
    pub usable: Vec<String>,
}

impl ViewSet {
    /// The same views estimated in the camera image of `position`, when it
    /// is usable.
    pub fn with_reference(&self, position: &str) -> Option<ViewSet> {
        self.usable.iter().any(|p| p == position).then(|| ViewSet {
            reference: position.to_string(),
            ..self.clone()
        })
    }
}

/// No usable view set.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ViewError {
    /// `--positions` names a position the manifest lacks.
    #[error("--positions: the scan has no position `{0}`")]
    UnknownPosition(String),
    /// `--views` names no lit capture of the selected positions.
    #[error("--views: `{0}` is no lit capture of the selected positions")]
    UnknownView(String),
    /// Every selected position failed the bad-light check.
    #[error("no usable position: {}", .0.join("; "))]
    NoUsablePosition(Vec<String>),
    /// The usable positions have no lit capture (one point light or the
    /// uniformly lit projector).
    #[error("no view to estimate from: the usable positions have no lit capture")]
    NoViews,
}

/// Selects the views of `manifest` that `filter` allows and calibration
/// finds usable.
pub fn select_views(
    manifest: &Manifest,
    calibration: &ScanCalibration,
    filter: &ViewFilter,
) -> Result<ViewSet, ViewError> {
    for name in &filter.positions {
        if manifest.position(name).is_none() {
            return Err(ViewError::UnknownPosition(name.clone()));
        }
    }
    let selected = manifest
        .positions
        .iter()
        .filter(|p| filter.positions.is_empty() || filter.positions.contains(&p.name));
    let mut usable = Vec::new();
    let mut left_out = Vec::new();
    for position in selected {
        let bad = calibration
            .position(&position.name)
            .and_then(|c| c.bad_light.reason());
        match bad {
            Some(reason) => left_out.push(reason),
            None => usable.push(position),
        }
    }
    let Some(reference) = usable.first().map(|p| p.name.clone()) else {
        return Err(ViewError::NoUsablePosition(left_out));
    };
    let all: Vec<View> = usable
        .iter()
        .flat_map(|p| {
            p.lit_captures().map(|(capture, light)| View {
                position: p.name.clone(),
                capture: capture.name.clone(),
                light,
            })
        })
        .collect();
    let views = if filter.views.is_empty() {
        all
    } else {
        let mut chosen: Vec<View> = Vec::new();
        for wanted in &filter.views {
            let matching: Vec<&View> = all
                .iter()
                .filter(|v| *wanted == v.capture || *wanted == v.to_string())
                .collect();
            if matching.is_empty() {
                return Err(ViewError::UnknownView(wanted.clone()));
            }
            for view in matching {
                if !chosen.contains(view) {
                    chosen.push(view.clone());
                }
            }
        }
        chosen
    };
    if views.is_empty() {
        return Err(ViewError::NoViews);
    }
    Ok(ViewSet {
        reference,
        views,
        left_out,
        usable: usable.iter().map(|p| p.name.clone()).collect(),
    })
}
