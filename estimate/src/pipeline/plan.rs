//! What to do with each parameter, and in which order the networks run
//! (thesis figure 3.14).
//!
//! Every parameter ends as *estimated* (its network runs), *given* (the
//! user passed a constant or a map) or *skipped* with a reason: the scan
//! lacks the capture its network needs (no backlit capture, so no
//! transmission; no checker capture, so no subsurface), or nothing
//! requested needs it. A skipped parameter feeds its dependents
//! `Param::default_value`.
//!
//! What each network is fed ([`feeds`]): subsurface the effective
//! transmission (eq. 3.5, so transmission and metallic); roughness metallic
//! and the effective transmission and subsurface; basecolor metallic,
//! effective transmission, roughness and the roughness network's per-view
//! illumination. So when basecolor is estimated the roughness network runs
//! even if roughness is given; only its illumination is used then. Only
//! what a requested parameter needs is planned; the rest is skipped as not
//! needed.
//!
//! Out of scope: running the networks (see `pipeline`).

use matscan_scan::capture_list::NeededCapture;
use matscan_scan::Param;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::path::PathBuf;

/// A user-given value of a parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum Given {
    /// The same value everywhere, in [0, 1] (each channel for basecolor).
    Constant(f32),
    /// A float EXR in the reference camera's image (RGB for basecolor, the
    /// first channel otherwise).
    Map(PathBuf),
}

impl fmt::Display for Given {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Given::Constant(v) => write!(f, "{v}"),
            Given::Map(path) => write!(f, "{}", path.display()),
        }
    }
}

/// An invalid request.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// Not `param=value`.
    #[error("--given `{0}`: expected PARAM=VALUE or PARAM=FILE, e.g. transmission=0")]
    Syntax(String),
    /// Not one of the five parameters.
    #[error("unknown parameter `{0}`: expected one of metallic, transmission, subsurface, roughness, basecolor")]
    UnknownParam(String),
    /// A constant outside [0, 1].
    #[error("--given {param}={value}: a constant must lie in [0, 1]")]
    OutOfRange {
        /// The parameter.
        param: Param,
        /// The value.
        value: f32,
    },
    /// The same parameter given twice.
    #[error("--given {0} appears twice")]
    Twice(Param),
    /// `--only` with nothing in it.
    #[error("--only names no parameter")]
    EmptyOnly,
}

/// Parses a parameter name.
pub fn parse_param(name: &str) -> Result<Param, PlanError> {
    name.trim()
        .parse::<Param>()
        .ok()
        .ok_or_else(|| PlanError::UnknownParam(name.to_string()))
}

/// Parses `param=value` (a number in [0, 1]) or `param=file`.
pub fn parse_given(text: &str) -> Result<(Param, Given), PlanError> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| PlanError::Syntax(text.to_string()))?;
    let param = parse_param(name)?;
    let value = value.trim();
    if value.is_empty() {
        return Err(PlanError::Syntax(text.to_string()));
    }
    match value.parse::<f32>() {
        Ok(v) if v.is_finite() && (0.0..=1.0).contains(&v) => Ok((param, Given::Constant(v))),
        Ok(v) if v.is_finite() => Err(PlanError::OutOfRange { param, value: v }),
        _ => Ok((param, Given::Map(PathBuf::from(value)))),
    }
}

/// The parameters whose values `kind`'s network reads (not counting
/// illumination, which comes from the roughness network).
pub fn feeds(kind: Param) -> &'static [Param] {
    use Param as P;
    match kind {
        P::Metallic | P::Transmission => &[],
        P::Subsurface => &[P::Transmission, P::Metallic],
        P::Roughness => &[P::Metallic, P::Transmission, P::Subsurface],
        P::Basecolor => &[P::Metallic, P::Transmission, P::Roughness],
    }
}

/// Which captures the scan's views offer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Availability {
    /// Some view's position has a backlit capture.
    pub backlit: bool,
    /// Some view's position has a checker capture.
    pub checker: bool,
}

/// The decision for one parameter.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    /// Its network runs and its map is the result.
    Estimate,
    /// The user's value.
    Given(Given),
    /// Not estimated; dependents get `Param::default_value`.
    Skip {
        /// Why, for the user.
        reason: String,
    },
}

/// What runs, for one scan and one request.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    decisions: BTreeMap<Param, Decision>,
    requested: BTreeSet<Param>,
    networks: Vec<Vec<Param>>,
}

impl Plan {
    /// Plans `only` (every parameter when `None`) with `given` values.
    pub fn new(
        only: Option<&[Param]>,
        given: &[(Param, Given)],
        available: Availability,
    ) -> Result<Plan, PlanError> {
        let requested: BTreeSet<Param> = match only {
            Some([]) => return Err(PlanError::EmptyOnly),
            Some(list) => list.iter().copied().collect(),
            None => crate::net::spec::PIPELINE_ORDER.into_iter().collect(),
        };
        let mut given_map = BTreeMap::new();
        for (kind, value) in given {
            if given_map.insert(*kind, value.clone()).is_some() {
                return Err(PlanError::Twice(*kind));
            }
        }
        let missing = |kind: Param| -> Option<&'static str> {
            match kind.needs() {
                Some(NeededCapture::Backlit) if !available.backlit => {
                    Some("no backlit capture (lights = [\"backlight\"]) among the views' positions")
                }
                Some(NeededCapture::Checker) if !available.checker => {
                    Some("no checker capture (the projector with a checker pattern) among the views' positions")
                }
                _ => None,
            }
        };
        // Walk from the requested parameters through what running networks read.
        let mut needed = BTreeSet::new();
        let mut networks = BTreeSet::new();
        let mut stack: Vec<Param> = requested.iter().copied().collect();
        while let Some(kind) = stack.pop() {
            if !needed.insert(kind) {
                continue;
            }
            let runs = !given_map.contains_key(&kind) && missing(kind).is_none();
            if runs {
                networks.insert(kind);
                stack.extend(feeds(kind));
                if kind == Param::Basecolor {
                    // Basecolor reads the roughness network's illumination.
                    networks.insert(Param::Roughness);
                    stack.extend(feeds(Param::Roughness));
                }
            }
        }
        let mut decisions = BTreeMap::new();
        for kind in crate::net::spec::PIPELINE_ORDER {
            let decision = if let Some(value) = given_map.get(&kind) {
                Decision::Given(value.clone())
            } else if !needed.contains(&kind) {
                Decision::Skip {
                    reason: "not requested (--only) and no requested parameter needs it"
                        .to_string(),
                }
            } else if let Some(reason) = missing(kind) {
                Decision::Skip {
                    reason: format!("{reason}; dependents use {}", kind.default_value()),
                }
            } else {
                Decision::Estimate
            };
            decisions.insert(kind, decision);
        }
        Ok(Plan {
            decisions,
            requested,
            networks: stages(&networks),
        })
    }

    /// The decision for `kind`.
    pub fn decision(&self, kind: Param) -> &Decision {
        // Every kind is decided in `new`.
        &self.decisions[&kind]
    }

    /// Whether the user asked for `kind` (all, without `--only`).
    pub fn is_requested(&self, kind: Param) -> bool {
        self.requested.contains(&kind)
    }

    /// The networks to run, in stages: every network of a stage depends only
    /// on earlier stages, so a stage's networks may run concurrently.
    pub fn stages(&self) -> &[Vec<Param>] {
        &self.networks
    }

    /// Every network that runs.
    pub fn networks(&self) -> impl Iterator<Item = Param> + '_ {
        self.networks.iter().flatten().copied()
    }
}

/// Groups `networks` by depth in the dependency graph.
fn stages(networks: &BTreeSet<Param>) -> Vec<Vec<Param>> {
    let mut depth: BTreeMap<Param, usize> = BTreeMap::new();
    // crate::net::spec::PIPELINE_ORDER lists every network after what it reads.
    for kind in crate::net::spec::PIPELINE_ORDER {
        if !networks.contains(&kind) {
            continue;
        }
        let mut reads: Vec<Param> = feeds(kind).to_vec();
        if kind == Param::Basecolor {
            reads.push(Param::Roughness);
        }
        let d = reads
            .iter()
            .filter_map(|r| depth.get(r))
            .map(|d| d + 1)
            .max()
            .unwrap_or(0);
        depth.insert(kind, d);
    }
    let levels = depth.values().max().map_or(0, |d| d + 1);
    (0..levels)
        .map(|level| {
            crate::net::spec::PIPELINE_ORDER
                .into_iter()
                .filter(|k| depth.get(k) == Some(&level))
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use Param as P;

    const ALL_CAPTURES: Availability = Availability {
        backlit: true,
        checker: true,
    };

    #[test]
    fn a_full_scan_runs_the_graph_of_figure_3_14() {
        let plan = Plan::new(None, &[], ALL_CAPTURES).unwrap();
        assert_eq!(
            plan.stages(),
            &[
                vec![P::Metallic, P::Transmission],
                vec![P::Subsurface],
                vec![P::Roughness],
                vec![P::Basecolor]
            ]
        );
        for kind in crate::net::spec::PIPELINE_ORDER {
            assert_eq!(plan.decision(kind), &Decision::Estimate);
        }
    }

    #[test]
    fn only_roughness_runs_what_roughness_reads() {
        let plan = Plan::new(Some(&[P::Roughness]), &[], ALL_CAPTURES).unwrap();
        let run: Vec<P> = plan.networks().collect();
        assert_eq!(
            run,
            vec![P::Metallic, P::Transmission, P::Subsurface, P::Roughness]
        );
        assert!(
            matches!(plan.decision(P::Basecolor), Decision::Skip { reason } if reason.contains("not requested"))
        );
        let plan = Plan::new(Some(&[P::Metallic]), &[], ALL_CAPTURES).unwrap();
        assert_eq!(plan.networks().collect::<Vec<_>>(), vec![P::Metallic]);
    }

    #[test]
    fn a_given_parameter_runs_no_network_and_cuts_its_inputs() {
        let given = [(P::Transmission, Given::Constant(0.0))];
        let plan = Plan::new(Some(&[P::Subsurface]), &given, ALL_CAPTURES).unwrap();
        assert_eq!(plan.stages(), &[vec![P::Metallic], vec![P::Subsurface]]);
        assert_eq!(
            plan.decision(P::Transmission),
            &Decision::Given(Given::Constant(0.0))
        );
    }

    #[test]
    fn given_roughness_still_runs_its_network_for_basecolors_illumination() {
        let given = [(P::Roughness, Given::Constant(0.3))];
        let plan = Plan::new(Some(&[P::Basecolor]), &given, ALL_CAPTURES).unwrap();
        assert!(plan.networks().any(|k| k == P::Roughness));
        assert_eq!(
            plan.decision(P::Roughness),
            &Decision::Given(Given::Constant(0.3))
        );
    }

    #[test]
    fn missing_captures_skip_with_the_reason() {
        let none = Availability {
            backlit: false,
            checker: false,
        };
        let plan = Plan::new(None, &[], none).unwrap();
        assert!(
            matches!(plan.decision(P::Transmission), Decision::Skip { reason } if reason.contains("no backlit capture"))
        );
        assert!(
            matches!(plan.decision(P::Subsurface), Decision::Skip { reason } if reason.contains("no checker capture"))
        );
        assert_eq!(
            plan.stages(),
            &[vec![P::Metallic], vec![P::Roughness], vec![P::Basecolor]]
        );
    }

    #[test]
    fn given_values_parse_as_constants_or_files() {
        assert_eq!(
            parse_given("transmission=0").unwrap(),
            (P::Transmission, Given::Constant(0.0))
        );
        assert_eq!(
            parse_given("roughness=map.exr").unwrap(),
            (P::Roughness, Given::Map(PathBuf::from("map.exr")))
        );
        assert!(matches!(
            parse_given("metallic=1.5"),
            Err(PlanError::OutOfRange { .. })
        ));
        assert!(matches!(
            parse_given("sheen=0"),
            Err(PlanError::UnknownParam(_))
        ));
        assert!(matches!(parse_given("metallic"), Err(PlanError::Syntax(_))));
        let twice = [
            (P::Metallic, Given::Constant(0.0)),
            (P::Metallic, Given::Constant(1.0)),
        ];
        assert_eq!(
            Plan::new(None, &twice, ALL_CAPTURES),
            Err(PlanError::Twice(P::Metallic))
        );
    }
}
