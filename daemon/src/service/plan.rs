//! The capture plan: which photos to take at each position, from a profile
//! (which parameters are given rather than estimated) and what the rig has.
//! Captures nobody will use or the rig cannot take are left out, each with
//! the reason: no backlit photo when transmission is given or the rig has
//! no backlight panel, no checkerboards when subsurface is given, no
//! projector photos on a rig without a projector. The estimator then skips
//! the parameters those photos would have served, with its own reason.
//!
//! Boundaries: pure data; the sequencer (`super::sequencer`) carries it
//! out.

use super::config::Profile;
use matscan_drivers::{Checker, Level, LightId};
use matscan_scan::capture_list::{position_captures, CaptureKind, UNIFORM_LEVEL};
use std::num::NonZeroU32;

/// What the rig does for one photo (on top of the ambient scene).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Step {
    /// Every rig light off, the projector black.
    Ambient,
    /// One flash alone at full power.
    Flash(LightId),
    /// The projector alone, uniformly at `level` (the thesis's grey image).
    ProjectorUniform(Level),
    /// The backlight panel alone.
    Backlit,
    /// The projector showing a checkerboard.
    Checker(Checker),
}

impl Step {
    /// Whether the photo must differ from ambient (a rig light is on).
    pub fn is_lit(&self) -> bool {
        !matches!(self, Step::Ambient)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct PlannedCapture {
    /// The capture's name in the manifest and its file stem.
    pub name: String,
    pub step: Step,
}

/// The photos of one position, in the order they are taken, and what was
/// left out.
#[derive(Debug, Clone, PartialEq)]
pub struct CapturePlan {
    pub captures: Vec<PlannedCapture>,
    /// One line per left-out capture kind, saying why.
    pub left_out: Vec<String>,
}

/// What the rig has beyond its camera and two flashes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Capabilities {
    pub projector: bool,
    /// The projector shows the plan's checkerboards exactly (a
    /// LightCrafter's test-pattern generator shows uniform levels only).
    pub checkers: bool,
    pub backlight: bool,
}

impl Capabilities {
    /// Projector and backlight panel: every capture of the thesis.
    pub const FULL: Capabilities = Capabilities {
        projector: true,
        checkers: true,
        backlight: true,
    };
}

/// The checkerboard photographed for `period`: full contrast, no shift.
pub fn checker_of(period: NonZeroU32) -> Checker {
    Checker {
        period_px: period,
        phase_px: [0, 0],
        low: Level::ZERO,
        high: Level::FULL,
    }
}

/// The plan for `profile` on a rig with `rig`; `checker_periods` are the
/// small and large checkerboard periods in projector pixels (even, at
/// least 2). The photos are the contract's (`matscan_scan::capture_list`),
/// less those the rig cannot take or nobody needs.
pub fn plan(
    profile: &Profile,
    checker_periods: (NonZeroU32, NonZeroU32),
    rig: Capabilities,
) -> CapturePlan {
    let (small, large) = checker_periods;
    let mut captures = Vec::new();
    let mut left_out: Vec<String> = Vec::new();
    for kind in position_captures(FLASHES.len(), (small.get(), large.get())) {
        match left_out_reason(kind, profile, rig) {
            Some(reason) => {
                if !left_out.contains(&reason) {
                    left_out.push(reason);
                }
            }
            None => captures.push(PlannedCapture {
                name: kind.name(),
                step: step_of(kind),
            }),
        }
    }
    CapturePlan { captures, left_out }
}

/// The flashes of every rig, in capture order.
const FLASHES: [LightId; 2] = [LightId::Flash0, LightId::Flash1];

/// What the rig does for a photo of `kind`.
fn step_of(kind: CaptureKind) -> Step {
    match kind {
        CaptureKind::Ambient => Step::Ambient,
        CaptureKind::Flash(i) => Step::Flash(FLASHES[i.min(FLASHES.len() - 1)]),
        CaptureKind::Uniform => {
            Step::ProjectorUniform(Level::new(UNIFORM_LEVEL).unwrap_or(Level::FULL))
        }
        CaptureKind::Backlit => Step::Backlit,
        CaptureKind::Checker { period_px } => Step::Checker(checker_of(
            NonZeroU32::new(period_px).unwrap_or(NonZeroU32::MIN),
        )),
    }
}

/// Why a photo of `kind` is not taken (one line per kind of photo), or
/// `None` when it is.
fn left_out_reason(kind: CaptureKind, profile: &Profile, rig: Capabilities) -> Option<String> {
    let given = kind.only_for().filter(|p| profile.given.contains(p));
    match kind {
        CaptureKind::Ambient | CaptureKind::Flash(_) => None,
        CaptureKind::Uniform => {
            (!rig.projector).then(|| "projector: this rig has no projector".to_string())
        }
        CaptureKind::Backlit => match given {
            Some(p) => Some(format!("backlight: {p} is given")),
            None if !rig.backlight => Some(
                "backlight: this rig has no backlight panel (transmission cannot be estimated)"
                    .to_string(),
            ),
            None => None,
        },
        CaptureKind::Checker { .. } => match given {
            Some(p) => Some(format!("checkerboards: {p} is given")),
            None if !rig.projector => Some(
                "checkerboards: this rig has no projector (subsurface cannot be estimated)"
                    .to_string(),
            ),
            None if !rig.checkers => Some(
                "checkerboards: the projector cannot show them exactly (subsurface cannot be \
                 estimated; drive it over DRM/KMS to show checkers)"
                    .to_string(),
            ),
            None => None,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use matscan_scan::Param;

    fn periods() -> (NonZeroU32, NonZeroU32) {
        (NonZeroU32::new(8).unwrap(), NonZeroU32::new(32).unwrap())
    }

    fn names(p: &CapturePlan) -> Vec<&str> {
        p.captures.iter().map(|c| c.name.as_str()).collect()
    }

    #[test]
    fn full_profile_takes_every_capture_ambient_first() {
        let p = plan(&Profile::default(), periods(), Capabilities::FULL);
        assert_eq!(
            names(&p),
            [
                "ambient",
                "flash0",
                "flash1",
                "projector",
                "backlight",
                "checker_8",
                "checker_32"
            ]
        );
        assert!(p.left_out.is_empty());
        assert!(!p.captures[0].step.is_lit());
        assert!(p.captures[1..].iter().all(|c| c.step.is_lit()));
    }

    #[test]
    fn given_transmission_drops_the_backlit_photo_and_given_subsurface_the_checkers() {
        let given = |ps: &[Param]| Profile {
            given: ps.iter().copied().collect(),
        };
        let p = plan(
            &given(&[Param::Transmission]),
            periods(),
            Capabilities::FULL,
        );
        assert!(!names(&p).contains(&"backlight"));
        assert!(names(&p).contains(&"checker_8"));
        assert_eq!(p.left_out, ["backlight: transmission is given"]);

        let p = plan(
            &given(&[Param::Subsurface, Param::Transmission]),
            periods(),
            Capabilities::FULL,
        );
        assert_eq!(names(&p), ["ambient", "flash0", "flash1", "projector"]);
        assert_eq!(p.left_out.len(), 2);

        let p = plan(&given(&[Param::Roughness]), periods(), Capabilities::FULL);
        assert_eq!(p.captures.len(), 7, "lit captures serve every parameter");
    }

    #[test]
    fn a_rig_without_projector_or_backlight_drops_their_photos_with_the_reason() {
        let no_projector = Capabilities {
            projector: false,
            checkers: false,
            backlight: true,
        };
        let p = plan(&Profile::default(), periods(), no_projector);
        assert_eq!(names(&p), ["ambient", "flash0", "flash1", "backlight"]);
        assert_eq!(
            p.left_out,
            [
                "projector: this rig has no projector",
                "checkerboards: this rig has no projector (subsurface cannot be estimated)"
            ]
        );
        let bare = Capabilities {
            projector: false,
            checkers: false,
            backlight: false,
        };
        let p = plan(&Profile::default(), periods(), bare);
        assert_eq!(names(&p), ["ambient", "flash0", "flash1"]);
        assert!(
            p.left_out[1].contains("no backlight panel"),
            "{:?}",
            p.left_out
        );
        // A given parameter's reason wins: nobody needs the photo anyway.
        let given = Profile {
            given: [Param::Transmission].into_iter().collect(),
        };
        let p = plan(&given, periods(), bare);
        assert!(p
            .left_out
            .contains(&"backlight: transmission is given".to_string()));
    }

    #[test]
    fn a_projector_without_exact_checkers_keeps_the_uniform_photo_and_drops_the_checkers() {
        let uniform_only = Capabilities {
            checkers: false,
            ..Capabilities::FULL
        };
        let p = plan(&Profile::default(), periods(), uniform_only);
        assert_eq!(
            names(&p),
            ["ambient", "flash0", "flash1", "projector", "backlight"]
        );
        assert_eq!(p.left_out.len(), 1);
        assert!(
            p.left_out[0].starts_with("checkerboards: the projector cannot show them exactly"),
            "{:?}",
            p.left_out
        );
    }
}
