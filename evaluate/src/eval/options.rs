//! What an evaluation measures and on what, and what it reports.

use super::tables::GroupBy;
use std::path::PathBuf;
use std::str::FromStr;

/// What `matscan eval` measures, and on what.
#[derive(Clone, Debug)]
pub struct EvalOptions {
    /// Scan folders, or folders of them (see [`collect_scans`]).
    pub data: Vec<PathBuf>,
    /// Folder with `<param>.weights` per network; `None`: the embedded ones.
    pub weights: Option<PathBuf>,
    /// View counts to compare; 0 = every view.
    pub views: Vec<usize>,
    /// A set whose mean truth per parameter is the trivial baseline
    /// (`None`: the evaluated set's own mean).
    pub baseline_from: Option<PathBuf>,
    /// Evaluate at most this many scans (in name order).
    pub limit: Option<usize>,
    /// Rows of the per-group tables.
    pub group_by: GroupBy,
    /// Also tabulate each scene's run time beside its errors.
    pub per_scene: bool,
    /// Where each network's dependencies come from.
    pub dependencies: DependencySource,
    /// Also bake estimate and truth into UV textures of this many texels
    /// and score them in texture space and re-rendered.
    pub textures: Option<u32>,
    /// Who answers basecolor, roughness and metallic in the chained
    /// estimate (`None`: the estimator's default). The truth-fed protocol
    /// measures the networks alone and takes no method.
    pub method: Option<matscan_estimate::pipeline::method::Method>,
    /// Which light the physical fit explains (`None`: the fit's default).
    pub fit_light: Option<matscan_estimate::fit::FitLight>,
    /// Sets of truth pieces to feed the chained estimate, one budget row
    /// each beside the estimate as it is (see [`super::budget`]); empty:
    /// no budget.
    pub oracles: Vec<matscan_estimate::pipeline::oracle::Oracles>,
    /// A deliberate calibration error applied to every scan before it is
    /// estimated (the chained estimate only).
    pub rig_error: Option<super::rig_error::RigError>,
    /// Calibrated rig files that replace each scan's rig before it is
    /// estimated (the chained estimate only; see [`super::rig_from`]).
    pub rig_from: Option<std::path::PathBuf>,
}

impl EvalOptions {
    /// Where the networks' weights come from.
    pub fn models(&self) -> matscan_estimate::ModelSource {
        match &self.weights {
            Some(dir) => matscan_estimate::ModelSource::Dir(dir.clone()),
            None => matscan_estimate::ModelSource::Embedded,
        }
    }

    /// The chained estimate's options: this evaluation's method and fit
    /// light, the default calibration, maps of the reference position
    /// only, written to `out`.
    pub fn estimate_options(
        &self,
        out: PathBuf,
        filter: matscan_estimate::ViewFilter,
    ) -> matscan_estimate::EstimateOptions {
        matscan_estimate::EstimateOptions {
            out: Some(out),
            filter,
            method: self.method.unwrap_or_default(),
            fit: matscan_estimate::fit::FitOptions {
                light: self.fit_light.unwrap_or_default(),
                ..matscan_estimate::fit::FitOptions::default()
            },
            ..matscan_estimate::EstimateOptions::default()
        }
    }
}

/// The printed tables and the CSV of one evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct EvalReport {
    pub table: String,
    pub csv: String,
}

/// What the networks that read other parameters are fed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DependencySource {
    /// The other networks' estimates: the product's chained path (what
    /// `matscan estimate` does; the thesis's section 4.8).
    #[default]
    Estimated,
    /// The truth: each network on its own, as the thesis measured its
    /// Tables 4.1 to 4.3 (section 4.5); run time is the networks' alone.
    Truth,
}

impl DependencySource {
    /// The names `--dependencies` takes.
    pub const NAMES: &'static str = "estimated or truth";
}

impl FromStr for DependencySource {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "estimated" => Ok(DependencySource::Estimated),
            "truth" => Ok(DependencySource::Truth),
            other => Err(format!(
                "unknown dependency source `{other}`: expected {}",
                Self::NAMES
            )),
        }
    }
}
