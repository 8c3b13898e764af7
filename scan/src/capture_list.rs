//! The photos a rig takes at each position, in the order it takes them
//! (thesis section 3.1.4; docs/scan-format.md): the ambient scene, each
//! flash alone, the projector's uniform grey, the backlight panel alone,
//! and two checkerboards; and which parameter only one kind of photo
//! measures. The daemon's capture plan, the simulated rig's bundle writer
//! and the estimator's plan read it here, so a capture the plan drops is
//! exactly one the estimate then skips.

use crate::param::Param;
use std::fmt;

/// The projector's level in the uniform capture (the thesis's grey image).
pub const UNIFORM_LEVEL: f32 = 0.5;

/// One kind of photo of a position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaptureKind {
    /// Every rig light off: what the others are differences to.
    Ambient,
    /// Flash `index` alone at full power.
    Flash(usize),
    /// The projector alone, uniformly at [`UNIFORM_LEVEL`].
    Uniform,
    /// The backlight panel alone.
    Backlit,
    /// The projector showing a full-contrast checkerboard of
    /// `period_px` projector pixels.
    Checker { period_px: u32 },
}

impl CaptureKind {
    /// The capture's name in the manifest and its file stem.
    pub fn name(self) -> String {
        self.to_string()
    }

    /// The one parameter only this kind of photo serves (see
    /// [`Param::needs`]); `None`: every parameter's network reads it.
    pub fn only_for(self) -> Option<Param> {
        Param::ALL
            .into_iter()
            .find(|p| p.needs().is_some_and(|n| n.is(self)))
    }

    /// Lit by a flash or the uniform projector: a view of the networks.
    pub fn is_view(self) -> bool {
        matches!(self, CaptureKind::Flash(_) | CaptureKind::Uniform)
    }
}

impl fmt::Display for CaptureKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CaptureKind::Ambient => f.write_str("ambient"),
            CaptureKind::Flash(i) => write!(f, "flash{i}"),
            CaptureKind::Uniform => f.write_str("projector"),
            CaptureKind::Backlit => f.write_str("backlight"),
            CaptureKind::Checker { period_px } => write!(f, "checker_{period_px}"),
        }
    }
}

/// Every photo of a position with `flashes` flashes and the small and
/// large checkerboard periods `checkers`, in the order taken.
pub fn position_captures(flashes: usize, checkers: (u32, u32)) -> Vec<CaptureKind> {
    let mut out = vec![CaptureKind::Ambient];
    out.extend((0..flashes).map(CaptureKind::Flash));
    out.push(CaptureKind::Uniform);
    out.push(CaptureKind::Backlit);
    for period_px in [checkers.0, checkers.1] {
        out.push(CaptureKind::Checker { period_px });
    }
    out
}

impl Param {
    /// The photo a parameter's network needs beyond the lit views, by its
    /// role in a manifest: transmission a backlit capture, subsurface a
    /// checkerboard; `None` for the others.
    pub fn needs(self) -> Option<NeededCapture> {
        match self {
            Param::Transmission => Some(NeededCapture::Backlit),
            Param::Subsurface => Some(NeededCapture::Checker),
            _ => None,
        }
    }
}

/// A kind of capture a parameter cannot do without (see [`Param::needs`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NeededCapture {
    Backlit,
    Checker,
}

impl NeededCapture {
    /// Whether `kind` is such a capture.
    pub fn is(self, kind: CaptureKind) -> bool {
        matches!(
            (self, kind),
            (NeededCapture::Backlit, CaptureKind::Backlit)
                | (NeededCapture::Checker, CaptureKind::Checker { .. })
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_position_takes_the_thesis_captures_in_order() {
        let names: Vec<String> = position_captures(2, (8, 32))
            .into_iter()
            .map(CaptureKind::name)
            .collect();
        assert_eq!(
            names,
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
    }

    #[test]
    fn only_the_backlit_photo_and_the_checkers_serve_one_parameter() {
        for kind in position_captures(2, (8, 32)) {
            let only = kind.only_for();
            match kind {
                CaptureKind::Backlit => assert_eq!(only, Some(Param::Transmission)),
                CaptureKind::Checker { .. } => assert_eq!(only, Some(Param::Subsurface)),
                _ => assert_eq!(only, None),
            }
            // What a parameter needs is exactly what serves only it.
            for param in Param::ALL {
                let needed = param.needs().is_some_and(|n| n.is(kind));
                assert_eq!(needed, only == Some(param), "{kind} {param}");
            }
        }
    }
}
